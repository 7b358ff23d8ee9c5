// Live notices between replicas (server/live_notice.h): what one replica
// NOTIFYs the others is parsed as untrusted input, so every malformed or
// oversize payload is refused naming what was wrong; remote sessions in the
// hub (listed, watched, ended, expired; never over a local one); the relay
// ignores its own replica's notices; JPEGs cross in parts, put back together
// whatever their order, and an image missing a part is never shown. No
// database: docs/web.md.
#include "server/live_notice.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "server/live_hub.h"
#include "server/live_image.h"
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

// A JPEG's signature and end marker around `bytes` in all of `fill`.
std::string Jpeg(size_t bytes, char fill = '\x42') {
  std::string jpeg(bytes, fill);
  jpeg.replace(0, 4, "\xFF\xD8\xFF\xE0");
  jpeg.replace(bytes - 2, 2, "\xFF\xD9");
  return jpeg;
}

// 80-point scope and colon, as ves-station run sends them.
v1::LiveFrame Frame(int k, size_t jpeg_bytes = 0) {
  v1::LiveFrame f;
  f.set_t_s(0.05 * k);
  f.set_tip_arc_m(0.01 * k);
  f.set_base_force_n(2.5);
  f.set_dropped_frames(2);
  for (int i = 0; i < 80; ++i) {
    for (float v : {0.001f * i, -0.002f * i, 0.003f * i * k}) f.add_scope_xyz_m(v);
    for (float v : {0.01f * i, 0.0f, 0.02f * i}) f.add_colon_xyz_m(v);
  }
  for (float v : {0.0f, 0.0f, 0.01f * k}) f.add_tip_xyz_m(v);
  if (jpeg_bytes > 0) f.set_endoscope_jpeg(Jpeg(jpeg_bytes));
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

// `jpeg` as image `image`'s part notices, in order.
std::vector<LiveNotice> ImageParts(const std::string& jpeg, uint64_t image,
                                   const std::string& replica = "a1b2c3d4e5f60718") {
  std::vector<LiveNotice> parts;
  const int count = LiveImagePartCount(jpeg.size());
  for (int i = 0; i < count; ++i) {
    LiveNotice n;
    n.kind = LiveNoticeKind::kImage;
    n.replica_id = replica;
    n.info.session_uuid = Info().session_uuid;
    n.image = image;
    n.part.part = i;
    n.part.parts = count;
    n.part.bytes = jpeg.substr(i * kLiveImagePartBytes, kLiveImagePartBytes);
    parts.push_back(n);
  }
  return parts;
}

// A frame notice naming image `image` (0: none).
LiveNotice FrameNotice(int k, uint64_t image) {
  LiveNotice n = Notice(LiveNoticeKind::kFrame, "a1b2c3d4e5f60718", k);
  n.image = image;
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

// A valid payload with one field replaced or removed, as JSON text: the
// malformed-payload tests start from a good notice and break one thing.
struct JsonEdits {
  json good;
  std::string with(const std::string& key, const json& value) const {
    json j = good;
    j[key] = value;
    return j.dump();
  }
  std::string without(const std::string& key) const {
    json j = good;
    j.erase(key);
    return j.dump();
  }
};

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

TEST(LiveNotice, AFramesJpegStaysOutOfItsNoticeWhichNamesTheImageInstead) {
  LiveNotice n = FrameNotice(1, 42);
  n.frame = Frame(1, 1500);
  std::string why;
  const auto got = ParseLiveNotice(Encode(n), &why);
  ASSERT_TRUE(got.has_value()) << why;
  EXPECT_TRUE(got->frame.endoscope_jpeg().empty()) << "it goes in image notices";
  EXPECT_EQ(got->image, 42u);
  EXPECT_EQ(got->frame.scope_xyz_m_size(), 240);
  const auto plain = ParseLiveNotice(Encode(Notice(LiveNoticeKind::kFrame)), &why);
  ASSERT_TRUE(plain.has_value()) << why;
  EXPECT_EQ(plain->image, 0u) << "no image follows";
}

TEST(LiveNotice, TheLargestJpegGoesInPartsThatEachFitAndRoundTrip) {
  EXPECT_EQ(LiveImagePartCount(0), 0);
  EXPECT_EQ(LiveImagePartCount(1), 1);
  EXPECT_EQ(LiveImagePartCount(kLiveImagePartBytes), 1);
  EXPECT_EQ(LiveImagePartCount(kLiveImagePartBytes + 1), 2);
  EXPECT_LE(LiveImagePartCount(kMaxLiveJpegBytes), kMaxLiveImageParts);
  EXPECT_EQ(LiveImagePartCount(kMaxLiveImageParts * kLiveImagePartBytes + 1), 0) << "refused";

  // The gRPC path's largest JPEG, with bytes that do not repeat, and the
  // envelope's ids at their bounds.
  std::string jpeg = Jpeg(kMaxLiveJpegBytes);
  for (size_t i = 4; i + 2 < jpeg.size(); ++i) jpeg[i] = static_cast<char>((i * 131) >> 3);
  std::vector<LiveNotice> parts = ImageParts(jpeg, (uint64_t{1} << 53), std::string(64, 'r'));
  ASSERT_EQ(parts.size(), 13u);
  std::string joined;
  for (LiveNotice& p : parts) {
    p.info.session_uuid = std::string(128, 's');
    const std::string payload = Encode(p);
    EXPECT_LT(payload.size(), 7300u) << "a margin under PostgreSQL's 8000 bytes";
    std::string why;
    const auto got = ParseLiveNotice(payload, &why);
    ASSERT_TRUE(got.has_value()) << why;
    EXPECT_EQ(got->kind, LiveNoticeKind::kImage);
    EXPECT_EQ(got->replica_id, std::string(64, 'r'));
    EXPECT_EQ(got->info.session_uuid, std::string(128, 's'));
    EXPECT_EQ(got->image, uint64_t{1} << 53);
    EXPECT_EQ(got->part.part, p.part.part);
    EXPECT_EQ(got->part.parts, 13);
    joined += got->part.bytes;
  }
  EXPECT_EQ(joined, jpeg);
}

TEST(LiveNotice, MalformedImagePartsAreRefusedNamingTheProblem) {
  const json good = json::parse(Encode(ImageParts(Jpeg(12000), 7)[1]));
  ASSERT_EQ(good["part"], 1);
  ASSERT_EQ(good["parts"], 3);
  const JsonEdits edit{good};
  ExpectRefused(edit.without("image"), "image: missing", "no image number");
  ExpectRefused(edit.with("image", 0), "image = 0", "image 0");
  ExpectRefused(edit.with("image", -3), "image", "negative image");
  ExpectRefused(edit.with("image", (1ull << 53) + 1), "image", "image number past 2^53");
  ExpectRefused(edit.without("parts"), "parts: missing", "no part count");
  ExpectRefused(edit.with("parts", 0), "parts = 0", "no parts");
  ExpectRefused(edit.with("parts", kMaxLiveImageParts + 1), "parts", "more parts than the bound");
  ExpectRefused(edit.with("parts", 2.5), "parts", "fractional parts");
  ExpectRefused(edit.without("part"), "part: missing", "no part index");
  ExpectRefused(edit.with("part", 3), "part = 3", "index = count");
  ExpectRefused(edit.with("part", -1), "part", "negative index");
  ExpectRefused(edit.without("data"), "data: missing", "no data");
  ExpectRefused(edit.with("data", 17), "data: missing or not a string", "numeric data");
  ExpectRefused(edit.with("data", ""), "data: empty", "empty data");
  ExpectRefused(edit.with("data", "QUJD\nREVG"), "data: not base64", "whitespace");
  ExpectRefused(edit.with("data", "QUJ"), "data: not base64", "not padded");
  ExpectRefused(edit.with("data", "not*base64!!"), "data: not base64", "bad alphabet");
  ExpectRefused(edit.with("session", "abc\x1b[2Jdef"), "session", "control characters");
  ExpectRefused(edit.with("replica", std::string(65, 'a')), "replica", "long replica id");
  std::string why;
  EXPECT_TRUE(ParseLiveNotice(good.dump(), &why).has_value()) << why;
}

TEST(LiveImageAssembly, PartsInAnyOrderCompleteTheWaitingFrameWithTheExactJpeg) {
  LiveImageAssembly assembly;
  const std::string jpeg = Jpeg(14000, '\x07');
  EXPECT_FALSE(assembly.Await(FrameNotice(4, 9)));
  std::vector<LiveNotice> parts = ImageParts(jpeg, 9);
  ASSERT_EQ(parts.size(), 3u);
  LiveNotice frame;
  std::string why;
  using Outcome = LiveImageAssembly::Outcome;
  EXPECT_EQ(assembly.Add(parts[2], &frame, &why), Outcome::kPending) << why;
  EXPECT_EQ(assembly.Add(parts[0], &frame, &why), Outcome::kPending) << why;
  ASSERT_EQ(assembly.Add(parts[1], &frame, &why), Outcome::kComplete) << why;
  EXPECT_EQ(frame.frame.endoscope_jpeg(), jpeg);
  EXPECT_DOUBLE_EQ(frame.frame.tip_arc_m(), 0.04) << "the frame that named the image";
  EXPECT_EQ(assembly.waiting(), 0u) << "freed once complete";
  EXPECT_EQ(assembly.Add(parts[1], &frame, &why), Outcome::kIgnored) << "nothing waits now";
}

TEST(LiveImageAssembly, PartsAtOddsWithTheImageDiscardItNamingWhy) {
  using Outcome = LiveImageAssembly::Outcome;
  struct Case {
    const char* what;
    std::vector<LiveNotice> parts;  // the last one is refused
    std::string why;
  };
  std::vector<Case> cases;
  {
    std::vector<LiveNotice> p = ImageParts(Jpeg(12000), 5);
    LiveNotice other = p[1];
    other.part.parts = 4;
    cases.push_back({"another part count", {p[0], other}, "an earlier part said 3 parts"});
  }
  {
    std::vector<LiveNotice> p = ImageParts(Jpeg(12000), 5);
    cases.push_back({"a part twice", {p[0], p[0]}, "came twice"});
  }
  {
    std::vector<LiveNotice> p = ImageParts(Jpeg(13 * kLiveImagePartBytes), 5);
    ASSERT_EQ(p.size(), 13u);
    cases.push_back({"over 64 KiB in all", p, "more than 65536 bytes"});
  }
  {
    std::string gif = Jpeg(9000);
    gif.replace(0, 6, "GIF89a");
    cases.push_back({"not a JPEG", ImageParts(gif, 5), "no FF D8 FF start"});
  }
  {
    std::string cut = Jpeg(9000);
    cut.back() = 'x';
    cases.push_back({"cut short", ImageParts(cut, 5), "no FF D9 end"});
  }
  for (const Case& c : cases) {
    LiveImageAssembly assembly;
    assembly.Await(FrameNotice(1, 5));
    LiveNotice frame;
    std::string why;
    for (size_t i = 0; i + 1 < c.parts.size(); ++i) {
      ASSERT_EQ(assembly.Add(c.parts[i], &frame, &why), Outcome::kPending) << c.what << ": " << why;
    }
    EXPECT_EQ(assembly.Add(c.parts.back(), &frame, &why), Outcome::kRefused) << c.what;
    EXPECT_NE(why.find(c.why), std::string::npos) << c.what << ": " << why;
    EXPECT_EQ(assembly.waiting(), 0u) << c.what << ": discarded";
  }

  // Parts no frame waits for: an older image, another replica's, or an
  // image whose frame never came.
  LiveImageAssembly assembly;
  assembly.Await(FrameNotice(1, 5));
  LiveNotice frame;
  std::string why;
  EXPECT_EQ(assembly.Add(ImageParts(Jpeg(100), 4)[0], &frame, &why), Outcome::kIgnored);
  EXPECT_EQ(assembly.Add(ImageParts(Jpeg(100), 5, "0123456789abcdef")[0], &frame, &why),
            Outcome::kIgnored);
  EXPECT_EQ(assembly.waiting(), 1u) << "still waiting for image 5";
  EXPECT_EQ(assembly.Add(ImageParts(Jpeg(100), 6)[0], &frame, &why), Outcome::kIgnored);
  EXPECT_EQ(assembly.waiting(), 0u) << "image 5's parts will not come after image 6's";
}

TEST(LiveImageAssembly, EndedOrExpiredSessionsFreeTheirWaitingImages) {
  LiveImageAssembly assembly;
  LiveNotice second = FrameNotice(1, 3);
  second.info.session_uuid = "5f0c6a1e-0000-4000-8000-000000000002";
  assembly.Await(FrameNotice(1, 3));
  assembly.Await(second);
  LiveNotice frame;
  std::string why;
  ASSERT_EQ(assembly.Add(ImageParts(Jpeg(9000), 3)[0], &frame, &why),
            LiveImageAssembly::Outcome::kPending);
  EXPECT_TRUE(assembly.Await(FrameNotice(2, 4))) << "image 3 was incomplete";
  EXPECT_EQ(assembly.waiting(), 2u) << "one per session";
  EXPECT_TRUE(assembly.Forget(Info().session_uuid));
  EXPECT_EQ(assembly.Retain([](const std::string&, const std::string&) { return false; }), 1);
  EXPECT_EQ(assembly.waiting(), 0u);
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
  n.image = uint64_t{1} << 53;
  n.frame.set_endoscope_jpeg(Jpeg(20000));  // goes in image notices
  const std::string payload = EncodeLiveNotice(n);
  ASSERT_FALSE(payload.empty());
  std::string why;
  EXPECT_TRUE(ParseLiveNotice(payload, &why).has_value()) << why;
}

TEST(LiveNotice, MalformedPayloadsAreRefusedNamingTheProblem) {
  const json good = json::parse(Encode(Notice(LiveNoticeKind::kFrame)));
  const JsonEdits edit{good};
  ExpectRefused(std::string(kMaxLiveNoticeBytes + 1, ' '), "more than 7999", "oversize");
  ExpectRefused("", "not JSON", "empty");
  ExpectRefused("{\"v\":1,", "not JSON", "cut short");
  ExpectRefused(std::string(3990, '[') + std::string(3990, ']'), "not a JSON object",
                "deeply nested");
  ExpectRefused("[1,2]", "not a JSON object", "an array");
  ExpectRefused(edit.with("v", 2), "v:", "a newer version");
  ExpectRefused(edit.without("v"), "v:", "no version");
  ExpectRefused(edit.with("kind", "explode"), "kind", "unknown kind");
  ExpectRefused(edit.with("image", -1), "image", "a negative image number");
  ExpectRefused(edit.with("kind", 3), "kind", "numeric kind");
  ExpectRefused(edit.without("replica"), "replica", "no replica");
  ExpectRefused(edit.with("replica", std::string(65, 'a')), "replica", "long replica id");
  ExpectRefused(edit.with("replica", json::array()), "replica", "replica not a string");
  ExpectRefused(edit.with("session", ""), "session", "empty session");
  ExpectRefused(edit.with("session", "abc\x1b[2Jdef"), "session", "control characters");
  ExpectRefused(edit.with("session", std::string(129, 'u')), "session", "long session");
  ExpectRefused(edit.without("institution"), "institution", "no institution");
  ExpectRefused(edit.with("trainee", 12), "trainee", "numeric trainee");
  {
    std::string bad_utf8 = good.dump();
    bad_utf8.replace(bad_utf8.find("\"sample\""), 8, "\"\xC0\xAF\"");
    ExpectRefused(bad_utf8, "not JSON", "invalid UTF-8");
  }
  ExpectRefused(edit.with("case_version", -1), "case_version", "negative version");
  ExpectRefused(edit.with("case_version", 1.5), "case_version", "fractional version");
  ExpectRefused(edit.with("case_version", 1ull << 32), "case_version", "version over 32 bits");
  ExpectRefused(edit.with("started_unix_ms", "yesterday"), "started_unix_ms", "a string clock");
  ExpectRefused(edit.with("started_unix_ms", 1ull << 62), "started_unix_ms", "a clock past 9999");
  ExpectRefused(edit.with("frames", -5), "frames", "negative frames");
  ExpectRefused(edit.without("frame"), "frame", "a frame notice without one");
  ExpectRefused(edit.with("frame", "not*base64!"), "frame: not base64", "bad alphabet");
  ExpectRefused(edit.with("frame", "QUJD\nREVG"), "frame: not base64", "whitespace");
  ExpectRefused(edit.with("frame", "QQ==QUJD"), "frame: not base64", "data after padding");
  ExpectRefused(edit.with("frame", "/////w=="), "LiveFrame", "not protobuf");
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
    n.frame.set_base_force_n(1e9);
    ExpectRefused(EncodeLiveNotice(n), "frame.base_force_n", "absurd force");
    // Ids inside the frame would bypass the envelope's checks, and a JPEG
    // there skip the parts' checks; EncodeLiveNotice clears both, so the
    // frame is forged by hand.
    const auto forged = [](const v1::LiveFrame& f) {
      const std::string raw = f.SerializeAsString();
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
      return b64;
    };
    v1::LiveFrame gif = Frame(1);
    gif.set_endoscope_jpeg("GIF89a");
    ExpectRefused(edit.with("frame", forged(gif)), "frame.endoscope_jpeg", "not a JPEG");
    v1::LiveFrame with_id = Frame(1);
    with_id.set_trainee_id("someone");
    ExpectRefused(edit.with("frame", forged(with_id)), "carries ids", "ids inside the frame");
  }
  // Unknown extra fields are ignored (a newer replica may add some).
  std::string why;
  EXPECT_TRUE(ParseLiveNotice(edit.with("future", "x"), &why).has_value()) << why;
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

// The listener end to end: a frame that names an image reaches the viewer
// only with its JPEG; an image missing a part is never shown, the next one is.
TEST(LivePgRelay, AnImageMissingAPartIsNotShownTheNextOneIs) {
  LiveHub hub;
  LivePgRelay relay(LivePgRelayOptions{}, &hub);
  relay.OnNotification(Encode(Notice(LiveNoticeKind::kBegin)));
  std::string why;
  auto viewer = hub.Watch(Info().session_uuid, &why);
  ASSERT_TRUE(viewer) << why;

  const std::string first = Jpeg(15000, '\x11'), second = Jpeg(15000, '\x22');
  bool ended = false;
  relay.OnNotification(Encode(FrameNotice(1, 1)));
  std::vector<LiveNotice> parts = ImageParts(first, 1);
  ASSERT_EQ(parts.size(), 3u);
  relay.OnNotification(Encode(parts[0]));
  relay.OnNotification(Encode(parts[2]));  // part 1 lost on the way
  EXPECT_EQ(viewer->Next(0, &ended), "") << "neither the frame nor its image";

  relay.OnNotification(Encode(FrameNotice(2, 2)));
  parts = ImageParts(second, 2);
  relay.OnNotification(Encode(parts[1]));
  relay.OnNotification(Encode(parts[0]));
  relay.OnNotification(Encode(parts[2]));
  const std::string shown = viewer->Next(0, &ended);
  ASSERT_FALSE(shown.empty()) << "the next image is shown";
  const json f = json::parse(shown);
  EXPECT_DOUBLE_EQ(f["tip_arc_m"].get<double>(), 0.02);
  v1::LiveFrame expected = Frame(2);
  expected.set_endoscope_jpeg(second);
  EXPECT_EQ(f["jpeg_base64"], json::parse(LiveFrameJson(expected, 0))["jpeg_base64"]);

  relay.OnNotification(Encode(FrameNotice(3, 0)));  // no image: shown as it comes
  const json g = json::parse(viewer->Next(0, &ended));
  EXPECT_DOUBLE_EQ(g["tip_arc_m"].get<double>(), 0.03);
  EXPECT_FALSE(g.contains("jpeg_base64"));
  const LivePgRelay::Stats s = relay.stats();
  EXPECT_EQ(s.images_received, 2u);
  EXPECT_EQ(s.images_completed, 1u) << "the first lacked a part";
  EXPECT_EQ(s.refused, 0u);
}

TEST(LivePgRelay, AViewerGetsTheRemoteFrameWithItsJpegAsALocalViewerWould) {
  LiveHub remote_hub, local_hub;
  LivePgRelay relay(LivePgRelayOptions{}, &remote_hub);
  std::string why;
  ASSERT_TRUE(local_hub.Begin(Info(), &why)) << why;
  auto local_viewer = local_hub.Watch(Info().session_uuid, &why);
  ASSERT_TRUE(local_viewer);
  const std::string jpeg = Jpeg(20000, '\x33');
  local_hub.Publish(Info().session_uuid, Frame(5, 0));
  v1::LiveFrame with_jpeg = Frame(5);
  with_jpeg.set_endoscope_jpeg(jpeg);
  local_hub.Publish(Info().session_uuid, with_jpeg);

  relay.OnNotification(Encode(FrameNotice(5, 1)));
  auto remote_viewer = remote_hub.Watch(Info().session_uuid, &why);
  ASSERT_TRUE(remote_viewer) << why;
  bool ended = false;
  EXPECT_EQ(remote_viewer->Next(0, &ended), "") << "the frame waits for its image";
  for (const LiveNotice& p : ImageParts(jpeg, 1)) relay.OnNotification(Encode(p));
  json remote = json::parse(remote_viewer->Next(1000, &ended));
  json local = json::parse(local_viewer->Next(1000, &ended));
  ASSERT_TRUE(remote.contains("jpeg_base64"));
  EXPECT_EQ(remote["jpeg_base64"], local["jpeg_base64"]);
  for (json* j : {&remote, &local}) j->erase("received_unix_ms");
  EXPECT_EQ(remote, local) << "the same JSON, figures and picture";
  EXPECT_EQ(relay.stats().images_completed, 1u);
}

// Publishing (no database: the queue is never drained): a frame with a JPEG
// queues its image's parts, all of them or none; a second JPEG sooner than
// min_image_interval_ms is not sent; the frames go on regardless.
TEST(LivePgRelay, AnImageTheQueueCannotTakeWholeIsDroppedWhole) {
  LiveHub hub;
  LivePgRelayOptions options;
  options.queue_capacity = 6;
  options.min_frame_interval_ms = 0;
  options.min_image_interval_ms = 3600 * 1000;  // one image per session in this test
  LivePgRelay relay(options, &hub);
  LiveSessionInfo info = Info();
  relay.Framed(info, Frame(1, 3 * kLiveImagePartBytes));  // the frame and 3 parts: 4 queued
  relay.Framed(info, Frame(2, 3 * kLiveImagePartBytes));  // too soon: the frame alone, 5
  info.session_uuid = "5f0c6a1e-0000-4000-8000-000000000002";
  relay.Framed(info, Frame(1, 2 * kLiveImagePartBytes));  // needs 3, room for 1: the frame, 6
  v1::LiveFrame cut = Frame(2, 100);
  cut.mutable_endoscope_jpeg()->back() = 'x';
  info.session_uuid = "5f0c6a1e-0000-4000-8000-000000000003";
  relay.Framed(info, cut);  // no FF D9 end: never sent; the frame finds the queue full
  const LivePgRelay::Stats s = relay.stats();
  EXPECT_EQ(s.images_thinned, 1u);
  EXPECT_EQ(s.images_dropped, 2u) << "the one without room, and the one cut short";
  EXPECT_EQ(s.dropped_full, 1u);
  EXPECT_EQ(s.throttled, 0u);
}

}  // namespace
}  // namespace ves::server
