#include "station/sync/live_stream.h"

#include <chrono>
#include <utility>

#include "ves/v1/live.grpc.pb.h"

namespace ves::sync {
namespace {

constexpr int kMaxConnectAttempts = 3;

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// The server refused the stream itself: retrying would not help.
bool Permanent(grpc::StatusCode code) {
  return code == grpc::StatusCode::INVALID_ARGUMENT || code == grpc::StatusCode::UNAUTHENTICATED ||
         code == grpc::StatusCode::PERMISSION_DENIED ||
         code == grpc::StatusCode::FAILED_PRECONDITION || code == grpc::StatusCode::UNIMPLEMENTED;
}

}  // namespace

LiveStreamer::LiveStreamer(ServerEndpoint endpoint, ves::v1::LiveFrame first)
    : endpoint_(std::move(endpoint)), first_(std::move(first)) {
  CheckEndpoint(endpoint_);
  thread_ = std::thread([this] { Run(); });
}

LiveStreamer::~LiveStreamer() { Close(0); }

void LiveStreamer::Offer(ves::v1::LiveFrame frame) {
  std::unique_lock lock(mutex_, std::try_to_lock);
  // The haptic loop never waits: a busy lock or a full queue drops the frame.
  if (!lock.owns_lock() || closing_ || !connected_) {
    ++dropped_;
    return;
  }
  ++stats_.offered;
  if (queue_.size() >= kLiveQueueFrames) {
    queue_.pop_front();  // the newest is worth more than the oldest
    ++dropped_;
  }
  frame.set_sent_unix_ms(NowMs());
  queue_.push_back(std::move(frame));
  lock.unlock();
  cv_.notify_one();
}

bool LiveStreamer::Idle() {
  std::unique_lock lock(mutex_, std::try_to_lock);
  return lock.owns_lock() && connected_ && !closing_ && queue_.empty();
}

LiveStreamStats LiveStreamer::Close(int wait_ms) {
  {
    std::unique_lock lock(mutex_);
    closing_ = true;
    cv_.notify_all();
    // A stream stuck on a dead network is cancelled rather than waited for.
    if (!cv_.wait_for(lock, std::chrono::milliseconds(wait_ms),
                      [&] { return context_ == nullptr && !connected_; }) &&
        context_ != nullptr) {
      context_->TryCancel();
    }
  }
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  LiveStreamStats out = stats_;
  out.dropped = dropped_.load();
  return out;
}

void LiveStreamer::RequestClose(int wait_ms) {
  std::lock_guard lock(mutex_);
  if (closing_) return;
  closing_ = true;
  cancel_at_ = std::chrono::steady_clock::now() + std::chrono::milliseconds(wait_ms);
  cv_.notify_all();
}

bool LiveStreamer::Reap(LiveStreamStats* stats) {
  if (!finished_.load(std::memory_order_acquire)) {
    std::unique_lock lock(mutex_, std::try_to_lock);
    // A stream stuck on a dead network is cancelled rather than waited for.
    if (lock.owns_lock() && closing_ && context_ != nullptr &&
        std::chrono::steady_clock::now() >= cancel_at_) {
      context_->TryCancel();
    }
    return false;
  }
  if (thread_.joinable()) thread_.join();  // it has returned: no wait
  std::lock_guard lock(mutex_);
  *stats = stats_;
  stats->dropped = dropped_.load();
  return true;
}

void LiveStreamer::Run() {
  for (int attempt = 0; attempt < kMaxConnectAttempts; ++attempt) {
    {
      std::unique_lock lock(mutex_);
      if (closing_) break;
      if (attempt > 0) {
        // Backoff between attempts; Close() cuts it short.
        cv_.wait_for(lock, std::chrono::seconds(attempt), [&] { return closing_; });
        if (closing_) break;
      }
    }
    if (!Stream()) break;
    std::lock_guard lock(mutex_);
    if (closing_) break;
  }
  std::lock_guard lock(mutex_);
  if (!closing_) stats_.gave_up = true;
  connected_ = false;
  cv_.notify_all();
  finished_.store(true, std::memory_order_release);
}

bool LiveStreamer::Stream() {
  auto stub = ves::v1::Live::NewStub(MakeChannel(endpoint_));
  grpc::ClientContext context;
  context.AddMetadata("authorization", "Bearer " + endpoint_.token);
  ves::v1::LiveStreamSummary summary;
  {
    std::lock_guard lock(mutex_);
    if (closing_) return false;
    context_ = &context;
    ++stats_.connects;
  }
  auto writer = stub->StreamSession(&context, &summary);
  ves::v1::LiveFrame frame = first_;
  frame.set_sent_unix_ms(NowMs());
  bool ok = writer->Write(frame);
  {
    std::lock_guard lock(mutex_);
    connected_ = ok;
  }
  while (ok) {
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return closing_ || !queue_.empty(); });
      if (queue_.empty()) break;  // closing, all sent
      frame = std::move(queue_.front());
      queue_.pop_front();
    }
    frame.set_dropped_frames(dropped_.load());
    ok = writer->Write(frame);
    if (ok) {
      std::lock_guard lock(mutex_);
      ++stats_.sent;
    }
  }
  if (ok) writer->WritesDone();
  const grpc::Status status = writer->Finish();
  std::lock_guard lock(mutex_);
  connected_ = false;
  context_ = nullptr;
  dropped_ += queue_.size();
  queue_.clear();
  cv_.notify_all();
  if (status.ok()) {
    stats_.last_error.clear();
    return true;
  }
  stats_.last_error = "Live.StreamSession: " + status.error_message();
  return !Permanent(status.error_code());
}

}  // namespace ves::sync
