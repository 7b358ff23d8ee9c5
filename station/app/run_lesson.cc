#include "station/app/run_lesson.h"

#include <chrono>
#include <filesystem>
#include <ostream>
#include <thread>

#include "patient_db/case_bundle.h"
#include "station/sync/lesson_client.h"
#include "station/training/lesson_gate.h"

namespace ves::station {
namespace {

std::string Short(const std::string& sha) { return sha.substr(0, 16); }

void PrintVerdict(const ves::v1::LessonVerdict& v, std::ostream& out) {
  out << "server verdict (replayed): lesson " << v.lesson_id() << " session " << v.session_uuid()
      << ": " << (v.passed() ? "PASSED" : v.rejected() ? "REJECTED" : "FAILED")
      << " score=" << v.score() << "\n";
  for (const auto& c : v.checks()) out << "  " << c << "\n";
}

}  // namespace

LessonPlan ObtainNextLesson(const std::optional<sync::ServerEndpoint>& endpoint,
                            const std::string& trainee_id, sync::LessonCache& cache,
                            std::ostream& log) {
  std::optional<ves::v1::GetNextLessonResponse> next;
  bool from_server = false;
  if (endpoint) {
    try {
      next = sync::FetchNextLesson(*endpoint, trainee_id);
      cache.PutNext(trainee_id, *next);
      from_server = true;
    } catch (const sync::LessonCallError& error) {
      if (error.code() != grpc::StatusCode::UNAVAILABLE &&
          error.code() != grpc::StatusCode::DEADLINE_EXCEEDED) {
        throw LessonRefused(std::string("the server refused: ") + error.what());
      }
      log << "ves-station run: could not ask " << endpoint->address << " for the next lesson ("
          << error.what() << "); trying the offline lesson cache\n";
    }
  }
  if (!next) next = cache.FindNext(trainee_id);
  if (!next) {
    throw LessonRefused("no lesson for trainee '" + trainee_id + "' in the offline cache" +
                        (endpoint ? " and the server did not answer"
                                  : " (no --server given; run once with the server first)"));
  }
  if (!next->available()) {
    throw LessonRefused("no lesson to run for trainee '" + trainee_id + "': " + next->note());
  }
  LessonPlan plan;
  plan.lesson = next->lesson();
  plan.curriculum_id = next->curriculum_id();
  plan.curriculum_title = next->curriculum_title();
  plan.number = next->lesson_number();
  plan.count = next->lesson_count();
  plan.passes = next->passes();
  plan.from_server = from_server;
  return plan;
}

ObtainedCase ObtainLessonCase(const std::optional<sync::ServerEndpoint>& endpoint,
                              const ves::v1::Lesson& lesson, sync::CaseCache& cache,
                              std::ostream& log) {
  const ves::v1::CaseRef& ref = lesson.case_ref();
  const std::string& want = ref.payload_sha256_hex();
  const std::string what = "lesson '" + lesson.lesson_id() + "': case '" + ref.case_id() +
                           "' v" + std::to_string(ref.version()) + " (sha256 " + Short(want) + "…)";
  ObtainedCase obtained;
  const auto path = cache.dir() / (want + ".vescase");
  if (!std::filesystem::exists(path) && endpoint) {
    try {
      const sync::CachedCase got = sync::DownloadCaseToCache(*endpoint, ref.case_id(), cache);
      obtained.from_server = true;
      if (got.sha256_hex != want) {
        log << "ves-station run: the server's latest '" << ref.case_id() << "' has sha256 "
            << Short(got.sha256_hex) << "…, not the lesson's " << Short(want) << "…\n";
      }
    } catch (const std::exception& error) {
      log << "ves-station run: could not get case '" << ref.case_id() << "' from "
          << endpoint->address << " (" << error.what() << ")\n";
    }
  }
  if (!std::filesystem::exists(path)) {
    throw LessonRefused(what + " is not in the offline cache" +
                        (endpoint ? " and the server has no case with that hash" : "") +
                        "; refusing to start the lesson");
  }
  try {
    obtained.colon_case = cache.Load(want);  // decodes, checks the embedded and the file's hash
  } catch (const std::exception& error) {
    throw LessonRefused(what + " fails verification (" + error.what() +
                        "); refusing to start the lesson");
  }
  const std::string got = patient_db::CasePayloadSha256Hex(obtained.colon_case);
  if (got != want) {
    throw LessonRefused(what + ": the cached case hashes to " + Short(got) +
                        "…; refusing to start the lesson");
  }
  obtained.entry = {obtained.colon_case.id(), obtained.colon_case.version(),
                    obtained.colon_case.title(), want, path};
  return obtained;
}

void PrintLessonBrief(const LessonPlan& plan, double time_limit_s, std::ostream& out) {
  const ves::v1::Lesson& l = plan.lesson;
  out << "lesson " << plan.number << "/" << plan.count << " of curriculum '"
      << plan.curriculum_id << "': " << l.lesson_id() << " — " << l.title() << " ("
      << (plan.from_server ? "from the server" : "offline lesson cache") << ")\n";
  if (!l.description().empty()) out << "  " << l.description() << "\n";
  out << "  case " << l.case_ref().case_id() << " v" << l.case_ref().version() << ", scope "
      << l.scope().id() << ", time limit " << time_limit_s << " s\n";
  out << "  aids: fluoroscopy " << (l.aids().fluoroscopy_allowed() ? "allowed" : "OFF")
      << ", wireframe view " << (l.aids().wireframe_allowed() ? "allowed" : "OFF") << "\n";
  out << "  to pass (" << plan.passes << "/" << l.required_passes() << " passes so far):\n";
  for (const std::string& c : training::DescribePassCriteria(l)) out << "    - " << c << "\n";
}

training::InputSample ApplyLessonAids(const ves::v1::LessonAids& aids,
                                      training::InputSample sample) {
  if (!aids.fluoroscopy_allowed()) sample.fluoroscopy_on = false;
  if (!aids.wireframe_allowed() && sample.view_mode == training::ViewMode::kWireframe) {
    sample.view_mode = training::ViewMode::kFlat;
  }
  return sample;
}

void PrintStationVerdict(const ves::v1::Lesson& lesson, const ves::v1::SessionRecord& record,
                         bool wireframe_used, std::ostream& out) {
  const training::GateResult gate =
      training::CheckLessonGate(lesson, record.metrics(), record.score(), wireframe_used);
  out << "station verdict: lesson " << lesson.lesson_id() << ": "
      << (gate.passed ? "PASSED" : "FAILED")
      << " (the server's verdict, from its replay, is the one that counts)\n";
  for (const auto& c : gate.checks) out << "  " << c << "\n";
}

int CollectServerVerdicts(const sync::ServerEndpoint& endpoint, sync::LessonCache& cache,
                          const std::string& wait_for_uuid, double wait_s, std::ostream& out) {
  int arrived = 0;
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<int64_t>(wait_s * 1e3));
  for (const sync::AwaitedVerdict& awaited : cache.Awaited()) {
    for (;;) {
      std::optional<ves::v1::LessonVerdict> verdict;
      try {
        verdict = sync::FetchLessonVerdict(endpoint, awaited.session_uuid);
      } catch (const sync::LessonCallError& error) {
        if (error.code() == grpc::StatusCode::UNAVAILABLE ||
            error.code() == grpc::StatusCode::DEADLINE_EXCEEDED) {
          out << "server verdicts: " << endpoint.address << " unreachable; "
              << cache.Awaited().size() << " still awaited\n";
          return arrived;
        }
        // NOT_FOUND: not uploaded yet (still in the outbox); ask again later.
        break;
      }
      if (verdict) {
        cache.PutVerdict(*verdict);
        PrintVerdict(*verdict, out);
        ++arrived;
        break;
      }
      const bool waiting = wait_for_uuid == "*" || awaited.session_uuid == wait_for_uuid;
      if (!waiting || std::chrono::steady_clock::now() > deadline) {
        out << "server verdict for session " << awaited.session_uuid
            << ": still being judged (replay); `ves-station sync` fetches it later\n";
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
  return arrived;
}

}  // namespace ves::station
