#include "server/lesson_judge.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <optional>

#include "patient_db/case_bundle.h"
#include "server/services.h"
#include "server/session_replay.h"
#include "server/session_series.h"
#include "station/training/lesson_gate.h"
#include "ves/v1/session.pb.h"

namespace ves::server {
namespace {

using patient_db::StoreCode;
using patient_db::StoreStatus;

std::string JoinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += (out.empty() ? "" : "\n") + l;
  return out;
}

}  // namespace

LessonJudge::LessonJudge(patient_db::Store* store, training::JudgeBudget budget,
                         SessionSeries* series)
    : store_(store), budget_(budget), series_(series) {}

LessonJudge::~LessonJudge() { Stop(); }

void LessonJudge::Start() {
  auto pending = store_->ListUnjudgedLessonSessions("", 100000);
  if (!pending.ok()) {
    spdlog::error("lesson judge: cannot list unjudged sessions: {}", pending.status.message);
  } else {
    if (!pending.value.empty()) {
      spdlog::info("lesson judge: {} stored lesson session(s) wait for a verdict",
                   pending.value.size());
    }
    for (const std::string& uuid : pending.value) Enqueue(uuid);
  }
  thread_ = std::thread([this] { Loop(); });
}

void LessonJudge::Enqueue(const std::string& session_uuid,
                          std::shared_ptr<const CheckedRecord> record) {
  {
    std::lock_guard lock(mutex_);
    if (!queued_.insert(session_uuid).second) return;
    queue_.push_back(session_uuid);
    held_.Hold(session_uuid, std::move(record));
  }
  wake_.notify_one();
}

void LessonJudge::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cancel_ = true;
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

uint64_t LessonJudge::judged() const {
  std::lock_guard lock(mutex_);
  return judged_;
}

uint64_t LessonJudge::series_recorded() const { return series_recorded_.load(); }

void LessonJudge::Loop() {
  for (;;) {
    std::string uuid;
    std::shared_ptr<const CheckedRecord> held;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      // Left in the queue on stop: still without a verdict in the store, so
      // the next start queues them again.
      if (stopping_) return;
      uuid = queue_.front();
      queue_.pop_front();
      held = held_.Take(uuid);
    }
    const auto start = std::chrono::steady_clock::now();
    auto verdict = held ? Judge(uuid, held->record(), held) : JudgeStored(uuid);
    const double ms = std::chrono::duration<double, std::milli>(
                          std::chrono::steady_clock::now() - start).count();
    if (verdict.ok()) {
      spdlog::info("lesson judge: session {} lesson {}: {} (score {:.1f}, replay {:.0f} ms)", uuid,
                   verdict.value.lesson_id,
                   verdict.value.passed ? "PASSED"
                   : verdict.value.rejected ? "REJECTED"
                                            : "FAILED",
                   verdict.value.score, ms);
    } else {
      spdlog::error("lesson judge: session {}: {}", uuid, verdict.status.message);
    }
    std::lock_guard lock(mutex_);
    queued_.erase(uuid);
    ++judged_;
  }
}

patient_db::StoreResult<ves::v1::ColonCase> LessonJudge::LessonCase(const ves::v1::Lesson& lesson) {
  const std::string& sha = lesson.case_ref().payload_sha256_hex();
  {
    std::lock_guard lock(cases_mutex_);
    auto it = cases_.find(sha);
    if (it != cases_.end()) return it->second;
  }
  auto row = store_->GetCase(lesson.case_ref().case_id(), lesson.case_ref().version());
  if (!row.ok()) return row.status;
  auto blob = store_->GetBlob(row.value.sha256_hex);
  if (!blob.ok()) return blob.status;
  ves::v1::ColonCase colon_case;
  try {
    colon_case = patient_db::DecodeCaseBundle(blob.value, "stored case " + row.value.case_id);
  } catch (const std::exception& error) {
    return StoreStatus::Error(StoreCode::kInternal, error.what());
  }
  if (patient_db::CasePayloadSha256Hex(colon_case) != sha) {
    return StoreStatus::Error(StoreCode::kInternal, "stored case " + row.value.case_id +
                                                        " does not match the lesson's hash");
  }
  std::lock_guard lock(cases_mutex_);
  cases_[sha] = colon_case;
  return colon_case;
}

patient_db::StoreResult<patient_db::LessonVerdictRow> LessonJudge::JudgeStored(
    const std::string& session_uuid) {
  auto stored = store_->GetSession(session_uuid);
  if (!stored.ok()) return stored.status;
  ves::v1::SessionRecord record;
  if (!record.ParseFromString(stored.value.body)) {
    return StoreStatus::Error(StoreCode::kInternal, "stored session is corrupt");
  }
  return Judge(session_uuid, record, nullptr);
}

patient_db::StoreResult<patient_db::LessonVerdictRow> LessonJudge::Judge(
    const std::string& session_uuid, const ves::v1::SessionRecord& record,
    std::shared_ptr<const CheckedRecord> held) {
  patient_db::LessonVerdictRow v;
  v.session_uuid = session_uuid;
  v.trainee_id = record.trainee_id();
  v.lesson_id = record.lesson_id();
  v.session_start_unix_ms = record.start_unix_ms();
  std::vector<std::string> checks;
  // The session page's series, recorded from the judged replay.
  std::string series_json;
  auto curriculum_id = store_->FindLessonCurriculum(record.lesson_id());
  ves::v1::Curriculum curriculum;
  const ves::v1::Lesson* lesson = nullptr;
  if (curriculum_id.ok()) {
    auto row = store_->GetCurriculum(curriculum_id.value);
    if (!row.ok()) return row.status;
    if (!curriculum.ParseFromString(row.value.body)) {
      return StoreStatus::Error(StoreCode::kInternal, "stored curriculum is corrupt");
    }
    v.curriculum_id = curriculum.curriculum_id();
    for (const auto& l : curriculum.lessons()) {
      if (l.lesson_id() == record.lesson_id()) lesson = &l;
    }
  } else if (curriculum_id.status.code != StoreCode::kNotFound) {
    return curriculum_id.status;
  }
  if (lesson == nullptr) {
    // A verdict all the same, so the session is not judged again and again.
    checks.push_back("lesson '" + record.lesson_id() + "' is not on this server: FAILED");
  } else {
    auto colon_case = LessonCase(*lesson);
    if (!colon_case.ok()) return colon_case.status;  // stays unjudged; retried on restart
    // Counted durably before the replay: a record whose replay kills the
    // server is not replayed forever on every restart.
    auto starts = store_->AddJudgeStarts(session_uuid, 1);
    if (!starts.ok()) return starts.status;
    training::GateResult gate;
    if (starts.value > kMaxJudgeStarts) {
      gate.checks.push_back("rejected: its replay was started " +
                            std::to_string(starts.value - 1) +
                            " times and never finished (the server stopped during it)");
      gate.rejected = true;
    } else {
      // Its step is checked by the judge before any replayed step reaches the
      // recorder; a zero step would give the recorder no rate.
      std::optional<ReplayRecorder> recorder;
      const SeriesRates rates = SeriesRatesFor(record.input_log());
      if (record.input_log().dt_s() > 0) {
        recorder.emplace(record.input_log(), rates.series_hz, rates.shape_hz, kSeriesShapePoints);
      }
      std::optional<training::RunResult> replayed;
      try {
        gate = training::JudgeLessonSession(
            *lesson, colon_case.value, record, &cancel_, budget_,
            [&](const training::InputSample&, const training::SessionRunner& runner) {
              if (recorder) recorder->OnStep(runner);
            },
            &replayed);
        if (recorder && replayed) {
          series_json = SeriesJsonText(session_uuid, recorder->Finish(*replayed), rates);
        }
      } catch (const training::JudgeCancelled& cancelled) {
        store_->AddJudgeStarts(session_uuid, -1);  // a clean stop is not a failed start
        return StoreStatus::Error(StoreCode::kInternal, cancelled.what());  // judged next start
      }
    }
    v.passed = gate.passed;
    v.score = gate.score;
    v.rejected = gate.rejected;
    checks = gate.checks;
  }
  v.detail = JoinLines(checks);
  v.judged_unix_ms = NowUnixMs();
  // Stored before the verdict: a page that sees the verdict finds the plots.
  if (!series_json.empty()) {
    const StoreStatus stored =
        store_->PutSessionSeries({session_uuid, kSeriesFormatVersion, NowUnixMs(), series_json});
    if (stored.ok()) {
      ++series_recorded_;
    } else {
      spdlog::warn("lesson judge: series of {} not stored: {}", session_uuid, stored.message);
      series_json.clear();
    }
  }
  if (series_json.empty() && series_ != nullptr) series_->Enqueue(session_uuid, std::move(held));
  auto put = store_->PutLessonVerdict(v);
  if (!put.ok()) return put.status;
  if (!put.value) return store_->GetLessonVerdict(session_uuid);  // judged before: that one stands
  return v;
}

}  // namespace ves::server
