#include "station/app/live_publish.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <ostream>
#include <thread>

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

LiveFigures LiveFiguresOf(const training::SessionRunner& runner) {
  const auto& obs = runner.observation();
  LiveFigures f;
  f.t_s = obs.t_s;
  f.base_force_N = obs.base_force_N;
  f.inserted_m = obs.inserted_m;
  f.tip_arc_m = obs.tip_arc_m;
  f.stretch_m = obs.peak_stretch_m;
  f.pain = obs.peak_stretch_m > runner.session().accumulator().thresholds().pain_stretch_m;
  f.loop = runner.session().accumulator().in_loop();
  return f;
}

ves::v1::LiveFrame MakeLiveFrame(const training::SessionRunner& runner) {
  return MakeLiveFrame(runner.state(), LiveFiguresOf(runner));
}

ves::v1::LiveFrame MakeLiveFrame(const model::ModelState& state, const LiveFigures& figures) {
  ves::v1::LiveFrame f;
  f.set_t_s(figures.t_s);
  f.set_base_force_n(figures.base_force_N);
  f.set_inserted_m(figures.inserted_m);
  f.set_tip_arc_m(figures.tip_arc_m);
  f.set_stretch_m(figures.stretch_m);
  f.set_pain(figures.pain);
  f.set_loop(figures.loop);
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

std::string EncodeLiveJpeg(const cv::Mat& image) {
  if (image.empty()) return {};
  cv::Mat small;
  cv::resize(image, small, cv::Size(320, std::max(1, image.rows * 320 / std::max(1, image.cols))),
             0, 0, cv::INTER_AREA);
  std::vector<uchar> bytes;
  if (!cv::imencode(".jpg", small, bytes, {cv::IMWRITE_JPEG_QUALITY, 70})) return {};
  return std::string(bytes.begin(), bytes.end());
}

void LivePublisher::OnStep(const training::SessionRunner& runner,
                           const std::function<std::string()>& jpeg) {
  OnState(runner.observation().t_s, [&] { return MakeLiveFrame(runner); }, jpeg);
}

void LivePublisher::OnState(double t_s, const std::function<ves::v1::LiveFrame()>& make,
                            const std::function<std::string()>& jpeg) {
  if (!streamer_) return;
  if (t_s + 1e-9 < next_frame_s_) return;
  next_frame_s_ = t_s + kLiveFramePeriodS;
  ves::v1::LiveFrame frame = make();
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

void LivePublisher::EndInBackground() {
  if (streamer_) streamer_->RequestClose();
}

bool LivePublisher::Reap(sync::LiveStreamStats* stats) {
  if (!streamer_) {
    *stats = {};
    return true;
  }
  if (!streamer_->Reap(stats)) return false;
  streamer_.reset();
  return true;
}

InteractiveLive::InteractiveLive(std::optional<sync::ServerEndpoint> server,
                                 std::string trainee_id, std::string case_id,
                                 uint32_t case_version)
    : server_(std::move(server)),
      trainee_id_(std::move(trainee_id)),
      case_id_(std::move(case_id)),
      case_version_(case_version) {}

InteractiveLive::~InteractiveLive() = default;  // LiveStreamer's destructor closes (bounded)

void InteractiveLive::OnPublication(const std::string& session_uuid, bool running, double t_s,
                                    const std::function<ves::v1::LiveFrame()>& make,
                                    const std::function<std::string()>& jpeg) {
  ReapEnded();
  if (!server_) return;
  if (session_uuid != current_uuid_) {
    if (current_) {
      current_->EndInBackground();
      ending_.push_back(std::move(current_));
    }
    current_uuid_ = session_uuid;
    current_streamed_ = false;
  }
  // Its stream opens with its first running publication: a session is
  // published ready (armed, before its first insertion) first, and one over
  // before it ran has nothing to show.
  if (!current_ && !current_streamed_ && running && !session_uuid.empty()) {
    current_ = std::make_unique<LivePublisher>(server_, session_uuid, trainee_id_, case_id_,
                                               case_version_);
    current_streamed_ = true;
    ++sessions_;
  }
  if (!current_) return;
  current_->OnState(t_s, make, running ? jpeg : std::function<std::string()>{});
  if (!running) {  // its last frame is queued: the stream ends behind it
    current_->EndInBackground();
    ending_.push_back(std::move(current_));
  }
}

void InteractiveLive::ReapEnded() {
  for (auto it = ending_.begin(); it != ending_.end();) {
    sync::LiveStreamStats stats;
    if ((*it)->Reap(&stats)) {
      Count(stats);
      it = ending_.erase(it);
    } else {
      ++it;
    }
  }
}

void InteractiveLive::Count(const sync::LiveStreamStats& s) {
  sent_ += s.sent;
  dropped_ += s.dropped;
  if (s.gave_up || !s.last_error.empty()) {
    last_error_ = s.last_error.empty() ? "server unreachable" : s.last_error;
  }
}

void InteractiveLive::Finish(std::ostream& log) {
  if (!server_) return;
  if (current_) {
    current_->EndInBackground();
    ending_.push_back(std::move(current_));
  }
  // Bounded: each stream still open is cancelled 2 s after its end was asked.
  while (!ending_.empty()) {
    ReapEnded();
    if (!ending_.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  log << "live: " << sessions_ << (sessions_ == 1 ? " session, " : " sessions, ") << sent_
      << " frames streamed, " << dropped_ << " dropped";
  if (!last_error_.empty()) log << " (" << last_error_ << ")";
  log << "\n";
}

}  // namespace ves::station
