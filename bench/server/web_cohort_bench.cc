// web_cohort_bench: the latency of the supervisors' trainee list (with each
// trainee's curriculum progress) and group (cohort) page at 10,000 stored
// sessions and 200 trainees (docs/server.md, "Web pages at scale").
// One in-process ves-server (SQLite, loopback HTTP), the store seeded
// directly: 200 trainees in groups of --group-size (20), 50 sessions each
// over 50 days, every fourth a lesson attempt of a 5-lesson curriculum
// assigned to every group, with its verdict. Timed, each request on a new
// connection, one at a time: GET /api/v1/trainees?page_size=500 (what
// trainees.html asks), GET /api/v1/groups/{g}/cohort (all dates, and a
// 14-day range), the group's CSV, a trainee's report, and last the cohort
// page of one group holding every trainee.
// Usage: web_cohort_bench [--trainees N] [--sessions N] [--group-size N] [--requests R]
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "bench/server/bench_server.h"
#include "bench/server/web_latency.h"
#include "patient_db/store.h"
#include "server/auth.h"
#include "server/server.h"
#include "ves/v1/lesson.pb.h"

namespace {

using Clock = std::chrono::steady_clock;
constexpr int64_t kDay = 24 * 3600 * 1000;
constexpr int64_t kStart = 1'700'006'400'000;

bool Seed(ves::patient_db::Store& store, int trainees, int per_trainee, int group_size) {
  store.AddInstitution("north", 1);
  ves::v1::Curriculum c;
  c.set_curriculum_id("basics");
  c.set_title("Basics");
  ves::patient_db::CurriculumRow curriculum{"basics", "north", "Basics", {}, "bench", 1, "", ""};
  for (int l = 0; l < 5; ++l) {
    ves::v1::Lesson* lesson = c.add_lessons();
    lesson->set_lesson_id("lesson-" + std::to_string(l));
    lesson->set_title("Lesson " + std::to_string(l));
    lesson->set_required_passes(1);
    curriculum.lesson_ids.push_back(lesson->lesson_id());
  }
  curriculum.body = c.SerializeAsString();
  curriculum.body_sha256_hex = ves::server::Sha256Hex(curriculum.body);
  if (!store.PutCurriculum(curriculum).ok()) return false;
  std::mt19937_64 rng(11);
  for (int t = 0; t < trainees; ++t) {
    const std::string id = "trainee-" + std::to_string(t);
    const std::string group = "group-" + std::to_string(t / group_size);
    if (!store.AddTrainee({id, "north", "Trainee " + std::to_string(t), 1}).ok()) return false;
    if (!store.SetTraineeGroup(id, group).ok()) return false;
    if (t % group_size == 0 && !store.AddAssignment({"basics", true, group, "north", "bench", 1}).ok()) {
      return false;
    }
    ves::patient_db::WriteBatch batch;
    std::vector<ves::patient_db::LessonVerdictRow> verdicts;
    for (int s = 0; s < per_trainee; ++s) {
      ves::patient_db::SessionRow row;
      char uuid[40];
      std::snprintf(uuid, sizeof uuid, "%08x-0000-4000-8000-%012llx", t,
                    static_cast<unsigned long long>(s));
      row.uuid = uuid;
      row.trainee_id = id;
      row.institution = "north";
      row.case_id = s % 2 ? "standard-adult" : "redundant-sigmoid";
      row.case_version = 1;
      row.station_id = "station-1";
      row.start_unix_ms = kStart + kDay * s + 60'000 * t;
      row.end_unix_ms = row.start_unix_ms + 600'000;
      row.completed = rng() % 4 != 0;
      row.outcome = row.completed ? 1 : 3;
      row.time_to_cecum_s = row.completed ? 100 + static_cast<double>(rng() % 4000) / 10.0 : 0;
      row.score = static_cast<double>(rng() % 1000) / 10.0;
      row.pain_s = static_cast<double>(rng() % 300) / 10.0;
      row.loop_s = static_cast<double>(rng() % 600) / 10.0;
      row.xray_s = static_cast<double>(rng() % 100) / 10.0;
      row.operator_kind = "human";
      if (s % 4 == 3) row.lesson_id = "lesson-" + std::to_string((s / 4) % 5);
      row.body = "bench session " + row.uuid;  // the pages timed here never read bodies
      row.body_sha256_hex = ves::server::Sha256Hex(row.body);
      row.stored_unix_ms = row.end_unix_ms;
      if (!row.lesson_id.empty()) {
        verdicts.push_back({row.uuid, id, "basics", row.lesson_id, row.score >= 40, row.score,
                            row.start_unix_ms, row.end_unix_ms, "score ok", false});
      }
      batch.sessions.push_back(std::move(row));
    }
    if (!store.CommitBatch(batch).ok()) return false;
    for (const auto& v : verdicts) {
      if (!store.PutLessonVerdict(v).ok()) return false;
    }
  }
  return true;
}

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Times `requests` GETs over `targets` and prints p50/p99/max and the
// process CPU per request (server and client: what a busy machine cannot
// hide, unlike the wall-clock figures).
void Time(const char* what, const std::vector<std::string>& targets, int port,
          const std::string& token, int requests) {
  const double cpu0 = CpuSeconds();
  const ves::bench::LatencyStats s = ves::bench::MeasureGets(targets, port, token, requests);
  const double cpu_ms = 1000 * (CpuSeconds() - cpu0) / requests;
  std::printf("  %-40s p50 %7.2f ms  p99 %7.2f ms  max %7.2f ms  CPU %5.2f ms/req  (%d)\n",
              what, s.p50_ms, s.p99_ms, s.max_ms, cpu_ms, requests);
}

}  // namespace

int main(int argc, char** argv) {
  int trainees = 200, total_sessions = 10000, group_size = 20, requests = 200;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--trainees")) trainees = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--sessions")) total_sessions = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--group-size")) group_size = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--requests")) requests = std::atoi(argv[i + 1]);
  }
  if (trainees < 1 || trainees > 10000 || total_sessions < trainees ||
      total_sessions > 1'000'000 || group_size < 1 || group_size > trainees || requests < 10 ||
      requests > 100'000) {
    std::fprintf(stderr,
                 "web_cohort_bench: --trainees 1..10000, --sessions trainees..1000000, "
                 "--group-size 1..trainees, --requests 10..100000\n");
    return 2;
  }
  const int per_trainee = total_sessions / trainees;
  const auto dir = ves::bench::ScratchDir("ves-web-cohort-bench-");
  auto server = ves::bench::LoopbackServer(dir, /*http=*/true);
  const auto t_seed = Clock::now();
  if (!Seed(server->store(), trainees, per_trainee, group_size)) {
    std::fprintf(stderr, "web_cohort_bench: cannot seed the store\n");
    return 1;
  }
  const std::string token = ves::server::NewToken();
  server->store().AddToken({ves::server::Sha256Hex(token),
                            ves::patient_db::StoreRole::kSupervisor, "north", "", "bench", 1});
  const double seed_s = std::chrono::duration<double>(Clock::now() - t_seed).count();
  server->Start();
  const int port = server->http_port();

  const int groups = (trainees + group_size - 1) / group_size;
  std::vector<std::string> cohort, cohort_range, csv, report;
  const std::string range = "from_unix_ms=" + std::to_string(kStart + 20 * kDay) +
                            "&to_unix_ms=" + std::to_string(kStart + 34 * kDay);
  for (int g = 0; g < groups; ++g) {
    const std::string base = "/api/v1/groups/group-" + std::to_string(g);
    cohort.push_back(base + "/cohort");
    cohort_range.push_back(base + "/cohort?" + range);
    csv.push_back(base + "/sessions.csv?" + range);
  }
  for (int t = 0; t < trainees; ++t) {
    report.push_back("/api/v1/trainees/trainee-" + std::to_string(t) + "/report");
  }
  std::printf("web_cohort_bench: %d sessions (%d trainees x %d, groups of %d) stored in %.1f s\n",
              trainees * per_trainee, trainees, per_trainee, group_size, seed_s);
  ves::bench::MeasureGets(cohort, port, token, 10);  // warm the caches
  const std::vector<std::string> list = {"/api/v1/trainees?page_size=500"};
  char what[96];
  std::snprintf(what, sizeof what, "GET trainees (list of %d, progress)", trainees);
  Time(what, list, port, token, requests);
  std::snprintf(what, sizeof what, "GET groups/{g}/cohort (%d trainees)", group_size);
  Time(what, cohort, port, token, requests);
  Time("GET groups/{g}/cohort (14 days)", cohort_range, port, token, requests);
  Time("GET groups/{g}/sessions.csv (14 days)", csv, port, token, requests);
  Time("GET trainees/{id}/report", report, port, token, requests);
  // Then every trainee in one group: the largest cohort page an institution
  // of this size can ask for (the store's reads per page, not per trainee).
  for (int t = 0; t < trainees; ++t) {
    server->store().SetTraineeGroup("trainee-" + std::to_string(t), "everyone");
  }
  server->store().AddAssignment({"basics", true, "everyone", "north", "bench", 1});
  const std::vector<std::string> everyone = {"/api/v1/groups/everyone/cohort"};
  ves::bench::MeasureGets(everyone, port, token, 10);
  std::snprintf(what, sizeof what, "GET groups/{g}/cohort (all %d trainees)", trainees);
  Time(what, everyone, port, token, requests);
  server->Shutdown(std::chrono::milliseconds(0));
  server.reset();
  std::filesystem::remove_all(dir);
  return 0;
}
