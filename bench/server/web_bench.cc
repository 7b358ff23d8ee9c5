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
// A session page's first load (docs/web.md, "Session series"): a scripted
// session of --session-seconds (600: ten minutes) stored as an upload is,
// its series computed by the server's background worker (timed), then
// --page-loads loads of everything session.html asks for, one after another
// on new connections: the page, its scripts and style, chart.js, the session and
// its series.
// Usage: web_bench [--sessions N] [--requests R] [--session-seconds S] [--page-loads P]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/server/bench_server.h"
#include "bench/server/web_latency.h"
#include "patient_db/case_format.h"
#include "patient_db/store.h"
#include "server/auth.h"
#include "server/server.h"
#include "server/session_series.h"
#include "station/training/case_run.h"
#include "station/training/input_log.h"
#include "tests/server/web_client.h"

namespace {

using Clock = std::chrono::steady_clock;

using Stats = ves::bench::LatencyStats;
constexpr auto Measure = ves::bench::MeasureGets;

// One row of the latency table.
void PrintRow(const char* label, const Stats& stats, int requests) {
  std::printf("  %s  p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms  (%d requests)\n", label,
              stats.p50_ms, stats.p99_ms, stats.max_ms, requests);
}

// One load of a session page: what session.html asks for, one after another
// (a browser asks some of them at once: this is the slower case).
Stats MeasurePage(const std::vector<std::string>& targets, int port, const std::string& token,
                  int loads, size_t* bytes) {
  std::vector<double> ms;
  for (int i = 0; i < loads; ++i) {
    const auto start = Clock::now();
    *bytes = 0;
    for (const std::string& target : targets) {
      const auto r = ves::server::testing::HttpCall(port, "GET", target,
                                                    {{"Authorization", "Bearer " + token}});
      if (r.status != 200) {
        std::fprintf(stderr, "web_bench: %s answered %d: %.300s\n", target.c_str(), r.status,
                     r.body.c_str());
        std::exit(1);
      }
      *bytes += r.body.size();
    }
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms[std::min(ms.size() - 1, ms.size() * 99 / 100)], ms.back()};
}

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace

int main(int argc, char** argv) {
  int total_sessions = 10000;
  int requests = 500;
  double session_seconds = 600;
  int page_loads = 100;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--sessions")) total_sessions = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--requests")) requests = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--session-seconds")) session_seconds = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--page-loads")) page_loads = std::atoi(argv[i + 1]);
  }
  if (total_sessions < 100 || total_sessions > 1'000'000 || requests < 10 || requests > 100'000 ||
      !(session_seconds >= 1 && session_seconds <= 3600) || page_loads < 10 ||
      page_loads > 10'000) {
    std::fprintf(stderr,
                 "web_bench: --sessions must be 100..1000000, --requests 10..100000, "
                 "--session-seconds 1..3600 and --page-loads 10..10000\n");
    return 2;
  }
  const int trainees = 100;
  const int per_trainee = total_sessions / trainees;
  const auto dir = ves::bench::ScratchDir("ves-web-bench-");
  auto server = ves::bench::LoopbackServer(dir, /*http=*/true);
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
      row.body_sha256_hex = ves::server::Sha256Hex(row.body);
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
  store.AddToken({ves::server::Sha256Hex(token), ves::patient_db::StoreRole::kSupervisor, "north",
                  "", "bench supervisor", 1});
  const std::string admin = ves::server::NewToken();
  store.AddToken({ves::server::Sha256Hex(admin), ves::patient_db::StoreRole::kAdmin, "north", "",
                  "bench admin", 1});
  const double seed_s = std::chrono::duration<double>(Clock::now() - t_seed).count();

  // A long session as a station records it (the novice: it seldom reaches
  // the cecum, so the session runs to its time limit).
  const auto t_run = Clock::now();
  ves::v1::SessionRecord long_session;
  const auto colon_case = ves::patient_db::LoadCaseFile(
      std::filesystem::path(VES_SOURCE_DIR) / "patient_db/cases/standard-adult.textproto");
  ves::training::RunScriptedCase(colon_case, ves::v1::EndoscopeSpec(), {}, "novice",
                                 session_seconds, 1'700'000'000'000, &long_session);
  long_session.set_trainee_id("trainee-0");
  long_session.set_station_id("station-1");
  const double run_s = std::chrono::duration<double>(Clock::now() - t_run).count();
  {
    ves::patient_db::SessionRow row;
    row.uuid = long_session.uuid();
    row.trainee_id = "trainee-0";
    row.institution = "north";
    row.case_id = colon_case.id();
    row.case_version = colon_case.version();
    row.station_id = "station-1";
    row.start_unix_ms = long_session.start_unix_ms();
    row.end_unix_ms = long_session.end_unix_ms();
    row.body = long_session.SerializeAsString();
    row.body_sha256_hex = ves::server::Sha256Hex(row.body);
    row.stored_unix_ms = 1;
    ves::patient_db::WriteBatch batch;
    batch.sessions.push_back(std::move(row));
    if (!store.CommitBatch(batch).ok()) {
      std::fprintf(stderr, "web_bench: cannot store the long session\n");
      return 1;
    }
  }
  server->Start();
  const int port = server->http_port();
  // What an upload does once the session is durable: the worker computes it.
  const auto t_series = Clock::now();
  server->series().Enqueue(long_session.uuid());
  while (!store.GetSessionSeries(long_session.uuid()).ok()) {
    if (Clock::now() - t_series > std::chrono::minutes(10)) {
      std::fprintf(stderr, "web_bench: no series within 10 minutes\n");
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const double series_s = std::chrono::duration<double>(Clock::now() - t_series).count();
  const double duration_s =
      long_session.input_log().sample_count() * long_session.input_log().dt_s();
  std::printf(
      "web_bench: a %.0f s session (%.0f KB stored; recorded in %.1f s), its series computed in "
      "the background in %.1f s (%.0f KB)\n",
      duration_s, long_session.ByteSizeLong() / 1e3, run_s, series_s,
      store.GetSessionSeries(long_session.uuid()).value.json.size() / 1e3);

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
  const std::string uuid = long_session.uuid();
  size_t page_bytes = 0;
  const Stats sp = MeasurePage({"/session.html?uuid=" + uuid, "/common.js", "/style.css",
                                "/chart.js", "/stations.js", "/session.js", "/workflow.js",
                                "/api/v1/sessions/" + uuid, "/api/v1/sessions/" + uuid + "/series"},
                               port, token, page_loads, &page_bytes);
  size_t series_bytes = 0;
  const Stats ss =
      MeasurePage({"/api/v1/sessions/" + uuid + "/series"}, port, token, page_loads, &series_bytes);
  const double cpu = CpuSeconds() - cpu0;
  const double wall = std::chrono::duration<double>(Clock::now() - wall0).count();
  const int list_requests = std::max(10, requests / 10);
  PrintRow("GET trainees/{id}/curve   ", c, requests);
  PrintRow("GET trainees/{id}/sessions", s, requests);
  PrintRow("GET trainees (list, 100)  ", l, list_requests);
  PrintRow("GET trainees/{id}/sessions.csv", x, requests);
  PrintRow("GET audit (newest 50 of 100k)", an, list_requests);
  PrintRow("GET audit (actor+action, none of 100k match)", ar, list_requests);
  std::printf(
      "  session page, first load (6 requests, %.0f KB)  p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms"
      "  (%d loads)\n",
      page_bytes / 1e3, sp.p50_ms, sp.p99_ms, sp.max_ms, page_loads);
  std::printf(
      "  GET sessions/{uuid}/series (%.0f KB)  p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms"
      "  (%d requests)\n",
      series_bytes / 1e3, ss.p50_ms, ss.p99_ms, ss.max_ms, page_loads);
  std::printf("  process CPU (server and client) %.1f s over %.1f s wall\n", cpu, wall);
  server->Shutdown(std::chrono::milliseconds(0));
  server.reset();
  std::filesystem::remove_all(dir);
  return 0;
}
