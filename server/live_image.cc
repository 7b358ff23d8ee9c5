#include "server/live_image.h"

namespace ves::server {

bool LiveImageAssembly::Await(LiveNotice frame) {
  const bool lost = Forget(frame.info.session_uuid);
  Waiting& w = waiting_[frame.info.session_uuid];
  w.frame = std::move(frame);
  w.frame.frame.clear_endoscope_jpeg();
  return lost;
}

LiveImageAssembly::Outcome LiveImageAssembly::Add(const LiveNotice& n, LiveNotice* frame,
                                                  std::string* why) {
  const std::string name = "image " + std::to_string(n.image) + " part " +
                           std::to_string(n.part.part) + " of " + std::to_string(n.part.parts);
  auto it = waiting_.find(n.info.session_uuid);
  if (it == waiting_.end() || it->second.frame.replica_id != n.replica_id ||
      n.image < it->second.frame.image) {
    *why = name + ": no frame waits for it";
    return Outcome::kIgnored;
  }
  Waiting& w = it->second;
  if (n.image > w.frame.image) {
    // The newer image's frame was lost on the way, so the waiting image's
    // remaining parts will not come either.
    *why = name + ": newer than the waiting image " + std::to_string(w.frame.image);
    waiting_.erase(it);
    return Outcome::kIgnored;
  }
  const auto discard = [&](const std::string& what) {
    *why = name + ": " + what;
    waiting_.erase(it);
    return Outcome::kRefused;
  };
  if (w.parts.empty()) w.parts.resize(static_cast<size_t>(n.part.parts));
  if (static_cast<size_t>(n.part.parts) != w.parts.size()) {
    return discard("an earlier part said " + std::to_string(w.parts.size()) + " parts");
  }
  std::string& slot = w.parts[static_cast<size_t>(n.part.part)];
  if (!slot.empty()) return discard("came twice");
  if (w.bytes + n.part.bytes.size() > kMaxLiveJpegBytes) {
    return discard("the image would be more than " + std::to_string(kMaxLiveJpegBytes) + " bytes");
  }
  slot = n.part.bytes;
  w.bytes += slot.size();
  if (++w.have < n.part.parts) return Outcome::kPending;

  std::string jpeg;
  jpeg.reserve(w.bytes);
  for (const std::string& p : w.parts) jpeg += p;
  std::string bad = CheckLiveJpeg(jpeg);
  // The gRPC path's check, and the end marker: a JPEG cut short or put
  // together wrong is not shown.
  if (bad.empty() && jpeg.compare(jpeg.size() - 2, 2, "\xFF\xD9") != 0) {
    bad = "frame.endoscope_jpeg: not a whole JPEG (no FF D9 end)";
  }
  if (!bad.empty()) return discard(bad);
  *frame = std::move(w.frame);
  frame->frame.set_endoscope_jpeg(std::move(jpeg));
  waiting_.erase(it);
  return Outcome::kComplete;
}

bool LiveImageAssembly::Forget(const std::string& session_uuid) {
  auto it = waiting_.find(session_uuid);
  if (it == waiting_.end()) return false;
  waiting_.erase(it);
  return true;  // a waiting frame's image is incomplete by definition
}

int LiveImageAssembly::Retain(
    const std::function<bool(const std::string&, const std::string&)>& keep) {
  int freed = 0;
  for (auto it = waiting_.begin(); it != waiting_.end();) {
    if (keep(it->first, it->second.frame.replica_id)) {
      ++it;
    } else {
      it = waiting_.erase(it);
      ++freed;
    }
  }
  return freed;
}

}  // namespace ves::server
