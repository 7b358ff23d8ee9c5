#include "server/live_pg_relay.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <pqxx/pqxx>
#include <random>

#include "patient_db/limits.h"
#include "server/auth.h"

namespace ves::server {
namespace {

// 64 random bits as hex: unique enough among a handful of replicas, and
// new on every start, so a restarted replica is never taken for its old self.
std::string NewReplicaId() {
  std::random_device rd;
  const uint64_t bits = (static_cast<uint64_t>(rd()) << 32) ^ rd();
  char out[17];
  std::snprintf(out, sizeof out, "%016llx", static_cast<unsigned long long>(bits));
  return out;
}

int NextBackoffMs(int previous_ms, int max_ms) {
  return previous_ms == 0 ? 250 : std::min(previous_ms * 2, max_ms);
}

// A database host that vanishes without closing the socket would leave the
// listener waiting forever (LISTEN sends nothing) and a connect, or the
// shutdown waiting on it, hanging for minutes: TCP keepalives, a user
// timeout and a connect timeout make such a connection fail within ~30 s.
std::string WithDeadPeerTimeouts(const std::string& url) {
  if (url.find("keepalives") != std::string::npos ||
      url.find("tcp_user_timeout") != std::string::npos ||
      url.find("connect_timeout") != std::string::npos) {
    return url;  // the operator chose
  }
  return url + (url.find('?') == std::string::npos ? "?" : "&") +
         "connect_timeout=5&keepalives=1&keepalives_idle=10&keepalives_interval=5&"
         "keepalives_count=3&tcp_user_timeout=30000";
}

class Receiver final : public pqxx::notification_receiver {
 public:
  Receiver(pqxx::connection_base& conn, const std::string& channel, LivePgRelay* relay)
      : pqxx::notification_receiver(conn, channel), relay_(relay) {}
  void operator()(const std::string& payload, int /*backend_pid*/) override {
    relay_->OnNotification(payload);
  }

 private:
  LivePgRelay* relay_;
};

}  // namespace

std::string LiveChannelFor(const std::string& schema) {
  if (schema == "public") return "ves_live";
  return "ves_live_" + Sha256Hex(schema).substr(0, 16);
}

std::string LivePgRelay::Prepare(pqxx::connection_base& conn, const char* role) const {
  pqxx::nontransaction q(conn);
  std::string channel = options_.channel;
  if (channel.empty()) {
    const pqxx::result r = q.exec("SELECT current_schema()");
    channel = LiveChannelFor(r.empty() || r[0][0].is_null() ? "public" : r[0][0].c_str());
  }
  // Named in pg_stat_activity, so an operator can tell these connections
  // apart from the store's pool.
  q.exec("SET application_name = " + q.quote(std::string("ves live ") + role + " " + channel));
  return channel;
}

LivePgRelay::LivePgRelay(LivePgRelayOptions options, LiveHub* hub)
    : options_(std::move(options)),
      url_(WithDeadPeerTimeouts(options_.url)),
      hub_(hub),
      replica_id_(NewReplicaId()) {}

LivePgRelay::~LivePgRelay() { Stop(std::chrono::milliseconds(0)); }

void LivePgRelay::Start() {
  if (started_) return;
  started_ = true;
  spdlog::info("live relay: replica {} shares live sessions through PostgreSQL", replica_id_);
  publisher_ = std::thread([this] { RunPublisher(); });
  listener_ = std::thread([this] { RunListener(); });
}

void LivePgRelay::Stop(std::chrono::milliseconds drain) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    drain_until_ = std::chrono::steady_clock::now() + drain;
  }
  queue_cv_.notify_all();
  stop_cv_.notify_all();
  if (publisher_.joinable()) publisher_.join();
  if (listener_.joinable()) listener_.join();
  if (!started_) return;
  const Stats s = stats();
  spdlog::info(
      "live relay: stopped; {} notices published, {} frames thinned out, dropped {} (queue "
      "full) {} (too big) {} (connection lost); images: {} published, {} thinned out, {} "
      "dropped; {} received, {} refused, {} remote sessions expired; images from other "
      "replicas: {} received, {} completed",
      s.published, s.throttled, s.dropped_full, s.dropped_oversize, s.dropped_failed,
      s.images_published, s.images_thinned, s.images_dropped, s.received, s.refused, s.expired,
      s.images_received, s.images_completed);
}

bool LivePgRelay::listening() const {
  std::lock_guard lock(mutex_);
  return listening_;
}

LivePgRelay::Stats LivePgRelay::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void LivePgRelay::Began(const LiveSessionInfo& info) {
  Outgoing o;
  o.kind = LiveNoticeKind::kBegin;
  o.info = info;
  Enqueue(std::move(o));
}

void LivePgRelay::Framed(const LiveSessionInfo& info, const v1::LiveFrame& frame) {
  const int64_t now = SteadyNowMs();
  const std::string& jpeg = frame.endoscope_jpeg();
  const int parts = LiveImagePartCount(jpeg.size());
  Outgoing o;
  {
    std::lock_guard lock(mutex_);
    Outbound& out = outbound_[info.session_uuid];
    bool with_image = false;
    if (!jpeg.empty()) {
      // The receiver shows only whole JPEGs (FF D9 at the end): one that is
      // not is not sent.
      if (parts == 0 || jpeg.size() < 2 || jpeg.compare(jpeg.size() - 2, 2, "\xFF\xD9") != 0) {
        ++stats_.images_dropped;
      } else if (out.any_image && now - out.last_image_ms < options_.min_image_interval_ms) {
        ++stats_.images_thinned;
      } else {
        with_image = true;
      }
    }
    if (!with_image && out.any_frame && now - out.last_frame_ms < options_.min_frame_interval_ms) {
      ++stats_.throttled;
      return;
    }
    out.any_frame = true;
    out.last_frame_ms = now;
    if (with_image) {
      out.any_image = true;
      out.last_image_ms = now;
      o.image = ++out.images;
    }
  }
  o.kind = LiveNoticeKind::kFrame;
  o.info = info;
  o.frame = frame;
  std::shared_ptr<const std::string> image;
  if (o.image != 0) {
    image = std::make_shared<const std::string>(std::move(*o.frame.mutable_endoscope_jpeg()));
  }
  o.frame.clear_endoscope_jpeg();
  EnqueueFrame(std::move(o), std::move(image), parts);
}

void LivePgRelay::Ended(const std::string& session_uuid) {
  {
    std::lock_guard lock(mutex_);
    outbound_.erase(session_uuid);
  }
  Outgoing o;
  o.kind = LiveNoticeKind::kEnd;
  o.info.session_uuid = session_uuid;
  Enqueue(std::move(o));
}

void LivePgRelay::Enqueue(Outgoing o) {
  {
    std::lock_guard lock(mutex_);
    if (queue_.size() >= options_.queue_capacity) {
      // Dropping the newest keeps what is queued in order; a lost end is
      // made good by the other replicas' silence timeout.
      ++stats_.dropped_full;
      return;
    }
    queue_.push_back(std::move(o));
  }
  queue_cv_.notify_one();
}

void LivePgRelay::EnqueueFrame(Outgoing frame, std::shared_ptr<const std::string> jpeg, int parts) {
  {
    std::lock_guard lock(mutex_);
    const size_t room = options_.queue_capacity - std::min(queue_.size(), options_.queue_capacity);
    if (frame.image != 0 && room < 1 + static_cast<size_t>(parts)) {
      // Part of an image is no use to anyone: the frame goes without it.
      ++stats_.images_dropped;
      frame.image = 0;
    }
    if (room < 1) {
      ++stats_.dropped_full;
      return;
    }
    const uint64_t image = frame.image;
    const std::string session = frame.info.session_uuid;
    queue_.push_back(std::move(frame));
    for (int i = 0; image != 0 && i < parts; ++i) {
      Outgoing o;
      o.kind = LiveNoticeKind::kImage;
      o.info.session_uuid = session;
      o.image = image;
      o.part = i;
      o.parts = parts;
      o.jpeg = jpeg;
      queue_.push_back(std::move(o));
    }
  }
  queue_cv_.notify_one();
}

void LivePgRelay::RunPublisher() {
  std::unique_ptr<pqxx::connection> conn;
  std::string channel;
  int backoff_ms = 0;
  bool failing = false;
  // An image whose frame or part was lost: its remaining parts are no use.
  std::string lost_session;
  uint64_t lost_image = 0;
  while (true) {
    Outgoing o;
    {
      std::unique_lock lock(mutex_);
      queue_cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty() || (stopping_ && std::chrono::steady_clock::now() >= drain_until_)) {
        return;
      }
      o = std::move(queue_.front());
      queue_.pop_front();
    }
    const bool image_part = o.kind == LiveNoticeKind::kImage;
    if (image_part && o.image == lost_image && o.info.session_uuid == lost_session) continue;
    const std::string session = o.info.session_uuid;
    const auto lose_image = [&] {
      if (o.image == 0) return;
      lost_session = session;
      lost_image = o.image;
      std::lock_guard lock(mutex_);
      ++stats_.images_dropped;
    };
    LiveNotice notice;
    notice.kind = o.kind;
    notice.replica_id = replica_id_;
    notice.info = std::move(o.info);
    notice.frame = std::move(o.frame);
    notice.image = o.image;
    if (image_part) {
      notice.part.part = o.part;
      notice.part.parts = o.parts;
      notice.part.bytes =
          o.jpeg->substr(static_cast<size_t>(o.part) * kLiveImagePartBytes, kLiveImagePartBytes);
    }
    const std::string payload = EncodeLiveNotice(notice);
    if (payload.empty()) {
      {
        std::lock_guard lock(mutex_);
        ++stats_.dropped_oversize;
      }
      lose_image();
      continue;
    }
    try {
      if (!conn) {
        conn = std::make_unique<pqxx::connection>(url_);
        channel = Prepare(*conn, "notify");
      }
      pqxx::nontransaction q(*conn);
      q.exec_params("SELECT pg_notify($1, $2)", channel, payload);
      if (failing) spdlog::info("live relay: publishing to PostgreSQL again");
      failing = false;
      backoff_ms = 0;
      std::lock_guard lock(mutex_);
      ++stats_.published;
      if (image_part && o.part + 1 == o.parts) ++stats_.images_published;
    } catch (const std::exception& e) {
      conn.reset();
      backoff_ms = NextBackoffMs(backoff_ms, options_.max_backoff_ms);
      if (!failing) {
        spdlog::warn(
            "live relay: cannot publish to PostgreSQL ({}); other replicas miss this replica's "
            "live sessions until it reconnects (retrying with backoff up to {} ms)",
            e.what(), options_.max_backoff_ms);
      }
      failing = true;
      {
        std::lock_guard lock(mutex_);
        ++stats_.dropped_failed;
      }
      lose_image();
      std::unique_lock lock(mutex_);
      queue_cv_.wait_for(lock, std::chrono::milliseconds(backoff_ms), [&] { return stopping_; });
    }
  }
}

void LivePgRelay::RunListener() {
  int backoff_ms = 0;
  bool connected_once = false;
  while (true) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
    }
    bool was_listening = false;
    try {
      pqxx::connection conn(url_);
      const std::string channel = Prepare(conn, "listen");
      Receiver receiver(conn, channel, this);  // LISTEN
      conn.get_notifs();
      was_listening = true;
      {
        std::lock_guard lock(mutex_);
        listening_ = true;
        if (connected_once) ++stats_.listener_reconnects;
      }
      spdlog::info("live relay: {} on channel '{}'",
                   connected_once ? "listening again" : "listening", channel);
      connected_once = true;
      backoff_ms = 0;
      while (true) {
        {
          std::lock_guard lock(mutex_);
          if (stopping_) {
            listening_ = false;
            return;
          }
        }
        conn.await_notification(0, 200000);  // 0.2 s: stop and expiry stay prompt
        if (!conn.is_open()) throw pqxx::broken_connection("the LISTEN connection closed");
        ExpireTick();
      }
    } catch (const std::exception& e) {
      {
        std::lock_guard lock(mutex_);
        listening_ = false;
      }
      backoff_ms = NextBackoffMs(backoff_ms, options_.max_backoff_ms);
      spdlog::warn(
          "live relay: LISTEN connection to PostgreSQL {} ({}); other replicas' live sessions "
          "are not seen, reconnecting in {} ms",
          was_listening ? "lost" : "failed", e.what(), backoff_ms);
      if (!Backoff(backoff_ms)) return;
    }
  }
}

bool LivePgRelay::Backoff(int ms) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  while (std::chrono::steady_clock::now() < until) {
    {
      std::unique_lock lock(mutex_);
      if (stop_cv_.wait_for(lock, std::chrono::milliseconds(200), [&] { return stopping_; })) {
        return false;
      }
    }
    ExpireTick();  // remote sessions end on time while the database is away
  }
  return true;
}

void LivePgRelay::ExpireTick() {
  const int64_t now = SteadyNowMs();
  if (now - last_expire_ms_ < 250) return;
  last_expire_ms_ = now;
  const int expired = hub_->ExpireRemote(options_.remote_silence_ms);
  // Frames waiting for images of sessions that ended or expired, or moved
  // to another replica, are freed.
  images_.Retain([&](const std::string& session_uuid, const std::string& replica) {
    LiveSessionInfo info;
    return hub_->Find(session_uuid, &info) && info.origin_replica == replica;
  });
  if (expired > 0) {
    spdlog::info("live relay: {} remote live session(s) ended after {} ms without a notice",
                 expired, options_.remote_silence_ms);
    std::lock_guard lock(mutex_);
    stats_.expired += static_cast<uint64_t>(expired);
  }
}

void LivePgRelay::OnNotification(const std::string& payload) {
  std::string why;
  std::optional<LiveNotice> notice = ParseLiveNotice(payload, &why);
  if (!notice) {
    {
      std::lock_guard lock(mutex_);
      ++stats_.refused;
    }
    LogRefused(why);
    return;
  }
  if (notice->replica_id == replica_id_) return;  // our own, back from the channel
  if (notice->kind == LiveNoticeKind::kImage) {
    OnImagePart(*notice);
    return;
  }
  const bool awaits_image = notice->kind == LiveNoticeKind::kFrame && notice->image != 0;
  LiveNotice applied;
  if (awaits_image) {
    // The hub hears of the session now; viewers get the frame with its
    // image, as a local frame that carries one.
    applied.kind = LiveNoticeKind::kBegin;
    applied.replica_id = notice->replica_id;
    applied.info = notice->info;
  }
  if (!hub_->ApplyRemote(awaits_image ? applied : *notice)) {
    {
      std::lock_guard lock(mutex_);
      ++stats_.refused;
    }
    LogRefused("session " + notice->info.session_uuid + ": " + std::to_string(kMaxLiveSessions) +
               " remote live sessions already");
    return;
  }
  // A newer frame, or the end, frees what waited for an image that did not come.
  if (awaits_image) {
    images_.Await(std::move(*notice));
  } else if (notice->kind != LiveNoticeKind::kBegin) {
    images_.Forget(notice->info.session_uuid);
  }
  std::lock_guard lock(mutex_);
  ++stats_.received;
  if (awaits_image) ++stats_.images_received;
}

void LivePgRelay::OnImagePart(const LiveNotice& part) {
  LiveNotice frame;
  std::string why;
  switch (images_.Add(part, &frame, &why)) {
    case LiveImageAssembly::Outcome::kPending: {
      std::lock_guard lock(mutex_);
      ++stats_.received;
      return;
    }
    case LiveImageAssembly::Outcome::kComplete: {
      const bool shown = hub_->ApplyRemote(frame);
      std::lock_guard lock(mutex_);
      ++stats_.received;
      if (shown) ++stats_.images_completed;
      return;
    }
    case LiveImageAssembly::Outcome::kIgnored:
      return;  // its frame was lost or ended: nothing to show it with
    case LiveImageAssembly::Outcome::kRefused: {
      {
        std::lock_guard lock(mutex_);
        ++stats_.refused;
      }
      LogRefused("session " + part.info.session_uuid + " " + why);
      return;
    }
  }
}

void LivePgRelay::LogRefused(const std::string& why) {
  // At most one line a second: anyone who can connect to the database can
  // write to the channel, and must not be able to flood the log.
  const int64_t now = SteadyNowMs();
  if (last_refusal_log_ms_ != 0 && now - last_refusal_log_ms_ < 1000) {
    ++refusals_unlogged_;
    return;
  }
  spdlog::warn("live relay: refused a notice: {}{}", patient_db::PrintableExcerpt(why, 200),
               refusals_unlogged_ > 0
                   ? " (and " + std::to_string(refusals_unlogged_) + " more not logged)"
                   : std::string());
  refusals_unlogged_ = 0;
  last_refusal_log_ms_ = now;
}

}  // namespace ves::server
