#include "station/app/live_publish.h"

#include <algorithm>
#include <ostream>

namespace ves::station {
namespace {

void AddPolyline(const std::vector<Eigen::Vector3d>& points, size_t first,
                 google::protobuf::RepeatedField<float>* out) {
  if (first >= points.size()) return;
  const size_t n = points.size() - first;
  const size_t stride = std::max<size_t>(1, (n + kLivePolylinePoints - 1) / kLivePolylinePoints);
  const auto add = [&](const Eigen::Vector3d& p) {
    out->Add(static_cast<float>(p.x()));
    out->Add(static_cast<float>(p.y()));
    out->Add(static_cast<float>(p.z()));
  };
  for (size_t i = first; i < points.size(); i += stride) add(points[i]);
  if ((n - 1) % stride != 0) add(points.back());  // keep the tip / the cecum
}

}  // namespace

ves::v1::LiveFrame MakeLiveFrame(const training::SessionRunner& runner) {
  ves::v1::LiveFrame f;
  const auto& obs = runner.observation();
  const auto& th = runner.session().accumulator().thresholds();
  const auto& state = runner.state();
  f.set_t_s(obs.t_s);
  f.set_hand_force_n(obs.base_force_N);
  f.set_inserted_m(obs.inserted_m);
  f.set_tip_arc_m(obs.tip_arc_m);
  f.set_stretch_m(obs.peak_stretch_m);
  f.set_pain(obs.peak_stretch_m > th.pain_stretch_m);
  f.set_loop(runner.session().accumulator().in_loop());
  // The scope from just outside the anus to the tip, as the replay draws it.
  const size_t first = static_cast<size_t>(std::max(0, state.first_inside_sample - 1));
  AddPolyline(state.p_WSample, first, f.mutable_scope_xyz_m());
  AddPolyline(state.p_WColon, 0, f.mutable_colon_xyz_m());
  const auto& s = state.p_WSample;
  if (!s.empty()) {
    for (int k = 0; k < 3; ++k) f.add_tip_xyz_m(static_cast<float>(s.back()[k]));
    if (s.size() >= 2) {
      const Eigen::Vector3d d = s.back() - s[s.size() - 2];
      if (d.norm() > 0) {
        const Eigen::Vector3d u = d.normalized();
        for (int k = 0; k < 3; ++k) f.add_tip_dir(static_cast<float>(u[k]));
      }
    }
  }
  return f;
}

LivePublisher::LivePublisher(const std::optional<sync::ServerEndpoint>& server,
                             const std::string& session_uuid, const std::string& trainee_id,
                             const std::string& case_id, uint32_t case_version) {
  if (!server) return;
  ves::v1::LiveFrame first;
  first.set_session_uuid(session_uuid);
  first.set_trainee_id(trainee_id);
  first.set_case_id(case_id);
  first.set_case_version(case_version);
  try {
    streamer_ = std::make_unique<sync::LiveStreamer>(*server, std::move(first));
  } catch (const std::exception&) {
    streamer_.reset();  // the endpoint was checked at parse time; no live view then
  }
}

void LivePublisher::OnStep(const training::SessionRunner& runner,
                           const std::function<std::string()>& jpeg) {
  if (!streamer_) return;
  const double t_s = runner.observation().t_s;
  if (t_s + 1e-9 < next_frame_s_) return;
  next_frame_s_ = t_s + kLiveFramePeriodS;
  ves::v1::LiveFrame frame = MakeLiveFrame(runner);
  const auto now = std::chrono::steady_clock::now();
  if (jpeg && now >= next_jpeg_ && streamer_->Idle()) {
    next_jpeg_ = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                           std::chrono::duration<double>(kLiveJpegPeriodS));
    std::string bytes = jpeg();
    // Over the server's bound it would end the stream: sent without it.
    if (bytes.size() <= sync::kMaxLiveJpegBytes) frame.set_endoscope_jpeg(std::move(bytes));
  }
  streamer_->Offer(std::move(frame));
}

void LivePublisher::Finish(std::ostream& log) {
  if (!streamer_) return;
  const sync::LiveStreamStats s = streamer_->Close();
  streamer_.reset();
  log << "live: " << s.sent << " frames streamed, " << s.dropped << " dropped";
  if (s.gave_up || !s.last_error.empty()) {
    log << " (" << (s.last_error.empty() ? "server unreachable" : s.last_error) << ")";
  }
  log << "\n";
}

}  // namespace ves::station
