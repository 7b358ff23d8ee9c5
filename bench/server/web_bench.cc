// web_bench: the web API's latency for a supervisor's trainee page in an
// institution with 10,000 stored sessions (docs/server.md, docs/web.md).
// One in-process ves-server (SQLite, loopback HTTP); 100 trainees in groups
// of 10, 100 sessions each. A trainee page is what trainee.html asks for:
// GET /api/v1/trainees/{id}/curve (per case and lesson, with the group's
// median) and GET /api/v1/trainees/{id}/sessions; the trainee list page
// (GET /api/v1/trainees: every trainee's last activity) is timed apart, as
// are a trainee's CSV export (100 sessions) and the audit page (an admin's
// newest 50 of 100,000 rows, and a filter that matches none of them).
// Each request on a new connection, one at a time; p50/p99 over --requests.
// Usage: web_bench [--sessions N] [--requests R]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "bench/server/web_latency.h"
#include "patient_db/store.h"
#include "server/auth.h"
#include "server/server.h"
#include "station/training/input_log.h"

namespace {

using Clock = std::chrono::steady_clock;

using Stats = ves::bench::LatencyStats;
constexpr auto Measure = ves::bench::MeasureGets;

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace

int main(int argc, char** argv) {
  int total_sessions = 10000;
  int requests = 500;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--sessions")) total_sessions = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--requests")) requests = std::atoi(argv[i + 1]);
  }
  if (total_sessions < 100 || requests < 10) {
    std::fprintf(stderr, "web_bench: --sessions must be >= 100 and --requests >= 10\n");
    return 2;
  }
  const int trainees = 100;
  const int per_trainee = total_sessions / trainees;
  const auto dir =
      std::filesystem::temp_directory_path() / ("ves-web-bench-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  ves::server::ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.insecure_loopback = true;
  options.log_calls = false;
  options.http_listen = "127.0.0.1:0";
  auto server = std::make_unique<ves::server::VesServer>(
      options, ves::patient_db::OpenStore("sqlite:" + (dir / "ves.db").string()));
  auto& store = server->store();
  store.AddInstitution("north", 1);

  // A stored body as a station uploads it: metrics and a ~1 KiB input log.
  std::vector<ves::training::InputSample> samples(1000);
  for (size_t i = 0; i < samples.size(); ++i) samples[i].tick = i;
  const ves::v1::InputLog log = ves::training::MakeInputLog(samples, 0.001);
  std::mt19937_64 rng(5);
  const auto t_seed = Clock::now();
  for (int t = 0; t < trainees; ++t) {
    const std::string id = "trainee-" + std::to_string(t);
    store.AddTrainee({id, "north", "Trainee " + std::to_string(t), 1});
    store.SetTraineeGroup(id, "group-" + std::to_string(t / 10));
    ves::patient_db::WriteBatch batch;
    for (int s = 0; s < per_trainee; ++s) {
      ves::v1::SessionRecord rec;
      char uuid[40];
      std::snprintf(uuid, sizeof uuid, "%08x-0000-4000-8000-%012llx", t,
                    static_cast<unsigned long long>(s));
      rec.set_uuid(uuid);
      rec.set_trainee_id(id);
      rec.set_case_id(s % 2 ? "standard-adult" : "redundant-sigmoid");
      rec.set_case_version(1);
      rec.set_start_unix_ms(1'700'000'000'000 + 3'600'000LL * s);
      rec.set_end_unix_ms(rec.start_unix_ms() + 600'000);
      rec.set_score(static_cast<double>(rng() % 1000) / 10.0);
      rec.mutable_metrics()->set_pain_s(static_cast<double>(rng() % 100) / 10.0);
      rec.mutable_metrics()->set_loop_s(static_cast<double>(rng() % 100) / 10.0);
      *rec.mutable_input_log() = log;
      ves::patient_db::SessionRow row;
      row.uuid = rec.uuid();
      row.trainee_id = id;
      row.institution = "north";
      row.case_id = rec.case_id();
      row.case_version = 1;
      row.station_id = "station-1";
      row.start_unix_ms = rec.start_unix_ms();
      row.end_unix_ms = rec.end_unix_ms();
      row.score = rec.score();
      row.pain_s = rec.metrics().pain_s();
      row.body = rec.SerializeAsString();
      row.body_sha256_hex = ves::server::Sha256HexOf(row.body);
      row.stored_unix_ms = 1;
      batch.sessions.push_back(std::move(row));
    }
    if (!store.CommitBatch(batch).ok()) {
      std::fprintf(stderr, "web_bench: cannot store the sessions\n");
      return 1;
    }
  }
  // An audit log of a busy server: 100,000 rows of 50 actors, one row in a
  // thousand another action (all tok-0's), so a filter for that action and
  // another actor matches nothing: the page scans every row.
  {
    ves::patient_db::WriteBatch audit;
    for (int i = 0; i < 100'000; ++i) {
      const std::string actor = "tok-" + std::to_string(i % 50);
      audit.audit.push_back({0, 1'700'000'000'000 + i, actor, "Dr " + actor, "supervisor", "north",
                             i % 1000 == 0 ? "session.export" : "session.read",
                             "trainee-" + std::to_string(i % trainees), "OK"});
    }
    if (!store.CommitBatch(audit).ok()) {
      std::fprintf(stderr, "web_bench: cannot store the audit rows\n");
      return 1;
    }
  }
  const std::string token = ves::server::NewToken();
  store.AddToken({ves::server::Sha256HexOf(token), ves::patient_db::StoreRole::kSupervisor, "north",
                  "", "bench supervisor", 1});
  const std::string admin = ves::server::NewToken();
  store.AddToken({ves::server::Sha256HexOf(admin), ves::patient_db::StoreRole::kAdmin, "north", "",
                  "bench admin", 1});
  const double seed_s = std::chrono::duration<double>(Clock::now() - t_seed).count();
  server->Start();
  const int port = server->http_port();

  std::vector<std::string> page, curve, sessions, list = {"/api/v1/trainees?page_size=500"}, csv;
  const std::vector<std::string> audit_newest = {"/api/v1/audit?page_size=50"},
                                 audit_rare = {
                                     "/api/v1/audit?page_size=50&action=session.export"
                                     "&actor=Dr%20tok-7"};
  for (int t = 0; t < trainees; ++t) {
    const std::string id = "trainee-" + std::to_string(t);
    csv.push_back("/api/v1/trainees/" + id + "/sessions.csv");
    curve.push_back("/api/v1/trainees/" + id + "/curve");
    sessions.push_back("/api/v1/trainees/" + id + "/sessions?page_size=500");
    page.push_back(curve.back());
    page.push_back(sessions.back());
  }
  std::printf("web_bench: %d sessions (%d trainees x %d, groups of 10) stored in %.1f s\n",
              trainees * per_trainee, trainees, per_trainee, seed_s);
  Measure(page, port, token, 20);  // warm the caches
  const double cpu0 = CpuSeconds();
  const auto wall0 = Clock::now();
  const Stats c = Measure(curve, port, token, requests);
  const Stats s = Measure(sessions, port, token, requests);
  const Stats l = Measure(list, port, token, std::max(10, requests / 10));
  const Stats x = Measure(csv, port, token, requests);
  const Stats an = Measure(audit_newest, port, admin, std::max(10, requests / 10));
  const Stats ar = Measure(audit_rare, port, admin, std::max(10, requests / 10));
  const double cpu = CpuSeconds() - cpu0;
  const double wall = std::chrono::duration<double>(Clock::now() - wall0).count();
  std::printf(
      "  GET trainees/{id}/curve     p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms  (%d requests)\n",
      c.p50_ms, c.p99_ms, c.max_ms, requests);
  std::printf(
      "  GET trainees/{id}/sessions  p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms  (%d requests)\n",
      s.p50_ms, s.p99_ms, s.max_ms, requests);
  std::printf(
      "  GET trainees (list, 100)    p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms  (%d requests)\n",
      l.p50_ms, l.p99_ms, l.max_ms, std::max(10, requests / 10));
  std::printf(
      "  GET trainees/{id}/sessions.csv  p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms  (%d requests)\n",
      x.p50_ms, x.p99_ms, x.max_ms, requests);
  std::printf(
      "  GET audit (newest 50 of 100k)  p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms  (%d requests)\n",
      an.p50_ms, an.p99_ms, an.max_ms, std::max(10, requests / 10));
  std::printf(
      "  GET audit (actor+action, none of 100k match)  p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms"
      "  (%d requests)\n",
      ar.p50_ms, ar.p99_ms, ar.max_ms, std::max(10, requests / 10));
  std::printf("  process CPU (server and client) %.1f s over %.1f s wall\n", cpu, wall);
  server->Shutdown(std::chrono::milliseconds(0));
  server.reset();
  std::filesystem::remove_all(dir);
  return 0;
}
