// Live proctoring (docs/web.md, "Live proctoring") against a real server on
// loopback: a station's Live.StreamSession frames reach a WebSocket viewer
// of the same institution with the tip moving; another institution, other
// roles and no authentication are refused; a viewer that never reads does
// not hold up the station or a reading viewer; malformed frames end the
// stream with INVALID_ARGUMENT naming the field; the station's LiveStreamer
// streams when the server is there and never blocks when it is not, and
// ends a stream in the background (RequestClose, Reap) for interactive runs.
#include <gtest/gtest.h>

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <thread>

#include "server/client.h"
#include "server/live_hub.h"
#include "station/sync/live_stream.h"
#include "tests/integration/test_server.h"
#include "tests/server/web_client.h"
#include "tests/server/ws_viewer.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::StoreRole;
namespace asio = boost::asio;
using tcp = asio::ip::tcp;

static_assert(sync::kMaxLiveJpegBytes == kMaxLiveJpegBytes, "station and server JPEG bounds");

using Viewer = WsViewer;  // tests/server/ws_viewer.h

// A raw station stream (the fake station).
struct Station {
  Station(const ClientOptions& client) : stub(v1::Live::NewStub(MakeClientChannel(client))) {
    context.AddMetadata("authorization", "Bearer " + client.token);
    writer = stub->StreamSession(&context, &summary);
  }
  grpc::Status Finish() {
    writer->WritesDone();
    return writer->Finish();
  }
  std::unique_ptr<v1::Live::Stub> stub;
  grpc::ClientContext context;
  v1::LiveStreamSummary summary;
  std::unique_ptr<grpc::ClientWriter<v1::LiveFrame>> writer;
};

// The tip `k` steps along: deeper, further up the scope polyline.
v1::LiveFrame FrameAt(int k, size_t jpeg_bytes = 0) {
  v1::LiveFrame f;
  f.set_t_s(0.05 * k);
  f.set_tip_arc_m(0.01 * k);
  f.set_inserted_m(0.012 * k);
  f.set_base_force_n(2.5);
  for (int i = 0; i <= 10; ++i) {
    f.add_scope_xyz_m(0.0f);
    f.add_scope_xyz_m(0.0f);
    f.add_scope_xyz_m(0.001f * i * k);
  }
  for (int i = 0; i < 30; ++i) {
    f.add_colon_xyz_m(0.01f * i);
    f.add_colon_xyz_m(0.0f);
    f.add_colon_xyz_m(0.02f * i);
  }
  f.add_tip_xyz_m(0.0f);
  f.add_tip_xyz_m(0.0f);
  f.add_tip_xyz_m(0.01f * k);
  if (jpeg_bytes > 0) {
    std::string jpeg(jpeg_bytes, static_cast<char>(k & 0x7f));
    jpeg[0] = '\xFF';
    jpeg[1] = '\xD8';
    jpeg[2] = '\xFF';
    f.set_endoscope_jpeg(jpeg);
  }
  return f;
}

v1::LiveFrame FirstFrame(const std::string& uuid, const std::string& trainee) {
  v1::LiveFrame f = FrameAt(0);
  f.set_session_uuid(uuid);
  f.set_trainee_id(trainee);
  f.set_case_id("sample");
  f.set_case_version(1);
  return f;
}

// A station streaming through a LiveStreamer while the test watches: frames
// 1, 2, ... offered every 2 ms from their own thread until Stop (at most
// 2000 of them).
class BackgroundOfferer {
 public:
  explicit BackgroundOfferer(sync::LiveStreamer* streamer)
      : thread_([this, streamer] {
          for (int k = 1; k <= 2000 && !stop_; ++k) {
            streamer->Offer(FrameAt(k));
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
          }
        }) {}
  ~BackgroundOfferer() { Stop(); }
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Polls Reap (never blocking, as the interactive station does) until the
// stream's own thread has ended it, for at most 10 s.
bool ReapWithin10s(sync::LiveStreamer* streamer, sync::LiveStreamStats* stats) {
  for (int i = 0; i < 1000; ++i) {
    if (streamer->Reap(stats)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

class WebLiveTest : public ::testing::Test {
 protected:
  static ServerOptions WithHttp() {
    ServerOptions o;
    o.http_listen = "127.0.0.1:0";
    o.log_calls = false;
    return o;
  }
  void SetUp() override {
    server_.AddTrainee("t1", "north");
    server_.AddTrainee("s1", "south");
    supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "north");
    south_supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "south");
    station_ = server_.MakeToken(StoreRole::kStation, "north");
    south_station_ = server_.MakeToken(StoreRole::kStation, "south");
    trainee_ = server_.MakeToken(StoreRole::kTrainee, "north", "t1");
    std::mt19937_64 rng(11);
    uuid_ = NewUuid(rng);
  }
  int port() { return server_.server().http_port(); }
  // Where the north station streams to, as ves-station run configures it.
  sync::ServerEndpoint StationEndpoint() const {
    sync::ServerEndpoint endpoint;
    endpoint.address = server_.address();
    endpoint.token = station_;
    return endpoint;
  }
  json LiveList(const std::string& token) {
    const HttpResult r =
        HttpCall(port(), "GET", "/api/v1/live", {{"Authorization", "Bearer " + token}});
    EXPECT_EQ(r.status, 200) << r.body;
    return r.status == 200 ? json::parse(r.body)["live"] : json::array();
  }
  // A WebSocket upgrade request that the server refuses before upgrading:
  // its HTTP status and body.
  HttpResult Upgrade(const std::string& session_uuid, const std::string& token,
                     const std::string& cookie = "") {
    Headers h = {{"Connection", "Upgrade"},
                 {"Upgrade", "websocket"},
                 {"Sec-WebSocket-Version", "13"},
                 {"Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="}};
    if (!token.empty()) h.emplace_back("Authorization", "Bearer " + token);
    if (!cookie.empty()) h.emplace_back("Cookie", cookie);
    return HttpCall(port(), "GET", "/api/v1/live/ws?session=" + session_uuid, h);
  }
  // Waits (bounded) until the hub lists `uuid` for the north supervisor.
  bool WaitListed(const std::string& uuid) {
    for (int i = 0; i < 500; ++i) {
      for (const json& l : LiveList(supervisor_)) {
        if (l["session_uuid"] == uuid) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }

  TestServer server_{WithHttp()};
  std::string supervisor_, south_supervisor_, station_, south_station_, trainee_, uuid_;
};

TEST_F(WebLiveTest, ViewerOfTheInstitutionSeesTheTipMove) {
  Station station(server_.Client(station_));
  ASSERT_TRUE(station.writer->Write(FirstFrame(uuid_, "t1")));
  ASSERT_TRUE(WaitListed(uuid_));
  const json listed = LiveList(supervisor_)[0];
  EXPECT_EQ(listed["trainee_id"], "t1");
  EXPECT_EQ(listed["case_id"], "sample");
  EXPECT_GT(listed["started_unix_ms"].get<int64_t>(), 0);
  EXPECT_TRUE(LiveList(south_supervisor_).empty()) << "another institution's live list";

  Viewer viewer;
  ASSERT_EQ(viewer.Connect(port(), uuid_, supervisor_), 101) << viewer.body();
  constexpr int kFrames = 40;
  std::thread sender([&] {
    for (int k = 1; k <= kFrames; ++k) {
      ASSERT_TRUE(station.writer->Write(FrameAt(k)));
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  // The viewer sees the tip go deeper; it may skip frames, never go back.
  std::vector<double> tip_arc_m;
  int last_scope_tip_mm = -1;
  bool tip_moved_up = false;
  while (true) {
    const json f = viewer.Read();
    if (f.is_null() || f.value("ended", false)) {
      ADD_FAILURE() << "socket closed before the last frame";
      break;
    }
    tip_arc_m.push_back(f["tip_arc_m"].get<double>());
    const int tip_up_mm = f["scope_mm"].back()[1].get<int>();
    if (last_scope_tip_mm >= 0 && tip_up_mm > last_scope_tip_mm) tip_moved_up = true;
    last_scope_tip_mm = tip_up_mm;
    EXPECT_EQ(f["colon_mm"].size(), 30u);
    if (f["t_s"].get<double>() >= 0.05 * kFrames - 1e-9) break;
  }
  sender.join();
  ASSERT_GE(tip_arc_m.size(), 2u);
  for (size_t i = 1; i < tip_arc_m.size(); ++i) EXPECT_GT(tip_arc_m[i], tip_arc_m[i - 1]);
  EXPECT_TRUE(tip_moved_up);
  const grpc::Status done = station.Finish();
  EXPECT_TRUE(done.ok()) << done.error_message();
  EXPECT_EQ(station.summary.frames_received(), kFrames + 1u);
  // The end of the stream reaches the viewer, and the list forgets it.
  json last = viewer.Read();
  EXPECT_EQ(last.value("ended", false), true) << last.dump();
  EXPECT_TRUE(LiveList(supervisor_).empty());
}

TEST_F(WebLiveTest, OtherInstitutionsRolesAndStrangersAreRefused) {
  Station station(server_.Client(station_));
  ASSERT_TRUE(station.writer->Write(FirstFrame(uuid_, "t1")));
  ASSERT_TRUE(WaitListed(uuid_));
  const HttpResult foreign = Upgrade(uuid_, south_supervisor_);
  EXPECT_EQ(foreign.status, 403) << foreign.body;
  EXPECT_NE(foreign.body.find("PERMISSION_DENIED"), std::string::npos) << foreign.body;
  for (const std::string& token : {trainee_, station_}) {
    const HttpResult r = Upgrade(uuid_, token);
    EXPECT_EQ(r.status, 403) << "role: " << r.body;
  }
  EXPECT_EQ(Upgrade(uuid_, "").status, 401);
  EXPECT_EQ(Upgrade(uuid_, "0123456789abcdef").status, 401);
  EXPECT_EQ(Upgrade(uuid_, "", "ves_session=forged").status, 401);
  std::mt19937_64 rng(99);
  EXPECT_EQ(Upgrade(NewUuid(rng), supervisor_).status, 404);
  EXPECT_EQ(Upgrade("", supervisor_).status, 400);
  {  // a page of another origin cannot ride on a supervisor's credentials
    Headers h = {{"Connection", "Upgrade"},
                 {"Upgrade", "websocket"},
                 {"Sec-WebSocket-Version", "13"},
                 {"Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="},
                 {"Authorization", "Bearer " + supervisor_},
                 {"Origin", "https://evil.example"}};
    EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/live/ws?session=" + uuid_, h).status, 403);
  }
  // The same supervisor is let in (the refusals above were not by accident).
  Viewer ok;
  EXPECT_EQ(ok.Connect(port(), uuid_, supervisor_), 101);
  EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/live").status, 401);
  EXPECT_EQ(
      HttpCall(port(), "GET", "/api/v1/live", {{"Authorization", "Bearer " + trainee_}}).status,
      403);
  EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/live?institution=north",
                     {{"Authorization", "Bearer " + south_supervisor_}})
                .status,
            403);
  EXPECT_TRUE(station.Finish().ok());
}

TEST_F(WebLiveTest, ASlowViewerDoesNotHoldUpTheStationOrAFastViewer) {
  Station station(server_.Client(station_));
  ASSERT_TRUE(station.writer->Write(FirstFrame(uuid_, "t1")));
  ASSERT_TRUE(WaitListed(uuid_));
  Viewer slow, fast;
  ASSERT_EQ(slow.Connect(port(), uuid_, supervisor_), 101);  // never reads
  ASSERT_EQ(fast.Connect(port(), uuid_, supervisor_), 101);
  // 300 frames with a 60 KiB JPEG each (80 KiB as base64): ~24 MiB, far more
  // than the slow viewer's socket buffers hold.
  constexpr int kFrames = 300;
  std::thread sender([&] {
    for (int k = 1; k <= kFrames; ++k) ASSERT_TRUE(station.writer->Write(FrameAt(k, 60 << 10)));
  });
  int received = 0, with_jpeg = 0;
  while (true) {
    const json f = fast.Read();
    if (f.is_null() || f.value("ended", false)) {
      ADD_FAILURE() << "the fast viewer's socket closed after " << received << " frames";
      break;
    }
    ++received;
    if (f.contains("jpeg_base64")) {  // the first one (the start frame) has none
      EXPECT_EQ(f["jpeg_base64"].get<std::string>().substr(0, 4), "/9j/") << "a JPEG's base64";
      ++with_jpeg;
    }
    if (f["t_s"].get<double>() >= 0.05 * kFrames - 1e-9) break;
  }
  sender.join();  // the station was never held up by the slow viewer
  EXPECT_GE(with_jpeg, 1);
  const grpc::Status done = station.Finish();
  EXPECT_TRUE(done.ok()) << done.error_message();
  EXPECT_EQ(station.summary.frames_received(), kFrames + 1u);
}

TEST_F(WebLiveTest, MalformedFramesAreRefusedNamingTheField) {
  struct Case {
    std::string what;
    v1::LiveFrame first;
    std::string field;
  };
  std::vector<Case> cases;
  {
    v1::LiveFrame f = FirstFrame(uuid_, "t1");
    f.clear_session_uuid();
    cases.push_back({"no uuid", f, "frame.session_uuid"});
  }
  {
    v1::LiveFrame f = FirstFrame(uuid_, "t1");
    f.set_t_s(std::numeric_limits<double>::quiet_NaN());
    cases.push_back({"NaN time", f, "frame.t_s"});
  }
  {
    v1::LiveFrame f = FirstFrame(uuid_, "t1");
    for (int i = 0; i < 3 * kMaxLivePolylinePoints; ++i) f.add_scope_xyz_m(0.0f);
    cases.push_back({"too many points", f, "frame.scope_xyz_m"});
  }
  {
    v1::LiveFrame f = FirstFrame(uuid_, "t1");
    f.add_colon_xyz_m(1.0f);
    cases.push_back({"not triples", f, "frame.colon_xyz_m"});
  }
  {
    v1::LiveFrame f = FirstFrame(uuid_, "t1");
    f.set_base_force_n(std::numeric_limits<double>::infinity());
    cases.push_back({"infinite force", f, "frame.base_force_n"});
  }
  {
    v1::LiveFrame f = FirstFrame(uuid_, "t1");
    f.set_endoscope_jpeg(std::string(kMaxLiveJpegBytes + 1, '\xFF'));
    cases.push_back({"big JPEG", f, "frame.endoscope_jpeg"});
  }
  {
    v1::LiveFrame f = FirstFrame(uuid_, "t1");
    f.set_endoscope_jpeg("GIF89a");
    cases.push_back({"not a JPEG", f, "frame.endoscope_jpeg"});
  }
  for (const Case& c : cases) {
    Station station(server_.Client(station_));
    station.writer->Write(c.first);
    const grpc::Status s = station.Finish();
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.what;
    EXPECT_NE(s.error_message().find(c.field), std::string::npos)
        << c.what << ": " << s.error_message();
  }
  {  // a bad frame after a good start ends the stream, and the session
    Station station(server_.Client(station_));
    ASSERT_TRUE(station.writer->Write(FirstFrame(uuid_, "t1")));
    v1::LiveFrame bad = FrameAt(1);
    bad.set_inserted_m(std::nan(""));
    station.writer->Write(bad);
    const grpc::Status s = station.Finish();
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(s.error_message().find("frame.inserted_m"), std::string::npos) << s.error_message();
    EXPECT_TRUE(LiveList(supervisor_).empty());
  }
  {  // another institution's trainee, and a role that may not stream
    Station south(server_.Client(south_station_));
    south.writer->Write(FirstFrame(uuid_, "t1"));
    EXPECT_EQ(south.Finish().error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    Station trainee(server_.Client(trainee_));
    trainee.writer->Write(FirstFrame(uuid_, "t1"));
    EXPECT_EQ(trainee.Finish().error_code(), grpc::StatusCode::PERMISSION_DENIED);
    Station nobody(server_.Client("0123456789abcdef"));
    nobody.writer->Write(FirstFrame(uuid_, "t1"));
    EXPECT_EQ(nobody.Finish().error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
}

TEST_F(WebLiveTest, StationStreamerReachesAViewer) {
  sync::LiveStreamer streamer(StationEndpoint(), FirstFrame(uuid_, "t1"));
  ASSERT_TRUE(WaitListed(uuid_));
  Viewer viewer;
  ASSERT_EQ(viewer.Connect(port(), uuid_, supervisor_), 101) << viewer.body();
  // Offer frames until the viewer has seen the tip at three depths.
  BackgroundOfferer offerer(&streamer);
  std::set<double> depths;
  while (depths.size() < 3) {
    const json f = viewer.Read();
    if (f.is_null()) break;
    depths.insert(f["tip_arc_m"].get<double>());
  }
  offerer.Stop();
  EXPECT_GE(depths.size(), 3u);
  const sync::LiveStreamStats stats = streamer.Close();
  EXPECT_GT(stats.sent, 0u);
  EXPECT_FALSE(stats.gave_up);
  EXPECT_EQ(stats.last_error, "");
}

// Interactive runs end a session's stream without waiting (RequestClose);
// the stream's own thread finishes it and the viewer sees it end.
TEST_F(WebLiveTest, AStreamEndedInTheBackgroundEndsForTheViewer) {
  sync::LiveStreamer streamer(StationEndpoint(), FirstFrame(uuid_, "t1"));
  ASSERT_TRUE(WaitListed(uuid_));
  Viewer viewer;
  ASSERT_EQ(viewer.Connect(port(), uuid_, supervisor_), 101) << viewer.body();
  BackgroundOfferer offerer(&streamer);
  // Wait for an offered frame (tip deeper than the opening frame's 0 m),
  // not the opening frame a new viewer may be shown first.
  json f;
  do {
    f = viewer.Read();
  } while (!f.is_null() && f.value("tip_arc_m", 0.0) <= 0.0);
  offerer.Stop();
  ASSERT_FALSE(f.is_null());
  streamer.RequestClose();
  streamer.Offer(FrameAt(5000));  // after the request: dropped, not sent
  json last;
  do {
    last = viewer.Read();
  } while (!last.is_null() && !last.value("ended", false));
  EXPECT_EQ(last.value("ended", false), true) << last.dump();
  sync::LiveStreamStats stats;
  ASSERT_TRUE(ReapWithin10s(&streamer, &stats)) << "the stream's thread did not end";
  EXPECT_GT(stats.sent, 0u);
  EXPECT_GE(stats.dropped, 1u);
  EXPECT_EQ(stats.last_error, "");
  EXPECT_FALSE(stats.gave_up);
  EXPECT_TRUE(LiveList(supervisor_).empty());
}

// A loopback port nothing listens on: a stream to it cannot start.
sync::ServerEndpoint ClosedPortEndpoint() {
  asio::io_context io;
  tcp::acceptor probe(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
  const int closed_port = probe.local_endpoint().port();
  probe.close();
  sync::ServerEndpoint endpoint;
  endpoint.address = "127.0.0.1:" + std::to_string(closed_port);
  endpoint.token = "0123456789abcdef";
  return endpoint;
}

TEST(LiveStreamerOffline, NeverBlocksAndCountsWhatItDrops) {
  // A port nothing listens on: the stream cannot start; offers only drop.
  sync::LiveStreamer streamer(ClosedPortEndpoint(), FirstFrame("u", "t1"));
  for (int k = 0; k < 100; ++k) streamer.Offer(FrameAt(k));
  const sync::LiveStreamStats stats = streamer.Close(0);
  EXPECT_EQ(stats.sent, 0u);
  EXPECT_EQ(stats.dropped, 100u);
}

TEST(LiveStreamerOffline, RequestCloseLeavesTheEndToItsThread) {
  sync::LiveStreamer streamer(ClosedPortEndpoint(), FirstFrame("u", "t1"));
  for (int k = 0; k < 50; ++k) streamer.Offer(FrameAt(k));
  streamer.RequestClose();
  sync::LiveStreamStats stats;
  ASSERT_TRUE(ReapWithin10s(&streamer, &stats)) << "the stream's thread did not end";
  EXPECT_EQ(stats.sent, 0u);
  EXPECT_EQ(stats.dropped, 50u);
  // Reaped: Close has nothing left to wait for.
  EXPECT_EQ(streamer.Close(0).dropped, 50u);
}

TEST(LiveStreamerEndpoint, RefusesTheTokenInClearOffLoopback) {
  sync::ServerEndpoint endpoint;
  endpoint.address = "192.0.2.1:50051";
  endpoint.token = "0123456789abcdef";
  EXPECT_THROW(sync::LiveStreamer(endpoint, FirstFrame("u", "t1")), std::invalid_argument);
}

}  // namespace
}  // namespace ves::server::testing
