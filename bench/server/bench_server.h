#pragma once

#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include "patient_db/case_bundle.h"
#include "patient_db/store.h"
#include "server/auth.h"
#include "server/server.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/session.pb.h"

// What the server benches set up alike (server_bench, replica_bench,
// live_bench, web_bench, web_cohort_bench): a scratch directory, an
// in-process server on loopback and a stored case.
namespace ves::bench {

// `prefix` + this process's id under the temporary directory, created.
inline std::filesystem::path ScratchDir(const std::string& prefix) {
  const auto dir = std::filesystem::temp_directory_path() / (prefix + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

// An in-process ves-server on a SQLite store in `dir`, listening on loopback
// ports the system picks (gRPC, and HTTP too when `http`); not started.
inline std::unique_ptr<ves::server::VesServer> LoopbackServer(const std::filesystem::path& dir,
                                                              bool http) {
  ves::server::ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.insecure_loopback = true;
  options.log_calls = false;
  if (http) options.http_listen = "127.0.0.1:0";
  return std::make_unique<ves::server::VesServer>(
      options, ves::patient_db::OpenStore("sqlite:" + (dir / "ves.db").string()));
}

// Stores `colon_case` for `institution` as its upload would; returns the
// bundle stored.
inline std::string PutBenchCase(ves::patient_db::Store& store, const ves::v1::ColonCase& colon_case,
                                const std::string& institution) {
  const std::string bundle = ves::patient_db::EncodeCaseBundle(colon_case);
  ves::patient_db::CaseRow row;
  row.case_id = colon_case.id();
  row.version = colon_case.version();
  row.institution = institution;
  row.sha256_hex = ves::server::Sha256Hex(bundle);
  row.payload_sha256_hex = ves::patient_db::CasePayloadSha256Hex(colon_case);
  store.PutCase(row, bundle);
  return bundle;
}

// The part of a benchmark's session record every server bench fills alike:
// a scripted trainee's 300 s run of the standard case that reached the cecum
// at 200 s, started at `start_unix_ms`.
inline ves::v1::SessionRecord BenchRecord(const std::string& uuid, int64_t start_unix_ms) {
  ves::v1::SessionRecord r;
  r.set_uuid(uuid);
  r.set_trainee_id("bench-trainee");
  r.set_case_id("standard-adult");
  r.set_case_version(1);
  r.set_station_id("bench-station");
  r.set_start_unix_ms(start_unix_ms);
  r.set_end_unix_ms(r.start_unix_ms() + 300'000);
  r.set_outcome(ves::v1::OUTCOME_CECUM_REACHED);
  r.mutable_metrics()->set_duration_s(300);
  r.mutable_metrics()->set_completed(true);
  r.mutable_metrics()->set_time_to_cecum_s(200);
  return r;
}

}  // namespace ves::bench
