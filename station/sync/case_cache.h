#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "ves/v1/case.pb.h"

namespace ves::sync {

struct CachedCase {
  std::string id;
  uint32_t version{0};
  std::string title;
  std::string sha256_hex;  // content address (patient_db::CasePayloadSha256Hex)
  std::filesystem::path path;
};

// The station's offline case library: one case bundle per file, named by the
// SHA-256 of its payload (`<sha256>.vescase`). Every read decodes the bundle,
// which checks its embedded hash and validates the case, and checks that the
// name matches the payload, so a damaged or swapped file is refused before a
// run can use it. Writes go to a temporary file that is fsynced and renamed,
// so a station killed mid-write never leaves a half case behind.
class CaseCache {
 public:
  explicit CaseCache(std::filesystem::path dir);

  // Validates and stores the case; returns its entry (same case twice: one file).
  CachedCase Put(const ves::v1::ColonCase& colon_case);
  // Imports a bundle file (the paper's CD-ROM). A damaged, truncated or
  // foreign file throws patient_db::CaseError naming the file and the fault;
  // nothing is stored then.
  CachedCase ImportBundleFile(const std::filesystem::path& bundle_path);
  // Writes the cached case with this id (latest version) or content address
  // to `out` as a bundle; throws std::runtime_error when it is not cached.
  CachedCase ExportBundleFile(const std::string& id_or_sha, const std::filesystem::path& out) const;

  // Loads and verifies a cached case by content address; throws
  // std::runtime_error if absent, patient_db::CaseError if damaged.
  ves::v1::ColonCase Load(const std::string& sha256_hex) const;
  // The newest cached version of a case id, or nullopt.
  std::optional<CachedCase> FindLatest(const std::string& case_id) const;
  // Every readable entry, by id then version. Damaged files are skipped and
  // reported in `damaged` when given.
  std::vector<CachedCase> List(std::vector<std::string>* damaged = nullptr) const;

  const std::filesystem::path& dir() const { return dir_; }

 private:
  CachedCase Resolve(const std::string& id_or_sha) const;

  std::filesystem::path dir_;
};

}  // namespace ves::sync
