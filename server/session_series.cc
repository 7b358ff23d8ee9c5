#include "server/session_series.h"

#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "server/pipeline.h"
#include "server/services.h"
#include "server/web_api.h"

namespace ves::server {
namespace {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

// Rounded to 1/per_unit so the JSON carries no digits nobody reads (0.01 mm,
// 0.1 mN); dividing by a power of ten gives the double nearest the decimal,
// which prints short. + 0.0 makes -0 plain 0.
double Round(double v, double per_unit) { return std::round(v * per_unit) / per_unit + 0.0; }

// Every stride-th element of `n` (stride >= 1), the first and the last.
bool Kept(size_t i, size_t n, size_t stride) { return i % stride == 0 || i + 1 == n; }

}  // namespace

json SeriesJson(const std::string& uuid, const SessionReplay& replay, double series_hz,
                double shape_hz) {
  const size_t n = replay.frames.size();
  const size_t plot_stride =
      std::max<size_t>(1, (n + kSeriesMaxPlotFrames - 2) / (kSeriesMaxPlotFrames - 1));
  size_t shapes = 0;
  for (size_t i = 0; i < n; ++i) {
    if (Kept(i, n, plot_stride) && !replay.frames[i].scope_mm.empty()) ++shapes;
  }
  const size_t shape_stride =
      std::max<size_t>(1, (shapes + kSeriesMaxShapeFrames - 2) / (kSeriesMaxShapeFrames - 1));
  json frames = json::array();
  size_t shape_index = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!Kept(i, n, plot_stride)) continue;
    const ReplayFrame& f = replay.frames[i];
    json j = {{"t_s", Round(f.t_s, 1e4)},
              {"base_force_N", Round(f.base_force_N, 1e4)},
              {"stretch_m", Round(f.stretch_m, 1e5)},
              {"tip_arc_m", Round(f.tip_arc_m, 1e5)},
              {"inserted_m", Round(f.inserted_m, 1e5)},
              {"pain", f.pain},
              {"loop", f.loop}};
    if (!f.scope_mm.empty()) {
      if (Kept(shape_index, shapes, shape_stride)) {
        j["scope_mm"] = f.scope_mm;
        j["colon_mm"] = f.colon_mm;
      }
      ++shape_index;
    }
    frames.push_back(std::move(j));
  }
  const double duration_s = n > 0 ? replay.frames.back().t_s : 0.0;
  return {{"v", kSeriesFormatVersion},
          {"uuid", uuid},
          {"duration_s", duration_s},
          {"series_hz", series_hz},
          {"shape_hz", shape_hz},
          {"pain_stretch_m", replay.pain_stretch_m},
          {"cecum_arc_m", replay.cecum_arc_m},
          {"final_tip_arc_m", replay.final_tip_arc_m},
          {"summary", replay.summary_line},
          {"frames", std::move(frames)}};
}

SeriesRates SeriesRatesFor(const v1::InputLog& log) {
  const double duration_s = static_cast<double>(log.sample_count()) * log.dt_s();
  // A 10-minute session: 2.5 Hz and 1 Hz, less the first and last steps'
  // frames. SeriesJson thins whatever rounding adds.
  SeriesRates r;
  r.series_hz = duration_s > 150.0 ? std::max(0.01, (kSeriesMaxPlotFrames - 4) / duration_s) : 10.0;
  r.shape_hz =
      std::min(r.series_hz, duration_s > 120.0 ? (kSeriesMaxShapeFrames - 4) / duration_s : 5.0);
  return r;
}

std::string SeriesJsonText(const std::string& uuid, const SessionReplay& replay,
                           const SeriesRates& rates) {
  return WebApi::HtmlSafeJson(SeriesJson(uuid, replay, rates.series_hz, rates.shape_hz)
                                  .dump(-1, ' ', false, json::error_handler_t::replace));
}

std::string ComputeSeriesJson(const v1::SessionRecord& record, const std::atomic<bool>* cancel) {
  const SeriesRates rates = SeriesRatesFor(record.input_log());
  const SessionReplay replay =
      ReplaySession(record, rates.series_hz, rates.shape_hz, kSeriesShapePoints, cancel);
  return SeriesJsonText(record.uuid(), replay, rates);
}

json LessonVerdictJson(patient_db::Store& store, const v1::SessionRecord& record) {
  if (record.lesson_id().empty()) return nullptr;
  auto verdict = store.GetLessonVerdict(record.uuid());
  if (!verdict.ok()) {
    if (verdict.status.code != patient_db::StoreCode::kNotFound) {
      return {{"status", "unknown"}, {"lesson_id", record.lesson_id()}};
    }
    return {{"status", "pending"}, {"lesson_id", record.lesson_id()}};
  }
  const patient_db::LessonVerdictRow& v = verdict.value;
  json checks = json::array();
  size_t start = 0;
  while (start <= v.detail.size()) {
    const size_t end = std::min(v.detail.find('\n', start), v.detail.size());
    std::string line = v.detail.substr(start, end - start);
    start = end + 1;
    if (line.empty()) continue;
    // The gate's lines end in ": ok" or ": FAILED" (station/training/lesson_gate.h).
    json passed = nullptr;
    for (const auto& [suffix, ok] : {std::pair{": ok", true}, std::pair{": FAILED", false}}) {
      const std::string s = suffix;
      if (line.size() >= s.size() && line.compare(line.size() - s.size(), s.size(), s) == 0) {
        line.resize(line.size() - s.size());
        passed = ok;
        break;
      }
    }
    checks.push_back({{"text", line}, {"passed", passed}});
  }
  return {{"status", v.rejected ? "rejected"
                     : v.passed ? "passed"
                                : "failed"},
          {"lesson_id", v.lesson_id},
          {"curriculum_id", v.curriculum_id},
          {"score", v.score},
          {"judged_unix_ms", v.judged_unix_ms},
          {"checks", std::move(checks)}};
}

Status SessionSeriesCall(const ServiceDeps& deps, const Principal& who,
                         const v1::GetSessionRequest& request, std::string* json) {
  // Only refusals are audited here: the read itself is GetSession's row.
  static const CallSpec spec{"session.series",
                             {patient_db::StoreRole::kAdmin, patient_db::StoreRole::kSupervisor,
                              patient_db::StoreRole::kTrainee},
                             "read sessions",
                             /*audit_every_call=*/false};
  return RunCall(deps, who, spec, request.uuid(), [&]() -> Status {
    v1::GetSessionResponse read;
    Status s = GetSessionCall(deps, who, request, &read);
    if (!s.ok()) return s;
    if (deps.series == nullptr) {
      return Status(StatusCode::UNAVAILABLE, "this server computes no session series");
    }
    return deps.series->Get(request.uuid(), read.record(), json);
  });
}

SessionSeries::SessionSeries(patient_db::Store* store) : store_(store) {}

SessionSeries::~SessionSeries() { Stop(); }

void SessionSeries::Start() {
  std::lock_guard lock(mutex_);
  if (thread_.joinable() || stopping_) return;
  thread_ = std::thread([this] { Loop(); });
}

void SessionSeries::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cancel_ = true;
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void SessionSeries::Enqueue(const std::string& session_uuid,
                            std::shared_ptr<const CheckedRecord> record) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || queue_.size() >= kSeriesQueueLimit) return;  // computed on first view
    queue_.push_back(session_uuid);
    held_.Hold(session_uuid, std::move(record));
  }
  wake_.notify_one();
}

bool SessionSeries::Claim(const std::string& uuid) {
  std::lock_guard lock(mutex_);
  return computing_.insert(uuid).second;
}

void SessionSeries::Release(const std::string& uuid) {
  std::lock_guard lock(mutex_);
  computing_.erase(uuid);
}

void SessionSeries::StoreSeries(const std::string& uuid, const std::string& json) {
  const patient_db::StoreStatus put =
      store_->PutSessionSeries({uuid, kSeriesFormatVersion, NowUnixMs(), json});
  if (!put.ok()) spdlog::warn("session series of {}: not stored: {}", uuid, put.message);
}

void SessionSeries::Loop() {
  // Background work: below the gRPC and HTTP threads (Linux: per thread).
  setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 10);
  for (;;) {
    std::string uuid;
    std::shared_ptr<const CheckedRecord> held;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      uuid = std::move(queue_.front());
      queue_.pop_front();
      held = held_.Take(uuid);
    }
    auto stored = store_->GetSessionSeries(uuid);
    if (stored.ok() && stored.value.format_version == kSeriesFormatVersion) continue;
    if (!Claim(uuid)) continue;  // a page view is computing it
    // The upload's checked record, or (not held) the stored one, parsed here.
    v1::SessionRecord read_back;
    if (held == nullptr) {
      auto row = store_->GetSession(uuid);
      if (!row.ok() || !read_back.ParseFromString(row.value.body)) {
        Release(uuid);
        continue;
      }
    }
    const v1::SessionRecord& record = held ? held->record() : read_back;
    try {
      const std::string json = ComputeSeriesJson(record, &cancel_);
      {
        std::lock_guard lock(mutex_);
        ++computed_in_background_;
      }
      StoreSeries(uuid, json);
    } catch (const ReplayCancelled&) {
      Release(uuid);
      return;
    } catch (const std::exception& e) {
      // The page says why when it asks (FAILED_PRECONDITION).
      spdlog::info("session series of {}: cannot be computed: {}", uuid, e.what());
    }
    Release(uuid);
  }
}

Status SessionSeries::Get(const std::string& uuid, const v1::SessionRecord& record,
                          std::string* json) {
  auto stored = store_->GetSessionSeries(uuid);
  if (stored.ok() && stored.value.format_version == kSeriesFormatVersion) {
    *json = std::move(stored.value.json);
    return Status::OK;
  }
  if (!stored.ok() && stored.status.code != patient_db::StoreCode::kNotFound) {
    return ToGrpcStatus(stored.status);
  }
  {
    std::lock_guard lock(mutex_);
    if (computing_.count(uuid) > 0) {
      return Status(
          StatusCode::RESOURCE_EXHAUSTED,
          "the series of session " + uuid + " is being computed; ask again in a few seconds");
    }
    if (lazy_running_ >= kMaxConcurrentLazySeries) {
      return Status(StatusCode::RESOURCE_EXHAUSTED,
                    std::to_string(kMaxConcurrentLazySeries) +
                        " replays are running; ask again in a few seconds");
    }
    computing_.insert(uuid);
    ++lazy_running_;
  }
  Status result = Status::OK;
  try {
    *json = ComputeSeriesJson(record, &cancel_);
    StoreSeries(uuid, *json);
  } catch (const std::exception& e) {
    result = Status(StatusCode::FAILED_PRECONDITION,
                    "session " + uuid + " cannot be replayed: " + e.what());
  }
  std::lock_guard lock(mutex_);
  computing_.erase(uuid);
  --lazy_running_;
  if (result.ok()) ++computed_on_view_;
  return result;
}

uint64_t SessionSeries::computed_in_background() const {
  std::lock_guard lock(mutex_);
  return computed_in_background_;
}

uint64_t SessionSeries::computed_on_view() const {
  std::lock_guard lock(mutex_);
  return computed_on_view_;
}

}  // namespace ves::server
