#include "server/live_hub.h"

#include <openssl/evp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/live_notice.h"

namespace ves::server {
namespace {

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

template <class Floats>
std::string CheckFloats(const Floats& v, const char* name, int max_count, int multiple_of) {
  if (v.size() > max_count) {
    return std::string(name) + ": " + std::to_string(v.size()) + " numbers, more than " +
           std::to_string(max_count);
  }
  if (v.size() % multiple_of != 0) {
    return std::string(name) + ": " + std::to_string(v.size()) + " numbers, not a multiple of " +
           std::to_string(multiple_of);
  }
  for (int i = 0; i < v.size(); ++i) {
    // Shapes are metres inside a body: a kilometre is a broken frame.
    if (!std::isfinite(v[i]) || std::fabs(v[i]) > 1000.0f) {
      return std::string(name) + "[" + std::to_string(i) + "] = " + std::to_string(v[i]) +
             ": not a finite number within +-1000";
    }
  }
  return {};
}

std::string CheckNumber(double v, const char* name, double bound) {
  if (std::isfinite(v) && std::fabs(v) <= bound) return {};
  return std::string(name) + " = " + std::to_string(v) + ": not a finite number within +-" +
         std::to_string(static_cast<long long>(bound));
}

std::string CheckId(const std::string& id, const char* name, bool required) {
  if (id.empty() && !required) return {};
  if (patient_db::IsPrintableId(id)) return {};
  return std::string(name) + " = '" + patient_db::PrintableExcerpt(id) + "': " +
         (id.empty()
              ? "missing (the first frame names the session)"
              : "not 1.." + std::to_string(patient_db::kMaxIdBytes) + " bytes of printable text");
}

nlohmann::json ApMm(const google::protobuf::RepeatedField<float>& xyz) {
  // The replay's AP projection (server/session_replay.cc): right = -x, up = +z.
  nlohmann::json out = nlohmann::json::array();
  for (int i = 0; i + 2 < xyz.size(); i += 3) {
    out.push_back({static_cast<int>(std::lround(-xyz[i] * 1000.0)),
                   static_cast<int>(std::lround(xyz[i + 2] * 1000.0))});
  }
  return out;
}

}  // namespace

std::string CheckLiveFrame(const v1::LiveFrame& f, bool first) {
  std::string why;
  const auto bad = [&](std::string w) {
    if (why.empty() && !w.empty()) why = std::move(w);
  };
  bad(CheckId(f.session_uuid(), "frame.session_uuid", first));
  bad(CheckId(f.trainee_id(), "frame.trainee_id", first));
  bad(CheckId(f.case_id(), "frame.case_id", first));
  bad(CheckNumber(f.t_s(), "frame.t_s", 1e7));
  bad(CheckFloats(f.scope_xyz_m(), "frame.scope_xyz_m", 3 * kMaxLivePolylinePoints, 3));
  bad(CheckFloats(f.colon_xyz_m(), "frame.colon_xyz_m", 3 * kMaxLivePolylinePoints, 3));
  bad(CheckFloats(f.tip_xyz_m(), "frame.tip_xyz_m", 3, 3));
  bad(CheckFloats(f.tip_dir(), "frame.tip_dir", 3, 3));
  bad(CheckNumber(f.base_force_n(), "frame.base_force_n", 1e4));
  bad(CheckNumber(f.inserted_m(), "frame.inserted_m", 1e3));
  bad(CheckNumber(f.tip_arc_m(), "frame.tip_arc_m", 1e3));
  bad(CheckNumber(f.stretch_m(), "frame.stretch_m", 1e3));
  bad(CheckLiveJpeg(f.endoscope_jpeg()));
  return why;
}

std::string CheckLiveJpeg(const std::string& jpeg) {
  if (jpeg.size() > kMaxLiveJpegBytes) {
    return "frame.endoscope_jpeg: " + std::to_string(jpeg.size()) + " bytes, more than " +
           std::to_string(kMaxLiveJpegBytes);
  }
  if (!jpeg.empty() &&
      (jpeg.size() < 3 || jpeg.compare(0, 3, std::string("\xFF\xD8\xFF", 3)) != 0)) {
    return "frame.endoscope_jpeg: not a JPEG (no FF D8 FF start)";
  }
  return {};
}

std::string LiveFrameJson(const v1::LiveFrame& f, int64_t received_unix_ms) {
  nlohmann::json j = {{"t_s", f.t_s()},
                      {"base_force_N", f.base_force_n()},
                      {"inserted_m", f.inserted_m()},
                      {"tip_arc_m", f.tip_arc_m()},
                      {"stretch_m", f.stretch_m()},
                      {"pain", f.pain()},
                      {"loop", f.loop()},
                      {"sent_unix_ms", f.sent_unix_ms()},
                      {"received_unix_ms", received_unix_ms},
                      {"station_dropped", f.dropped_frames()}};
  if (!f.scope_xyz_m().empty()) j["scope_mm"] = ApMm(f.scope_xyz_m());
  if (!f.colon_xyz_m().empty()) j["colon_mm"] = ApMm(f.colon_xyz_m());
  if (f.tip_xyz_m().size() == 3) {
    j["tip_mm"] = {std::lround(f.tip_xyz_m(0) * 1000.0), std::lround(f.tip_xyz_m(1) * 1000.0),
                   std::lround(f.tip_xyz_m(2) * 1000.0)};
  }
  if (f.tip_dir().size() == 3) j["tip_dir"] = {f.tip_dir(0), f.tip_dir(1), f.tip_dir(2)};
  if (!f.endoscope_jpeg().empty()) j["jpeg_base64"] = EncodeBase64(f.endoscope_jpeg());
  // '<', '>' and '&' never reach a page unescaped (ids are not in frames, but
  // the same rule as every API reply).
  return j.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
}

std::string LiveViewer::Next(int wait_ms, bool* ended) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, std::chrono::milliseconds(wait_ms), [&] { return slot_ || ended_; });
  *ended = false;
  if (slot_) {
    std::shared_ptr<const std::string> frame = std::move(slot_);
    slot_.reset();
    return *frame;
  }
  *ended = ended_;
  return {};
}

uint64_t LiveViewer::overwritten() const {
  std::lock_guard lock(mutex_);
  return overwritten_;
}

std::string EncodeBase64(const std::string& bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()),
                                static_cast<int>(bytes.size()));
  out.resize(static_cast<size_t>(std::max(0, n)));
  return out;
}

int64_t SteadyNowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

bool LiveHub::Begin(const LiveSessionInfo& info, std::string* why) {
  LiveSessionInfo begun;
  {
    std::lock_guard lock(mutex_);
    auto it = live_.find(info.session_uuid);
    if (it != live_.end() && it->second.info.origin_replica.empty()) {
      *why = "session " + info.session_uuid + " is already streaming";
      return false;
    }
    if (local_ >= kMaxLiveSessions) {
      *why = std::to_string(kMaxLiveSessions) + " live sessions stream already";
      return false;
    }
    Live& l = live_[info.session_uuid];  // a remote entry keeps its viewers
    l.info = info;
    l.info.origin_replica.clear();
    l.info.started_unix_ms = NowMs();
    ++local_;
    begun = l.info;
  }
  if (relay_ != nullptr) relay_->Began(begun);
  return true;
}

void LiveHub::Publish(const std::string& session_uuid, const v1::LiveFrame& frame) {
  LiveSessionInfo info;
  if (Deliver(session_uuid, frame, /*remote=*/false, &info) && relay_ != nullptr) {
    relay_->Framed(info, frame);
  }
}

bool LiveHub::Deliver(const std::string& session_uuid, const v1::LiveFrame& frame, bool remote,
                      LiveSessionInfo* info) {
  const int64_t now = NowMs();
  auto json = std::make_shared<const std::string>(LiveFrameJson(frame, now));
  std::vector<std::shared_ptr<LiveViewer>> viewers;
  {
    std::lock_guard lock(mutex_);
    auto it = live_.find(session_uuid);
    if (it == live_.end() || it->second.info.origin_replica.empty() == remote) return false;
    Live& l = it->second;
    l.latest = json;
    l.info.last_frame_unix_ms = now;
    l.info.t_s = frame.t_s();
    l.info.station_dropped = frame.dropped_frames();
    if (!remote) ++l.info.frames;  // a remote session counts the frames its replica had
    viewers = l.viewers;
    *info = l.info;
  }
  for (const auto& v : viewers) {
    {
      std::lock_guard lock(v->mutex_);
      if (v->slot_) ++v->overwritten_;
      v->slot_ = json;  // the newest replaces what a slow viewer has not taken
    }
    v->cv_.notify_one();
  }
  return true;
}

void LiveHub::EndViewers(const std::vector<std::shared_ptr<LiveViewer>>& viewers) {
  for (const auto& v : viewers) {
    {
      std::lock_guard lock(v->mutex_);
      v->ended_ = true;
    }
    v->cv_.notify_one();
  }
}

void LiveHub::End(const std::string& session_uuid) {
  std::vector<std::shared_ptr<LiveViewer>> viewers;
  {
    std::lock_guard lock(mutex_);
    auto it = live_.find(session_uuid);
    if (it == live_.end() || !it->second.info.origin_replica.empty()) return;
    viewers = std::move(it->second.viewers);
    live_.erase(it);
    --local_;
  }
  EndViewers(viewers);
  if (relay_ != nullptr) relay_->Ended(session_uuid);
}

bool LiveHub::ApplyRemote(const LiveNotice& n) {
  const std::string& uuid = n.info.session_uuid;
  if (n.kind == LiveNoticeKind::kEnd) {
    std::vector<std::shared_ptr<LiveViewer>> viewers;
    {
      std::lock_guard lock(mutex_);
      auto it = live_.find(uuid);
      if (it == live_.end() || it->second.info.origin_replica.empty()) return true;
      viewers = std::move(it->second.viewers);
      live_.erase(it);
    }
    EndViewers(viewers);
    return true;
  }
  {
    std::lock_guard lock(mutex_);
    auto it = live_.find(uuid);
    if (it == live_.end()) {
      if (live_.size() - static_cast<size_t>(local_) >= static_cast<size_t>(kMaxLiveSessions)) {
        return false;
      }
      // A frame may come first (its begin dropped on the way): either starts it.
      Live& l = live_[uuid];
      l.info = n.info;
      l.info.last_frame_unix_ms = 0;
      l.info.t_s = 0;
      l.info.station_dropped = 0;
      it = live_.find(uuid);
    } else if (it->second.info.origin_replica.empty()) {
      return true;  // streaming here: this replica knows best
    }
    // The ids stay as first announced; the holder may change (the station
    // reconnected to a third replica).
    it->second.info.origin_replica = n.replica_id;
    it->second.info.frames = n.info.frames;
    it->second.last_notice_steady_ms = SteadyNowMs();
  }
  if (n.kind == LiveNoticeKind::kFrame) {
    LiveSessionInfo info;
    Deliver(uuid, n.frame, /*remote=*/true, &info);
  }
  return true;
}

int LiveHub::ExpireRemote(int64_t silence_ms) {
  const int64_t now = SteadyNowMs();
  std::vector<std::shared_ptr<LiveViewer>> viewers;
  int expired = 0;
  {
    std::lock_guard lock(mutex_);
    for (auto it = live_.begin(); it != live_.end();) {
      if (it->second.info.origin_replica.empty() ||
          now - it->second.last_notice_steady_ms < silence_ms) {
        ++it;
        continue;
      }
      for (auto& v : it->second.viewers) viewers.push_back(std::move(v));
      it = live_.erase(it);
      ++expired;
    }
  }
  EndViewers(viewers);
  return expired;
}

std::vector<LiveSessionInfo> LiveHub::List(const std::string& institution) const {
  std::vector<LiveSessionInfo> out;
  std::lock_guard lock(mutex_);
  for (const auto& [uuid, l] : live_) {
    if (institution.empty() || l.info.institution == institution) out.push_back(l.info);
  }
  std::sort(out.begin(), out.end(),
            [](const auto& a, const auto& b) { return a.started_unix_ms < b.started_unix_ms; });
  return out;
}

bool LiveHub::Find(const std::string& session_uuid, LiveSessionInfo* info) const {
  std::lock_guard lock(mutex_);
  auto it = live_.find(session_uuid);
  if (it == live_.end()) return false;
  *info = it->second.info;
  return true;
}

std::shared_ptr<LiveViewer> LiveHub::Watch(const std::string& session_uuid, std::string* why) {
  std::lock_guard lock(mutex_);
  auto it = live_.find(session_uuid);
  if (it == live_.end()) {
    *why = "session " + session_uuid + " is not live";
    return nullptr;
  }
  if (it->second.viewers.size() >= static_cast<size_t>(kMaxLiveViewersPerSession)) {
    *why = "session " + session_uuid + " has " + std::to_string(kMaxLiveViewersPerSession) +
           " viewers already";
    return nullptr;
  }
  auto v = std::make_shared<LiveViewer>();
  v->slot_ = it->second.latest;
  it->second.viewers.push_back(v);
  return v;
}

void LiveHub::Unwatch(const std::string& session_uuid, const std::shared_ptr<LiveViewer>& viewer) {
  std::lock_guard lock(mutex_);
  auto it = live_.find(session_uuid);
  if (it == live_.end()) return;
  auto& v = it->second.viewers;
  v.erase(std::remove(v.begin(), v.end(), viewer), v.end());
}

}  // namespace ves::server
