// live_bench: live proctoring on loopback (docs/web.md, "Live proctoring"):
// N stations stream Live.StreamSession at 20 Hz (80-point scope and colon,
// as ves-station run sends them), one WebSocket viewer per station; the
// station-to-viewer latency (send to receipt of the JSON, one process, one
// steady clock) and the process CPU. Bounded by --seconds.
//   live_bench [--stations 50] [--seconds 10]
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "bench/server/bench_server.h"
#include "patient_db/store.h"
#include "server/auth.h"
#include "server/client.h"
#include "server/server.h"
#include "ves/v1/live.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;
namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

double NowS() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

ves::v1::LiveFrame Frame(int k) {
  ves::v1::LiveFrame f;
  for (int i = 0; i < 80; ++i) {
    for (float v : {0.001f * i, 0.0005f * k, 0.002f * i}) f.add_scope_xyz_m(v);
    for (float v : {0.01f * i, 0.0f, 0.02f * i}) f.add_colon_xyz_m(v);
  }
  f.set_tip_arc_m(0.001 * k);
  f.set_inserted_m(0.001 * k);
  f.set_t_s(NowS());  // the send time on this process's steady clock
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  int stations = 50;
  double seconds = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--stations")) stations = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
  }
  if (stations < 1 || stations > 500 || !(seconds > 0 && seconds <= 120)) {
    std::fprintf(stderr, "live_bench: --stations in 1..500, --seconds in (0, 120]\n");
    return 2;
  }
  const auto dir = ves::bench::ScratchDir("ves-live-bench-");
  auto server = ves::bench::LoopbackServer(dir, /*http=*/true);
  auto& store = server->store();
  store.AddInstitution("north", 1);
  const std::string station_token = ves::server::NewToken();
  const std::string supervisor_token = ves::server::NewToken();
  store.AddToken({ves::server::Sha256Hex(station_token), ves::patient_db::StoreRole::kStation,
                  "north", "", "bench station", 1});
  store.AddToken({ves::server::Sha256Hex(supervisor_token),
                  ves::patient_db::StoreRole::kSupervisor, "north", "", "bench supervisor", 1});
  for (int s = 0; s < stations; ++s) {
    store.AddTrainee({"t" + std::to_string(s), "north", "Trainee", 1});
  }
  server->Start();
  const int http_port = server->http_port();
  ves::server::ClientOptions client;
  client.address = "127.0.0.1:" + std::to_string(server->port());
  client.token = station_token;
  auto channel = ves::server::MakeClientChannel(client);

  std::mutex mutex;
  std::vector<double> latency_ms;
  std::atomic<long> sent{0}, received{0};
  std::atomic<int> started{0};
  std::vector<std::thread> threads;
  for (int s = 0; s < stations; ++s) {
    const std::string uuid = "00000000-0000-4000-8000-" + std::to_string(100000000000LL + s);
    threads.emplace_back([&, s, uuid] {
      auto stub = ves::v1::Live::NewStub(channel);
      grpc::ClientContext ctx;
      ctx.AddMetadata("authorization", "Bearer " + station_token);
      ves::v1::LiveStreamSummary summary;
      auto writer = stub->StreamSession(&ctx, &summary);
      ves::v1::LiveFrame first = Frame(0);
      first.set_session_uuid(uuid);
      first.set_trainee_id("t" + std::to_string(s));
      first.set_case_id("standard-adult");
      writer->Write(first);
      ++started;
      while (started < 2 * stations) std::this_thread::sleep_for(std::chrono::milliseconds(5));
      const auto t0 = Clock::now();
      for (int k = 1; Clock::now() - t0 < std::chrono::duration<double>(seconds); ++k) {
        if (!writer->Write(Frame(k))) break;
        ++sent;
        std::this_thread::sleep_until(t0 + std::chrono::milliseconds(50 * k));
      }
      writer->WritesDone();
      writer->Finish();
    });
    threads.emplace_back([&, uuid] {
      asio::io_context io;
      websocket::stream<tcp::socket> ws(io);
      ws.set_option(websocket::stream_base::decorator([&](websocket::request_type& req) {
        req.set(beast::http::field::authorization, "Bearer " + supervisor_token);
      }));
      beast::error_code ec;
      for (int attempt = 0; attempt < 500; ++attempt) {  // until the station's stream is live
        tcp::resolver resolver(io);
        ws.next_layer().close(ec);
        asio::connect(ws.next_layer(), resolver.resolve("127.0.0.1", std::to_string(http_port)));
        ws.handshake("127.0.0.1", "/api/v1/live/ws?session=" + uuid, ec);
        if (!ec) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      ++started;
      std::vector<double> mine;
      while (!ec) {
        beast::flat_buffer buffer;
        ws.read(buffer, ec);
        if (ec) break;
        const double now = NowS();
        const auto j = nlohmann::json::parse(beast::buffers_to_string(buffer.data()));
        if (j.contains("ended")) break;
        if (j["tip_arc_m"].get<double>() == 0) continue;  // the first frame, sent before the clock
        mine.push_back((now - j["t_s"].get<double>()) * 1e3);
        ++received;
      }
      std::lock_guard lock(mutex);
      latency_ms.insert(latency_ms.end(), mine.begin(), mine.end());
    });
  }
  while (started < 2 * stations) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const double cpu0 = CpuSeconds();
  const auto wall0 = Clock::now();
  for (auto& t : threads) t.join();
  const double cpu = CpuSeconds() - cpu0;
  const double wall = std::chrono::duration<double>(Clock::now() - wall0).count();
  std::sort(latency_ms.begin(), latency_ms.end());
  const auto at = [&](double q) {
    return latency_ms.empty() ? 0.0
                              : latency_ms[std::min(latency_ms.size() - 1,
                                                    static_cast<size_t>(q * latency_ms.size()))];
  };
  std::printf("live_bench: %d stations at 20 Hz, one WebSocket viewer each, %.0f s\n", stations,
              seconds);
  std::printf(
      "  frames sent %ld, received by viewers %ld (%.1f%%; a slow viewer gets the newest)\n",
      sent.load(), received.load(), sent ? 100.0 * received / sent : 0.0);
  std::printf("  station-to-viewer latency p50 %.2f ms  p95 %.2f ms  p99 %.2f ms  max %.2f ms\n",
              at(0.5), at(0.95), at(0.99), latency_ms.empty() ? 0.0 : latency_ms.back());
  std::printf("  process CPU (server, %d station and %d viewer threads) %.1f s over %.1f s wall\n",
              stations, stations, cpu, wall);
  server->Shutdown(std::chrono::milliseconds(0));
  server.reset();
  std::filesystem::remove_all(dir);
  return latency_ms.empty() ? 1 : 0;
}
