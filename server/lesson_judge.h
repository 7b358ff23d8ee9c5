#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "patient_db/store.h"
#include "server/checked_record.h"
#include "station/training/lesson_gate.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/lesson.pb.h"

// The server's lesson judge (docs/lessons.md): a worker thread that takes
// stored lesson sessions, re-runs each from its input log on the lesson's
// case (training::JudgeLessonSession) and records the verdict. Replaying costs
// CPU (a 60 s session about 2.4 s), so it never runs on a gRPC thread: an
// upload is acknowledged once the session is durable, and the session is
// queued for judging in the same transaction (table lesson_sessions), so a
// server killed before the verdict judges it when it starts again. Each
// replay runs within training::JudgeBudget (memory and CPU); a session over
// it, or whose replay was started kMaxJudgeStarts times without finishing,
// gets a final rejected verdict, so no record can cost more than that again.
namespace ves::server {

class SessionSeries;  // session_series.h

// Replays of one session that may start without finishing (the server died
// during them) before the session gets a rejected verdict instead of a third.
inline constexpr int kMaxJudgeStarts = 2;

class LessonJudge {
 public:
  // The judge's replay of a lesson session also gives the session page its
  // series (stored before the verdict); when it does not run to its end the
  // session is handed to `series` (when not null) to compute it.
  explicit LessonJudge(patient_db::Store* store, training::JudgeBudget budget = {},
                       SessionSeries* series = nullptr);
  ~LessonJudge();  // Stop()
  LessonJudge(const LessonJudge&) = delete;
  LessonJudge& operator=(const LessonJudge&) = delete;

  // Queues every stored lesson session without a verdict, then serves Enqueue.
  void Start();
  // A lesson session was stored: judge it soon. `record`, when given, is the
  // upload's checked record, judged without reading it back from the store.
  void Enqueue(const std::string& session_uuid,
               std::shared_ptr<const CheckedRecord> record = nullptr);
  // Cancels the replay under way and stops; what was not judged keeps no
  // verdict and is judged on the next start. Idempotent.
  void Stop();

  // Judges one stored session now and records the verdict (also used by tests).
  patient_db::StoreResult<patient_db::LessonVerdictRow> JudgeStored(
      const std::string& session_uuid);
  // The same for a record the caller holds (`held` when it is checked and
  // shared: handed on to the series worker as it is).
  patient_db::StoreResult<patient_db::LessonVerdictRow> Judge(
      const std::string& session_uuid, const ves::v1::SessionRecord& record,
      std::shared_ptr<const CheckedRecord> held);

  uint64_t judged() const;
  // Series stored from the judge's own replays.
  uint64_t series_recorded() const;

 private:
  void Loop();
  // The lesson's case as stored, decoded (cached by payload hash).
  patient_db::StoreResult<ves::v1::ColonCase> LessonCase(const ves::v1::Lesson& lesson);

  patient_db::Store* store_;
  training::JudgeBudget budget_;
  SessionSeries* series_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::string> queue_;  // guarded by mutex_
  std::set<std::string> queued_;   // guarded by mutex_
  HeldRecords held_{kHeldRecordBytes};  // guarded by mutex_
  bool stopping_ = false;          // guarded by mutex_
  std::atomic<bool> cancel_{false};  // read by the replay under way
  uint64_t judged_ = 0;            // guarded by mutex_
  std::atomic<uint64_t> series_recorded_{0};
  std::thread thread_;
  std::mutex cases_mutex_;
  std::map<std::string, ves::v1::ColonCase> cases_;  // by payload hash; guarded by cases_mutex_
};

}  // namespace ves::server
