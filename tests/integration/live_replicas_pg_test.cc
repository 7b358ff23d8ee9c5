// Live proctoring across two real ves-server processes on one PostgreSQL
// database (docs/web.md, "Live proctoring across replicas"): a station
// streams to replica A; on replica B a supervisor of the same institution
// lists the session and watches its frames with the tip moving, another
// institution's supervisor is refused (403) as on A, and B reports the end
// when the stream ends; a SIGKILLed replica's session expires on the other;
// the relays reconnect when the database drops their connections; many
// stations on one replica reach the other without drops; a viewer on B gets
// the endoscope JPEGs a station streams to A byte for byte.
// Skipped unless VES_TEST_POSTGRES_URL is set (deploy/with-postgres.sh).
#include <gtest/gtest.h>
#include <openssl/evp.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <deque>
#include <fstream>
#include <nlohmann/json.hpp>
#include <pqxx/pqxx>
#include <random>
#include <regex>
#include <thread>

#include "patient_db/pg_store.h"
#include "server/auth.h"
#include "server/client.h"
#include "server/live_pg_relay.h"
#include "tests/integration/server_process.h"
#include "tests/integration/test_server.h"
#include "tests/patient_db/pg_test_util.h"
#include "tests/server/web_client.h"
#include "tests/server/ws_viewer.h"
#include "ves/v1/live.grpc.pb.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::StoreRole;
namespace pg = patient_db::pg_testing;

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

using Replica = ServerProcess;

using Viewer = WsViewer;  // tests/server/ws_viewer.h

// Frame k's endoscope picture: 16 KiB (a 320-pixel view is 10-20 KiB) that
// differ for every k, a JPEG's start and end markers around them.
std::string StationJpeg(int k) {
  std::mt19937 rng(static_cast<uint32_t>(k));
  std::string jpeg(16 << 10, '\0');
  for (char& c : jpeg) c = static_cast<char>(rng());
  jpeg.replace(0, 4, "\xFF\xD8\xFF\xE0");
  jpeg.replace(jpeg.size() - 2, 2, "\xFF\xD9");
  return jpeg;
}

std::string FromBase64(const std::string& text) {
  std::string bytes(text.size() / 4 * 3, '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(bytes.data()),
                                reinterpret_cast<const unsigned char*>(text.data()),
                                static_cast<int>(text.size()));
  if (n < 0) return {};
  const size_t pad = text.size() - text.find_last_not_of('=') - 1;
  bytes.resize(static_cast<size_t>(n) - pad);
  return bytes;
}

// A station streaming frames every 50 ms (20 Hz, as ves-station run does)
// from its own thread, the tip 1 cm deeper each frame, until Finish. With
// `jpeg_every`, every that many frames carry StationJpeg(k) (4: every
// 0.2 s, as ves-station run sends them).
class StreamingStation {
 public:
  StreamingStation(const ClientOptions& client, const std::string& uuid, int jpeg_every = 0)
      : stub_(v1::Live::NewStub(MakeClientChannel(client))) {
    context_.AddMetadata("authorization", "Bearer " + client.token);
    writer_ = stub_->StreamSession(&context_, &summary_);
    thread_ = std::thread([this, uuid, jpeg_every] {
      for (int k = 0; !stop_ && k < 2000; ++k) {
        v1::LiveFrame f;
        if (k == 0) {
          f.set_session_uuid(uuid);
          f.set_trainee_id("t1");
          f.set_case_id("sample");
          f.set_case_version(1);
        }
        f.set_t_s(0.05 * k);
        f.set_tip_arc_m(0.01 * k);
        f.set_inserted_m(0.012 * k);
        for (int i = 0; i <= 40; ++i) {
          for (float v : {0.0f, 0.0f, 0.0005f * i * k}) f.add_scope_xyz_m(v);
          for (float v : {0.01f * i, 0.0f, 0.02f * i}) f.add_colon_xyz_m(v);
        }
        for (float v : {0.0f, 0.0f, 0.02f * k}) f.add_tip_xyz_m(v);
        if (jpeg_every > 0 && k % jpeg_every == 0) f.set_endoscope_jpeg(StationJpeg(k));
        f.set_sent_unix_ms(NowUnixMs());
        if (!writer_->Write(f)) return;
        ++written_;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    });
  }
  ~StreamingStation() { StopWriting(); }
  void StopWriting() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  grpc::Status Finish() {
    StopWriting();
    writer_->WritesDone();
    return writer_->Finish();
  }
  int written() const { return written_; }
  uint64_t frames_received() const { return summary_.frames_received(); }

 private:
  std::unique_ptr<v1::Live::Stub> stub_;
  grpc::ClientContext context_;
  v1::LiveStreamSummary summary_;
  std::unique_ptr<grpc::ClientWriter<v1::LiveFrame>> writer_;
  std::atomic<bool> stop_{false};
  std::atomic<int> written_{0};
  std::thread thread_;
};

class LiveReplicas : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string base = pg::TestPostgresUrl();
    if (base.empty()) GTEST_SKIP() << pg::kNoPostgresMessage;
    schema_ = pg::UniqueSchemaName(::testing::UnitTest::GetInstance()->current_test_info()->name());
    url_ = pg::FreshSchema(base, schema_);
    dir_ = MakeTempDir("live-replicas");
    patient_db::PgStoreOptions o;
    o.url = url_;
    o.pool_size = 2;
    patient_db::PgStore store(o);  // migrates before the servers start
    store.AddInstitution("north", 1);
    store.AddInstitution("south", 1);
    ASSERT_TRUE(store.AddTrainee({"t1", "north", "T", 1}).ok());
    station_ = NewToken();
    north_ = NewToken();
    south_ = NewToken();
    ASSERT_TRUE(
        store.AddToken({Sha256Hex(station_), StoreRole::kStation, "north", "", "st", 1}).ok());
    ASSERT_TRUE(
        store.AddToken({Sha256Hex(north_), StoreRole::kSupervisor, "north", "", "sn", 1}).ok());
    ASSERT_TRUE(
        store.AddToken({Sha256Hex(south_), StoreRole::kSupervisor, "south", "", "ss", 1}).ok());
    std::mt19937_64 rng(23);
    uuid_ = NewUuid(rng);
  }
  void TearDown() override {
    for (Replica& r : replicas_) Stop(&r, SIGKILL);
    if (HasFailure() || std::getenv("VES_TEST_SHOW_LOGS") != nullptr) {
      for (const Replica& r : replicas_) {
        std::ifstream in(r.log);
        std::cerr << "---- " << r.log << "\n" << in.rdbuf() << "\n";
      }
    }
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  Replica& Start() {
    replicas_.push_back(
        StartServerProcess(url_, dir_, std::to_string(replicas_.size()), /*with_http=*/true));
    EXPECT_GT(replicas_.back().http_port, 0)
        << "ves-server did not start, see " << replicas_.back().log;
    return replicas_.back();
  }
  static void Stop(Replica* r, int signal) { StopServerProcess(r, signal); }
  ClientOptions Client(const Replica& r) const {
    ClientOptions o;
    o.address = r.address();
    o.token = station_;
    o.deadline = std::chrono::seconds(60);
    return o;
  }
  // GET /api/v1/live on `r` as `token`: the HTTP status and the list.
  static std::pair<int, json> Live(const Replica& r, const std::string& token,
                                   const std::string& query = "") {
    const HttpResult res = HttpCall(r.http_port, "GET", "/api/v1/live" + query,
                                    {{"Authorization", "Bearer " + token}});
    return {res.status, res.status == 200 ? json::parse(res.body)["live"] : json()};
  }
  // The session as `r` lists it to the north supervisor; null when not listed.
  json Listed(const Replica& r) {
    const auto [status, live] = Live(r, north_);
    EXPECT_EQ(status, 200);
    for (const json& l : live) {
      if (l["session_uuid"] == uuid_) return l;
    }
    return json();
  }
  // Polls until `r` lists the session (`listed`) or does not, up to `limit`;
  // how long it took, or -1 ms on timeout.
  std::chrono::milliseconds WaitListed(const Replica& r, bool listed,
                                       std::chrono::milliseconds limit) {
    const auto start = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - start < limit) {
      if (Listed(r).is_null() != listed) {
        return std::chrono::duration_cast<std::chrono::milliseconds>(
            std::chrono::steady_clock::now() - start);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return std::chrono::milliseconds(-1);
  }

  // The relays' connections of this test's replicas (application_name
  // "ves live listen|notify CHANNEL"), by role.
  int RelayConnections(const std::string& role) {
    pqxx::connection conn(url_);
    pqxx::nontransaction q(conn);
    return q
        .exec_params("SELECT count(*) FROM pg_stat_activity WHERE application_name = $1",
                     "ves live " + role + " " + LiveChannelFor(schema_))[0][0]
        .as<int>();
  }
  bool WaitRelayConnections(const std::string& role, int count) {
    for (int i = 0; i < 500; ++i) {
      if (RelayConnections(role) == count) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
  static std::string ReadLog(const Replica& r) {
    std::ifstream in(r.log);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

  std::string schema_, url_;
  std::filesystem::path dir_;
  std::string station_, north_, south_, uuid_;
  std::deque<Replica> replicas_;  // references stay valid as replicas start
};

TEST_F(LiveReplicas, ASupervisorOnTheOtherReplicaWatchesTheSessionAndSeesItEnd) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.http_port > 0 && b.http_port > 0);
  StreamingStation station(Client(a), uuid_);
  // B's listener may still be connecting: frames keep coming, and any one
  // of them announces the session.
  ASSERT_GE(WaitListed(b, true, std::chrono::seconds(15)).count(), 0) << "B never listed it";
  const json on_b = Listed(b);
  EXPECT_EQ(on_b["trainee_id"], "t1");
  EXPECT_EQ(on_b["case_id"], "sample");
  EXPECT_EQ(on_b["institution"], "north");
  EXPECT_EQ(on_b["station"], "st");
  EXPECT_EQ(on_b["remote"], true);
  EXPECT_EQ(Listed(a)["remote"], false);

  // Another institution's supervisor on B: not listed, refused as on A.
  const auto [south_status, south_list] = Live(b, south_);
  EXPECT_EQ(south_status, 200);
  EXPECT_TRUE(south_list.empty()) << south_list.dump();
  EXPECT_EQ(Live(b, south_, "?institution=north").first, 403);
  for (const Replica* r : {&a, &b}) {
    const HttpResult foreign = HttpCall(r->http_port, "GET", "/api/v1/live/ws?session=" + uuid_,
                                        {{"Connection", "Upgrade"},
                                         {"Upgrade", "websocket"},
                                         {"Sec-WebSocket-Version", "13"},
                                         {"Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="},
                                         {"Authorization", "Bearer " + south_}});
    EXPECT_EQ(foreign.status, 403) << foreign.body;
    EXPECT_NE(foreign.body.find("PERMISSION_DENIED"), std::string::npos) << foreign.body;
  }

  // The north supervisor on B sees the tip go deeper.
  Viewer viewer;
  ASSERT_EQ(viewer.Connect(b.http_port, uuid_, north_), 101);
  std::vector<double> tip_arc_m;
  std::vector<int64_t> latency_ms;  // station's Write on A to the viewer on B (one clock)
  int scope_tip_first_mm = -1, scope_tip_last_mm = -1;
  while (tip_arc_m.size() < 20) {
    const json f = viewer.Read();
    ASSERT_FALSE(f.is_null()) << "no frame within 10 s after " << tip_arc_m.size();
    ASSERT_FALSE(f.value("ended", false)) << "ended while streaming";
    if (!tip_arc_m.empty()) latency_ms.push_back(NowUnixMs() - f["sent_unix_ms"].get<int64_t>());
    tip_arc_m.push_back(f["tip_arc_m"].get<double>());
    const int up_mm = f["scope_mm"].back()[1].get<int>();
    if (scope_tip_first_mm < 0) scope_tip_first_mm = up_mm;
    scope_tip_last_mm = up_mm;
    EXPECT_EQ(f["colon_mm"].size(), 41u);
  }
  for (size_t i = 1; i < tip_arc_m.size(); ++i) EXPECT_GT(tip_arc_m[i], tip_arc_m[i - 1]);
  EXPECT_GT(scope_tip_last_mm, scope_tip_first_mm) << "the scope drawn deeper";
  std::sort(latency_ms.begin(), latency_ms.end());
  std::cout << "A to B: " << latency_ms.size() << " frames, latency p50 "
            << latency_ms[latency_ms.size() / 2] << " ms, max " << latency_ms.back() << " ms\n";
  EXPECT_LT(latency_ms[latency_ms.size() / 2], 200) << "the live page's latency target";
  const json listed_later = Listed(b);
  EXPECT_GT(listed_later["frames"].get<uint64_t>(), 20u);
  EXPECT_GT(listed_later["t_s"].get<double>(), 0.0);

  // The stream ends on A: B's viewer is told, and B's list forgets it, well
  // before the 5 s silence timeout (the end notice, not the expiry).
  const auto end_at = std::chrono::steady_clock::now();
  const grpc::Status done = station.Finish();
  ASSERT_TRUE(done.ok()) << done.error_message();
  EXPECT_EQ(station.frames_received(), static_cast<uint64_t>(station.written()));
  while (true) {
    const json f = viewer.Read();
    ASSERT_FALSE(f.is_null()) << "B's viewer was never told the end";
    if (f.value("ended", false)) break;
  }
  const auto end_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::steady_clock::now() - end_at);
  EXPECT_LT(end_ms.count(), 3000) << "the end came by silence, not by notice";
  EXPECT_TRUE(Listed(b).is_null());
  EXPECT_TRUE(Listed(a).is_null());
  std::cout << "end seen on B " << end_ms.count() << " ms after the station finished on A\n";
}

TEST_F(LiveReplicas, AKilledReplicasSessionEndsOnTheOtherBySilence) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.http_port > 0 && b.http_port > 0);
  StreamingStation station(Client(a), uuid_);
  ASSERT_GE(WaitListed(b, true, std::chrono::seconds(15)).count(), 0) << "B never listed it";
  Viewer viewer;
  ASSERT_EQ(viewer.Connect(b.http_port, uuid_, north_), 101);
  Stop(&a, SIGKILL);  // no end notice will ever come
  const auto gone = WaitListed(b, false, std::chrono::seconds(12));
  ASSERT_GE(gone.count(), 0) << "B still lists a dead replica's session";
  EXPECT_GE(gone.count(), 4000) << "ended before the 5 s silence";
  bool ended = false;
  for (int i = 0; i < 200 && !ended; ++i) {
    const json f = viewer.Read();
    if (f.is_null()) break;
    ended = f.value("ended", false);
  }
  EXPECT_TRUE(ended) << "B's viewer was not told";
  std::cout << "B forgot the killed replica's session after " << gone.count() << " ms\n";
}

// The database drops the relays' connections (a failover, an operator's
// pg_terminate_backend): both replicas reconnect with backoff, say so in
// their logs, and B sees A's next session.
TEST_F(LiveReplicas, RelaysReconnectAfterTheDatabaseDropsTheirConnections) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.http_port > 0 && b.http_port > 0);
  ASSERT_TRUE(WaitRelayConnections("listen", 2));
  {  // a first session opens A's publishing connection
    StreamingStation warmup(Client(a), "warm-up-session");
    ASSERT_TRUE(WaitRelayConnections("notify", 1));
    ASSERT_TRUE(warmup.Finish().ok());
  }
  {
    pqxx::connection conn(url_);
    pqxx::nontransaction q(conn);
    const pqxx::result r = q.exec_params(
        "SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE application_name "
        "IN ($1, $2)",
        "ves live listen " + LiveChannelFor(schema_), "ves live notify " + LiveChannelFor(schema_));
    ASSERT_EQ(r.size(), 3u);
  }
  ASSERT_TRUE(WaitRelayConnections("listen", 2)) << "the listeners did not come back";
  StreamingStation station(Client(a), uuid_);
  ASSERT_GE(WaitListed(b, true, std::chrono::seconds(15)).count(), 0) << "B never listed it";
  ASSERT_TRUE(station.Finish().ok());
  ASSERT_GE(WaitListed(b, false, std::chrono::seconds(3)).count(), 0) << "B missed the end";
  for (const Replica* r : {&a, &b}) {
    const std::string log = ReadLog(*r);
    EXPECT_NE(log.find("LISTEN connection to PostgreSQL lost"), std::string::npos) << log;
    EXPECT_NE(log.find("listening again"), std::string::npos) << log;
  }
  const std::string log_a = ReadLog(a);
  EXPECT_NE(log_a.find("cannot publish to PostgreSQL"), std::string::npos) << log_a;
  EXPECT_NE(log_a.find("publishing to PostgreSQL again"), std::string::npos) << log_a;
}

// Many stations on one replica at once (VES_LIVE_STATIONS, default 20, for
// VES_LIVE_SECONDS, default 3): the other replica lists every one, a viewer
// there keeps up (latency printed), and the publisher drops nothing.
TEST_F(LiveReplicas, ManyStationsOnOneReplicaAllReachTheOtherWithoutDrops) {
  const char* n_env = std::getenv("VES_LIVE_STATIONS");
  const char* s_env = std::getenv("VES_LIVE_SECONDS");
  const int stations = n_env != nullptr ? std::atoi(n_env) : 20;
  const int seconds = s_env != nullptr ? std::atoi(s_env) : 3;
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.http_port > 0 && b.http_port > 0);
  ASSERT_TRUE(WaitRelayConnections("listen", 2));
  std::mt19937_64 rng(29);
  std::vector<std::string> uuids;
  std::vector<std::unique_ptr<StreamingStation>> streams;
  for (int i = 0; i < stations; ++i) {
    uuids.push_back(NewUuid(rng));
    streams.push_back(std::make_unique<StreamingStation>(Client(a), uuids.back()));
  }
  const auto listed_on_b = [&] {
    const auto [status, live] = Live(b, north_);
    return status == 200 ? static_cast<int>(live.size()) : -1;
  };
  for (int i = 0; i < 500 && listed_on_b() < stations; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(listed_on_b(), stations);
  uuid_ = uuids[0];
  Viewer viewer;
  ASSERT_EQ(viewer.Connect(b.http_port, uuid_, north_), 101);
  std::vector<int64_t> latency_ms;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  viewer.Read();  // the frame it had before this viewer came
  while (std::chrono::steady_clock::now() < until) {
    const json f = viewer.Read();
    ASSERT_FALSE(f.is_null() || f.value("ended", false));
    latency_ms.push_back(NowUnixMs() - f["sent_unix_ms"].get<int64_t>());
  }
  for (auto& st : streams) EXPECT_TRUE(st->Finish().ok());
  for (int i = 0; i < 150 && listed_on_b() != 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(listed_on_b(), 0) << "ends missed";
  Stop(&a, SIGTERM);  // logs the relay's counters
  const std::string log = ReadLog(a);
  EXPECT_NE(log.find("dropped 0 (queue full) 0 (too big) 0 (connection lost)"), std::string::npos)
      << log;
  std::sort(latency_ms.begin(), latency_ms.end());
  ASSERT_GE(latency_ms.size(), 10u * seconds / 2) << "the viewer got too few frames";
  std::cout << stations << " stations: viewer on B got " << latency_ms.size() << " frames in "
            << seconds << " s, latency p50 " << latency_ms[latency_ms.size() / 2] << " ms, p99 "
            << latency_ms[latency_ms.size() * 99 / 100] << " ms, max " << latency_ms.back()
            << " ms\n"
            << log.substr(log.find("live relay: stopped")) << "\n";
}

// The endoscope JPEG crosses in image notices (too big for one): a viewer
// on B gets the very bytes the station streamed to A, each with the frame
// that carried it, and both relays count the images when they stop.
TEST_F(LiveReplicas, AViewerOnTheOtherReplicaGetsTheStationsJpegsByteForByte) {
  Replica& a = Start();
  Replica& b = Start();
  ASSERT_TRUE(a.http_port > 0 && b.http_port > 0);
  ASSERT_TRUE(WaitRelayConnections("listen", 2));
  StreamingStation station(Client(a), uuid_, /*jpeg_every=*/4);
  ASSERT_GE(WaitListed(b, true, std::chrono::seconds(15)).count(), 0) << "B never listed it";
  Viewer viewer;
  ASSERT_EQ(viewer.Connect(b.http_port, uuid_, north_), 101);
  int images = 0, frames = 0;
  std::vector<int64_t> latency_ms;  // station's Write on A to the viewer on B (one clock)
  while (images < 8) {
    const json f = viewer.Read();
    ASSERT_FALSE(f.is_null()) << "nothing within 10 s after " << images << " images";
    ASSERT_FALSE(f.value("ended", false)) << "ended while streaming";
    ++frames;
    if (!f.contains("jpeg_base64")) continue;
    const int k = static_cast<int>(std::lround(f["t_s"].get<double>() / 0.05));
    EXPECT_EQ(k % 4, 0) << "a frame that carried no JPEG got one";
    const std::string jpeg = FromBase64(f["jpeg_base64"].get<std::string>());
    ASSERT_EQ(jpeg.size(), StationJpeg(k).size()) << "frame " << k;
    EXPECT_TRUE(jpeg == StationJpeg(k)) << "frame " << k << ": not the station's bytes";
    EXPECT_DOUBLE_EQ(f["tip_arc_m"].get<double>(), 0.01 * k) << "with the frame that carried it";
    latency_ms.push_back(NowUnixMs() - f["sent_unix_ms"].get<int64_t>());
    ++images;
  }
  ASSERT_TRUE(station.Finish().ok());
  ASSERT_GE(WaitListed(b, false, std::chrono::seconds(3)).count(), 0) << "B missed the end";
  Stop(&a, SIGTERM);  // both log their relay's counters
  Stop(&b, SIGTERM);
  const auto counter = [](const std::string& log, const std::string& pattern) {
    std::smatch m;
    return std::regex_search(log, m, std::regex(pattern)) ? std::stoll(m[1]) : -1;
  };
  const std::string log_a = ReadLog(a), log_b = ReadLog(b);
  EXPECT_GT(counter(log_a, R"(images: (\d+) published)"), 0) << log_a;
  EXPECT_EQ(counter(log_a, R"(images: \d+ published, \d+ thinned out, (\d+) dropped)"), 0) << log_a;
  EXPECT_GE(counter(log_b, R"(images from other replicas: \d+ received, (\d+) completed)"), images)
      << log_b;
  std::sort(latency_ms.begin(), latency_ms.end());
  std::cout << "A to B: " << images << " JPEGs of 16 KiB among " << frames
            << " frames, latency p50 " << latency_ms[latency_ms.size() / 2] << " ms, max "
            << latency_ms.back() << " ms\n"
            << log_a.substr(log_a.find("live relay: stopped")) << "\n"
            << log_b.substr(log_b.find("live relay: stopped")) << "\n";
}

}  // namespace
}  // namespace ves::server::testing
