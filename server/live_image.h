#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "server/live_notice.h"

// The endoscope JPEGs other replicas send in parts (docs/web.md, "Live
// proctoring across replicas"), put back together. A frame notice that names
// an image waits here for that image's parts; with the last one it goes on
// with its JPEG, so a remote viewer gets it as a local one would. Pure: no
// I/O. Bounded: one waiting frame and image per session (the relay only
// brings sessions the hub holds as remote), an image at most
// kMaxLiveJpegBytes; a complete or discarded image is freed at once.
namespace ves::server {

class LiveImageAssembly {
 public:
  // `frame` (kFrame, image != 0) waits for its image, replacing whatever
  // waited for that session. True when that was an image still incomplete.
  bool Await(LiveNotice frame);

  enum class Outcome {
    kPending,   // kept; more parts to come
    kComplete,  // *frame is the waiting frame, its JPEG in endoscope_jpeg
    kIgnored,   // no frame waits for this image (its frame was lost, or it is older)
    kRefused,   // at odds with the image's other parts, or not a JPEG: image discarded
  };
  // One kImage notice (from ParseLiveNotice). `why` says what was wrong
  // (kIgnored, kRefused).
  Outcome Add(const LiveNotice& part, LiveNotice* frame, std::string* why);

  // Frees what waits for a session (it ended, or a frame without an image
  // superseded the waiting one). True when an image was incomplete.
  bool Forget(const std::string& session_uuid);
  // Keeps only what `keep(session_uuid, replica_id)` accepts; how many
  // waiting images were freed.
  int Retain(const std::function<bool(const std::string&, const std::string&)>& keep);
  size_t waiting() const { return waiting_.size(); }

 private:
  struct Waiting {
    LiveNotice frame;                // frame.image is the awaited image
    std::vector<std::string> parts;  // by index, "" until it comes; sized by the first
    int have = 0;
    size_t bytes = 0;
  };
  std::map<std::string, Waiting> waiting_;  // by session uuid
};

}  // namespace ves::server
