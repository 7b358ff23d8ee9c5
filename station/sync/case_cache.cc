#include "station/sync/case_cache.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "patient_db/case_bundle.h"
#include "patient_db/case_problem.h"
#include "patient_db/case_validate.h"

namespace ves::sync {
namespace {

constexpr const char* kBundleExtension = ".vescase";

std::string ReadWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string() + ": " + std::strerror(errno));
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Writes `bytes` to `path` durably: temp file, fsync, rename, fsync of the folder.
void WriteFileDurably(const std::filesystem::path& path, const std::string& bytes) {
  const std::filesystem::path temp = path.string() + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write " + temp.string() + ": " + std::strerror(errno));
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const std::string reason = std::strerror(errno);
      ::close(fd);
      std::filesystem::remove(temp);
      throw std::runtime_error("cannot write " + temp.string() + ": " + reason);
    }
    written += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    std::filesystem::remove(temp);
    throw std::runtime_error("cannot flush " + temp.string() + ": " + std::strerror(errno));
  }
  std::filesystem::rename(temp, path);
  const int dir_fd = ::open(path.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
}

CachedCase EntryFor(const ves::v1::ColonCase& colon_case, const std::string& sha,
                    const std::filesystem::path& path) {
  return CachedCase{colon_case.id(), colon_case.version(), colon_case.title(), sha, path};
}

}  // namespace

CaseCache::CaseCache(std::filesystem::path dir) : dir_(std::move(dir)) {
  std::error_code error;
  std::filesystem::create_directories(dir_, error);
  if (error) {
    throw std::runtime_error("case cache: cannot create " + dir_.string() + ": " + error.message());
  }
}

CachedCase CaseCache::Put(const ves::v1::ColonCase& colon_case) {
  const auto problems = patient_db::ValidateCase(colon_case, "case " + colon_case.id());
  if (!problems.empty()) throw patient_db::CaseError(problems);
  const std::string sha = patient_db::CasePayloadSha256Hex(colon_case);
  const auto path = dir_ / (sha + kBundleExtension);
  if (!std::filesystem::exists(path)) {
    WriteFileDurably(path, patient_db::EncodeCaseBundle(colon_case));
  }
  return EntryFor(colon_case, sha, path);
}

CachedCase CaseCache::ImportBundleFile(const std::filesystem::path& bundle_path) {
  const auto colon_case =
      patient_db::DecodeCaseBundle(ReadWholeFile(bundle_path), bundle_path.string());
  return Put(colon_case);
}

ves::v1::ColonCase CaseCache::Load(const std::string& sha256_hex) const {
  const auto path = dir_ / (sha256_hex + kBundleExtension);
  if (!std::filesystem::exists(path)) {
    throw std::runtime_error("case " + sha256_hex + " is not in the cache at " + dir_.string());
  }
  auto colon_case = patient_db::DecodeCaseBundle(ReadWholeFile(path), path.string());
  const std::string actual = patient_db::CasePayloadSha256Hex(colon_case);
  if (actual != sha256_hex) {
    throw patient_db::CaseError({patient_db::CaseProblem{
        path.string(), "file name", -1, actual,
        "payload hash does not match the file's content address " + sha256_hex}});
  }
  return colon_case;
}

std::vector<CachedCase> CaseCache::List(std::vector<std::string>* damaged) const {
  std::vector<CachedCase> entries;
  for (const auto& file : std::filesystem::directory_iterator(dir_)) {
    if (file.path().extension() != kBundleExtension) continue;
    const std::string sha = file.path().stem().string();
    try {
      entries.push_back(EntryFor(Load(sha), sha, file.path()));
    } catch (const std::exception& error) {
      if (damaged) damaged->push_back(error.what());
    }
  }
  std::sort(entries.begin(), entries.end(), [](const CachedCase& a, const CachedCase& b) {
    return a.id != b.id ? a.id < b.id : a.version < b.version;
  });
  return entries;
}

std::optional<CachedCase> CaseCache::FindLatest(const std::string& case_id) const {
  std::optional<CachedCase> latest;
  for (auto& entry : List()) {
    if (entry.id == case_id && (!latest || entry.version > latest->version)) latest = entry;
  }
  return latest;
}

CachedCase CaseCache::Resolve(const std::string& id_or_sha) const {
  if (std::filesystem::exists(dir_ / (id_or_sha + kBundleExtension))) {
    return EntryFor(Load(id_or_sha), id_or_sha, dir_ / (id_or_sha + kBundleExtension));
  }
  if (auto latest = FindLatest(id_or_sha)) return *latest;
  throw std::runtime_error("no cached case '" + id_or_sha + "' in " + dir_.string());
}

CachedCase CaseCache::ExportBundleFile(const std::string& id_or_sha,
                                       const std::filesystem::path& out) const {
  const CachedCase entry = Resolve(id_or_sha);
  WriteFileDurably(out, patient_db::EncodeCaseBundle(Load(entry.sha256_hex)));
  return entry;
}

}  // namespace ves::sync
