// Live notices between replicas (server/live_notice.h): what one replica
// NOTIFYs the others is parsed as untrusted input, so every malformed or
// oversize payload is refused naming what was wrong; remote sessions in the
// hub (listed, watched, ended, expired; never over a local one); the relay
// ignores its own replica's notices. No database: docs/web.md.
#include "server/live_notice.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "server/live_hub.h"
#include "server/live_pg_relay.h"

namespace ves::server {
namespace {

using nlohmann::json;

LiveSessionInfo Info(const std::string& uuid = "5f0c6a1e-0000-4000-8000-000000000001") {
  LiveSessionInfo i;
  i.session_uuid = uuid;
  i.institution = "north";
  i.trainee_id = "t1";
  i.case_id = "sample";
  i.case_version = 3;
  i.station = "station one";
  i.started_unix_ms = 1764672000000;
  i.frames = 7;
  return i;
}

// 80-point scope and colon, as ves-station run sends them.
v1::LiveFrame Frame(int k, size_t jpeg_bytes = 0) {
  v1::LiveFrame f;
  f.set_t_s(0.05 * k);
  f.set_tip_arc_m(0.01 * k);
  f.set_hand_force_n(2.5);
  f.set_dropped_frames(2);
  for (int i = 0; i < 80; ++i) {
    for (float v : {0.001f * i, -0.002f * i, 0.003f * i * k}) f.add_scope_xyz_m(v);
    for (float v : {0.01f * i, 0.0f, 0.02f * i}) f.add_colon_xyz_m(v);
  }
  for (float v : {0.0f, 0.0f, 0.01f * k}) f.add_tip_xyz_m(v);
  if (jpeg_bytes > 0) {
    std::string jpeg(jpeg_bytes, '\x42');
    jpeg.replace(0, 3, "\xFF\xD8\xFF");
    f.set_endoscope_jpeg(jpeg);
  }
  return f;
}

LiveNotice Notice(LiveNoticeKind kind, const std::string& replica = "a1b2c3d4e5f60718", int k = 1) {
  LiveNotice n;
  n.kind = kind;
  n.replica_id = replica;
  n.info = Info();
  if (kind == LiveNoticeKind::kFrame) n.frame = Frame(k);
  return n;
}

std::string Encode(const LiveNotice& n) {
  const std::string payload = EncodeLiveNotice(n);
  EXPECT_FALSE(payload.empty());
  return payload;
}

// Refused, with `why` naming `field`.
void ExpectRefused(const std::string& payload, const std::string& field, const std::string& what) {
  std::string why;
  EXPECT_FALSE(ParseLiveNotice(payload, &why).has_value()) << what;
  EXPECT_NE(why.find(field), std::string::npos) << what << ": " << why;
}

TEST(LiveNotice, AFrameRoundTripsWithItsSessionAndNumbers) {
  const LiveNotice sent = Notice(LiveNoticeKind::kFrame);
  const std::string payload = Encode(sent);
  EXPECT_LT(payload.size(), 4000u) << "80-point shapes fit with room to spare";
  std::string why;
  const auto got = ParseLiveNotice(payload, &why);
  ASSERT_TRUE(got.has_value()) << why;
  EXPECT_EQ(got->kind, LiveNoticeKind::kFrame);
  EXPECT_EQ(got->replica_id, "a1b2c3d4e5f60718");
  EXPECT_EQ(got->info.session_uuid, sent.info.session_uuid);
  EXPECT_EQ(got->info.institution, "north");
  EXPECT_EQ(got->info.trainee_id, "t1");
  EXPECT_EQ(got->info.case_id, "sample");
  EXPECT_EQ(got->info.case_version, 3u);
  EXPECT_EQ(got->info.station, "station one");
  EXPECT_EQ(got->info.started_unix_ms, 1764672000000);
  EXPECT_EQ(got->info.frames, 7u);
  EXPECT_EQ(got->info.station_dropped, 2u);
  EXPECT_EQ(got->frame.SerializeAsString(), sent.frame.SerializeAsString());
}

TEST(LiveNotice, BeginAndEndRoundTrip) {
  std::string why;
  const auto begin = ParseLiveNotice(Encode(Notice(LiveNoticeKind::kBegin)), &why);
  ASSERT_TRUE(begin.has_value()) << why;
  EXPECT_EQ(begin->kind, LiveNoticeKind::kBegin);
  EXPECT_EQ(begin->info.trainee_id, "t1");
  const auto end = ParseLiveNotice(Encode(Notice(LiveNoticeKind::kEnd)), &why);
  ASSERT_TRUE(end.has_value()) << why;
  EXPECT_EQ(end->kind, LiveNoticeKind::kEnd);
  EXPECT_EQ(end->info.session_uuid, Info().session_uuid);
}

TEST(LiveNotice, ASmallJpegRidesAlongABigOneIsLeftOut) {
  LiveNotice n = Notice(LiveNoticeKind::kFrame);
  n.frame = Frame(1, 1500);
  bool dropped = true;
  std::string payload = EncodeLiveNotice(n, &dropped);
  EXPECT_FALSE(dropped);
  std::string why;
  auto got = ParseLiveNotice(payload, &why);
  ASSERT_TRUE(got.has_value()) << why;
  EXPECT_EQ(got->frame.endoscope_jpeg().size(), 1500u);

  n.frame = Frame(1, 20 << 10);  // a typical 320-pixel view
  payload = EncodeLiveNotice(n, &dropped);
  EXPECT_TRUE(dropped);
  ASSERT_FALSE(payload.empty());
  EXPECT_LE(payload.size(), kMaxLiveNoticeBytes);
  got = ParseLiveNotice(payload, &why);
  ASSERT_TRUE(got.has_value()) << why;
  EXPECT_TRUE(got->frame.endoscope_jpeg().empty());
  EXPECT_EQ(got->frame.scope_xyz_m_size(), 240);
}

TEST(LiveNotice, TheLargestFrameTheServerAcceptsStillFits) {
  LiveNotice n = Notice(LiveNoticeKind::kFrame);
  n.frame.clear_scope_xyz_m();
  n.frame.clear_colon_xyz_m();
  for (int i = 0; i < 3 * kMaxLivePolylinePoints; ++i) {
    n.frame.add_scope_xyz_m(0.123456f * i);
    n.frame.add_colon_xyz_m(-0.654321f * i);
  }
  const std::string id(128, 'x');  // every id at its bound
  n.info.session_uuid = n.info.institution = n.info.trainee_id = n.info.case_id = id;
  n.info.station = id;
  const std::string payload = EncodeLiveNotice(n);
  ASSERT_FALSE(payload.empty());
  std::string why;
  EXPECT_TRUE(ParseLiveNotice(payload, &why).has_value()) << why;
}

TEST(LiveNotice, MalformedPayloadsAreRefusedNamingTheProblem) {
  const json good = json::parse(Encode(Notice(LiveNoticeKind::kFrame)));
  const auto with = [&](const std::string& key, const json& value) {
    json j = good;
    j[key] = value;
    return j.dump();
  };
  const auto without = [&](const std::string& key) {
    json j = good;
    j.erase(key);
    return j.dump();
  };
  ExpectRefused(std::string(kMaxLiveNoticeBytes + 1, ' '), "more than 7999", "oversize");
  ExpectRefused("", "not JSON", "empty");
  ExpectRefused("{\"v\":1,", "not JSON", "cut short");
  ExpectRefused(std::string(3990, '[') + std::string(3990, ']'), "not a JSON object",
                "deeply nested");
  ExpectRefused("[1,2]", "not a JSON object", "an array");
  ExpectRefused(with("v", 2), "v:", "a newer version");
  ExpectRefused(without("v"), "v:", "no version");
  ExpectRefused(with("kind", "explode"), "kind", "unknown kind");
  ExpectRefused(with("kind", 3), "kind", "numeric kind");
  ExpectRefused(without("replica"), "replica", "no replica");
  ExpectRefused(with("replica", std::string(65, 'a')), "replica", "long replica id");
  ExpectRefused(with("replica", json::array()), "replica", "replica not a string");
  ExpectRefused(with("session", ""), "session", "empty session");
  ExpectRefused(with("session", "abc\x1b[2Jdef"), "session", "control characters");
  ExpectRefused(with("session", std::string(129, 'u')), "session", "long session");
  ExpectRefused(without("institution"), "institution", "no institution");
  ExpectRefused(with("trainee", 12), "trainee", "numeric trainee");
  {
    std::string bad_utf8 = good.dump();
    bad_utf8.replace(bad_utf8.find("\"sample\""), 8, "\"\xC0\xAF\"");
    ExpectRefused(bad_utf8, "not JSON", "invalid UTF-8");
  }
  ExpectRefused(with("case_version", -1), "case_version", "negative version");
  ExpectRefused(with("case_version", 1.5), "case_version", "fractional version");
  ExpectRefused(with("case_version", 1ull << 32), "case_version", "version over 32 bits");
  ExpectRefused(with("started_unix_ms", "yesterday"), "started_unix_ms", "a string clock");
  ExpectRefused(with("started_unix_ms", 1ull << 62), "started_unix_ms", "a clock past 9999");
  ExpectRefused(with("frames", -5), "frames", "negative frames");
  ExpectRefused(without("frame"), "frame", "a frame notice without one");
  ExpectRefused(with("frame", "not*base64!"), "frame: not base64", "bad alphabet");
  ExpectRefused(with("frame", "QUJD\nREVG"), "frame: not base64", "whitespace");
  ExpectRefused(with("frame", "QQ==QUJD"), "frame: not base64", "data after padding");
  ExpectRefused(with("frame", "/////w=="), "LiveFrame", "not protobuf");
  {
    v1::LiveFrame f = Frame(1);
    f.set_t_s(std::numeric_limits<double>::quiet_NaN());
    LiveNotice n = Notice(LiveNoticeKind::kFrame);
    n.frame = f;
    ExpectRefused(EncodeLiveNotice(n), "frame.t_s", "NaN time (CheckLiveFrame)");
    n.frame = Frame(1);
    n.frame.add_scope_xyz_m(1.0f);
    ExpectRefused(EncodeLiveNotice(n), "frame.scope_xyz_m", "not triples");
    n.frame = Frame(1);
    n.frame.set_hand_force_n(1e9);
    ExpectRefused(EncodeLiveNotice(n), "frame.hand_force_n", "absurd force");
    n.frame = Frame(1);
    n.frame.set_endoscope_jpeg("GIF89a");
    ExpectRefused(EncodeLiveNotice(n), "frame.endoscope_jpeg", "not a JPEG");
    // Ids inside the frame would bypass the envelope's checks;
    // EncodeLiveNotice clears them, so the frame is forged by hand.
    v1::LiveFrame with_id = Frame(1);
    with_id.set_trainee_id("someone");
    std::string raw = with_id.SerializeAsString();
    static const char* kAlphabet =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string b64;
    for (size_t i = 0; i < raw.size(); i += 3) {
      uint32_t v = static_cast<uint8_t>(raw[i]) << 16;
      if (i + 1 < raw.size()) v |= static_cast<uint8_t>(raw[i + 1]) << 8;
      if (i + 2 < raw.size()) v |= static_cast<uint8_t>(raw[i + 2]);
      b64 += kAlphabet[(v >> 18) & 63];
      b64 += kAlphabet[(v >> 12) & 63];
      b64 += i + 1 < raw.size() ? kAlphabet[(v >> 6) & 63] : '=';
      b64 += i + 2 < raw.size() ? kAlphabet[v & 63] : '=';
    }
    ExpectRefused(with("frame", b64), "carries ids", "ids inside the frame");
  }
  // Unknown extra fields are ignored (a newer replica may add some).
  std::string why;
  EXPECT_TRUE(ParseLiveNotice(with("future", "x"), &why).has_value()) << why;
}

TEST(LiveHubRemote, ARemoteSessionIsListedWatchedAndEnded) {
  LiveHub hub;
  ASSERT_TRUE(hub.ApplyRemote(Notice(LiveNoticeKind::kBegin)));
  auto listed = hub.List("north");
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].origin_replica, "a1b2c3d4e5f60718");
  EXPECT_EQ(listed[0].trainee_id, "t1");
  EXPECT_TRUE(hub.List("south").empty()) << "institution rules as for local sessions";
  std::string why;
  auto viewer = hub.Watch(Info().session_uuid, &why);
  ASSERT_TRUE(viewer) << why;
  ASSERT_TRUE(hub.ApplyRemote(Notice(LiveNoticeKind::kFrame, "a1b2c3d4e5f60718", 5)));
  bool ended = false;
  const json f = json::parse(viewer->Next(1000, &ended));
  EXPECT_DOUBLE_EQ(f["tip_arc_m"].get<double>(), 0.05);
  EXPECT_EQ(hub.List("north")[0].frames, 7u) << "the holding replica's count";
  ASSERT_TRUE(hub.ApplyRemote(Notice(LiveNoticeKind::kEnd)));
  EXPECT_EQ(viewer->Next(1000, &ended), "");
  EXPECT_TRUE(ended);
  EXPECT_TRUE(hub.List("").empty());
}

TEST(LiveHubRemote, AFrameWithoutItsBeginStartsTheSession) {
  LiveHub hub;
  ASSERT_TRUE(hub.ApplyRemote(Notice(LiveNoticeKind::kFrame)));
  LiveSessionInfo info;
  ASSERT_TRUE(hub.Find(Info().session_uuid, &info));
  EXPECT_EQ(info.institution, "north");
  EXPECT_GT(info.last_frame_unix_ms, 0);
}

TEST(LiveHubRemote, ASilentRemoteSessionExpiresAndItsViewersAreTold) {
  LiveHub hub;
  ASSERT_TRUE(hub.ApplyRemote(Notice(LiveNoticeKind::kBegin)));
  std::string why;
  auto viewer = hub.Watch(Info().session_uuid, &why);
  ASSERT_TRUE(viewer);
  EXPECT_EQ(hub.ExpireRemote(60000), 0) << "heard from just now";
  LiveSessionInfo local = Info("5f0c6a1e-0000-4000-8000-000000000002");
  ASSERT_TRUE(hub.Begin(local, &why)) << why;
  EXPECT_EQ(hub.ExpireRemote(0), 1) << "only the remote one";
  bool ended = false;
  viewer->Next(1000, &ended);
  EXPECT_TRUE(ended);
  ASSERT_EQ(hub.List("").size(), 1u);
  EXPECT_TRUE(hub.List("")[0].origin_replica.empty());
}

TEST(LiveHubRemote, NoticesNeverOverrideASessionStreamingHere) {
  LiveHub hub;
  std::string why;
  ASSERT_TRUE(hub.Begin(Info(), &why)) << why;
  LiveNotice other = Notice(LiveNoticeKind::kBegin);
  other.info.institution = "south";
  ASSERT_TRUE(hub.ApplyRemote(other));
  ASSERT_TRUE(hub.ApplyRemote(Notice(LiveNoticeKind::kEnd)));
  LiveSessionInfo info;
  ASSERT_TRUE(hub.Find(Info().session_uuid, &info));
  EXPECT_TRUE(info.origin_replica.empty());
  EXPECT_EQ(info.institution, "north");
}

TEST(LiveHubRemote, AStationReconnectingHereTakesOverTheRemoteSessionAndItsViewers) {
  LiveHub hub;
  ASSERT_TRUE(hub.ApplyRemote(Notice(LiveNoticeKind::kBegin)));
  std::string why;
  auto viewer = hub.Watch(Info().session_uuid, &why);
  ASSERT_TRUE(viewer);
  ASSERT_TRUE(hub.Begin(Info(), &why)) << why;
  hub.Publish(Info().session_uuid, Frame(9));
  bool ended = false;
  const std::string next = viewer->Next(1000, &ended);
  ASSERT_FALSE(next.empty());
  EXPECT_DOUBLE_EQ(json::parse(next)["tip_arc_m"].get<double>(), 0.09);
  EXPECT_EQ(hub.ExpireRemote(0), 0) << "it is local now";
}

TEST(LiveHubRemote, RemoteSessionsAreBounded) {
  LiveHub hub;
  LiveNotice n = Notice(LiveNoticeKind::kBegin);
  for (int i = 0; i < kMaxLiveSessions; ++i) {
    n.info.session_uuid = "s" + std::to_string(i);
    ASSERT_TRUE(hub.ApplyRemote(n));
  }
  n.info.session_uuid = "one-too-many";
  EXPECT_FALSE(hub.ApplyRemote(n));
  std::string why;
  EXPECT_TRUE(hub.Begin(Info(), &why)) << "local streams have their own bound: " << why;
}

// A relay that is never started (no database): its listener's handling of
// payloads.
TEST(LivePgRelay, IgnoresItsOwnNoticesAndCountsRefusals) {
  LiveHub hub;
  LivePgRelay relay(LivePgRelayOptions{}, &hub);
  relay.OnNotification(Encode(Notice(LiveNoticeKind::kBegin, relay.replica_id())));
  EXPECT_TRUE(hub.List("").empty()) << "its own notice";
  relay.OnNotification(Encode(Notice(LiveNoticeKind::kBegin, "0123456789abcdef")));
  EXPECT_EQ(hub.List("").size(), 1u);
  relay.OnNotification("{\"v\":1,\"kind\":\"frame\"}");
  relay.OnNotification("\x01\x02 garbage");
  const LivePgRelay::Stats s = relay.stats();
  EXPECT_EQ(s.received, 1u);
  EXPECT_EQ(s.refused, 2u);
  EXPECT_EQ(relay.replica_id().size(), 16u);
}

}  // namespace
}  // namespace ves::server
