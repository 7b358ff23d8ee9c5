#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <nlohmann/json_fwd.hpp>
#include <set>
#include <string>
#include <thread>

#include "patient_db/store.h"
#include "server/checked_record.h"
#include "server/session_replay.h"
#include "ves/v1/services.pb.h"
#include "ves/v1/session.pb.h"

// What a session page shows of a stored session, computed once (docs/web.md,
// "Session series"): the plots' data and a replay track thinned for the
// browser, as JSON text kept in the store beside the session. A background
// worker computes it after each upload of a free run; the lesson judge
// records a lesson session's from the replay it judges (the session is
// replayed once), or hands it to the worker when its replay did not run to
// the end. A session stored without one (before
// series existed, or whose computation a restart lost) gets it on its first
// page view, and then it is stored too.
namespace ves::server {

// A stored series of another format version is computed again.
inline constexpr int kSeriesFormatVersion = 2;
// Bounds of one series: plot frames (10 Hz up to 150 s, fewer per second
// beyond), frames with shapes (5 Hz up to 120 s) and points per shape. With
// the numbers rounded, a series stays under patient_db::kMaxSessionSeriesBytes.
inline constexpr int kSeriesMaxPlotFrames = 1500;
inline constexpr int kSeriesMaxShapeFrames = 600;
inline constexpr int kSeriesShapePoints = 64;
// Uploads waiting for their series; past this they are computed on first view.
inline constexpr size_t kSeriesQueueLimit = 1024;
// Series computed on page views at once (each a replay: seconds of CPU); more
// answer RESOURCE_EXHAUSTED and the page asks again.
inline constexpr int kMaxConcurrentLazySeries = 2;

// The series of a replay, thinned to the bounds above: {"v", "uuid",
// "duration_s", "series_hz", "shape_hz", "pain_stretch_m", "cecum_arc_m",
// "final_tip_arc_m", "summary", "frames"} (frames as the /replay route's).
nlohmann::json SeriesJson(const std::string& uuid, const SessionReplay& replay, double series_hz,
                          double shape_hz);

// The rates a series is recorded at: 10 Hz plots and 5 Hz shapes for a short
// session; a long one gets as many frames as the bounds allow.
struct SeriesRates {
  double series_hz = 10.0;
  double shape_hz = 5.0;
};
SeriesRates SeriesRatesFor(const v1::InputLog& log);

// SeriesJson as the stored JSON text (HTML-safe).
std::string SeriesJsonText(const std::string& uuid, const SessionReplay& replay,
                           const SeriesRates& rates);

// Re-runs the record and returns its series as JSON text (HTML-safe). Throws
// as ReplaySession does (ReplayCancelled once `cancel` is true).
std::string ComputeSeriesJson(const v1::SessionRecord& record,
                              const std::atomic<bool>* cancel = nullptr);

// The server's verdict on a lesson session for the session page: null for a
// free run; {"status": "pending"} before the judge has replayed it; else
// {"status": "passed"|"failed"|"rejected", "lesson_id", "curriculum_id",
// "score", "judged_unix_ms", "checks": [{"text", "passed": true|false|null}]}.
nlohmann::json LessonVerdictJson(patient_db::Store& store, const v1::SessionRecord& record);

struct ServiceDeps;
struct Principal;

// GET /api/v1/sessions/{uuid}/series: the read rules (and audit row) of
// GetSession, then the session's series from deps.series; UNAVAILABLE when
// the server has none.
grpc::Status SessionSeriesCall(const ServiceDeps& deps, const Principal& who,
                               const v1::GetSessionRequest& request, std::string* json);

class SessionSeries {
 public:
  explicit SessionSeries(patient_db::Store* store);
  ~SessionSeries();  // Stop()
  SessionSeries(const SessionSeries&) = delete;
  SessionSeries& operator=(const SessionSeries&) = delete;

  void Start();
  // Cancels the computation under way and stops; what is left is computed on
  // first view. Idempotent.
  void Stop();
  // A session was stored: compute its series in the background (dropped,
  // hence computed on first view, when kSeriesQueueLimit wait already).
  // `record`, when given, is the upload's checked record, replayed without
  // reading it back from the store.
  void Enqueue(const std::string& session_uuid,
               std::shared_ptr<const CheckedRecord> record = nullptr);

  // The series of `record` (already read under the caller's access rules):
  // the stored one, or computed now and stored. RESOURCE_EXHAUSTED when it
  // is being computed already or kMaxConcurrentLazySeries computations run
  // (ask again); FAILED_PRECONDITION when the record cannot be replayed.
  grpc::Status Get(const std::string& uuid, const v1::SessionRecord& record, std::string* json);

  // Series computed by this worker's own replays (a lesson session's comes
  // from the judge's replay and is not counted here).
  uint64_t computed_in_background() const;
  uint64_t computed_on_view() const;

 private:
  void Loop();
  // Computes and stores; false when another thread is computing it.
  bool Claim(const std::string& uuid);
  void Release(const std::string& uuid);
  void StoreSeries(const std::string& uuid, const std::string& json);

  patient_db::Store* store_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::string> queue_;        // guarded by mutex_
  HeldRecords held_{kHeldRecordBytes};   // guarded by mutex_
  std::set<std::string> computing_;      // guarded by mutex_
  int lazy_running_ = 0;                 // guarded by mutex_
  bool stopping_ = false;                // guarded by mutex_
  uint64_t computed_in_background_ = 0;  // guarded by mutex_
  uint64_t computed_on_view_ = 0;        // guarded by mutex_
  std::atomic<bool> cancel_{false};
  std::thread thread_;
};

}  // namespace ves::server
