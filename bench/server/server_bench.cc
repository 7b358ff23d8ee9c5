// server_bench: the figures of docs/server.md, all in one run on one machine.
//   1. raw SQLite single-row durable commits/s (WAL, synchronous=FULL), the
//      ceiling without group commit;
//   2. Sessions.UploadSession over loopback gRPC with 1, 16, 64 clients
//      (uploads/s, p50, p99), each acknowledged only once durable;
//   3. Cases.DownloadCase MB/s for a ~50 MB case vs a raw loopback TCP copy.
// Usage: server_bench [--seconds S] [--case-mb M] [--case-file F.textproto]
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/server/bench_server.h"
#include "patient_db/case_format.h"
#include "patient_db/sqlite_db.h"
#include "server/client.h"
#include "server/server.h"
#include "station/training/input_log.h"
#include "ves/v1/services.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;
using ves::server::ClientOptions;

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

std::string Uuid(std::mt19937_64& rng) {
  static const char kHex[] = "0123456789abcdef";
  std::string s(36, '-');
  for (size_t i = 0; i < s.size(); ++i) {
    if (i != 8 && i != 13 && i != 18 && i != 23) s[i] = kHex[rng() & 0xf];
  }
  return s;
}

// A well-formed input log (its header is checked at upload) of about 1 KiB.
const ves::v1::InputLog& InputLogBytes() {
  static const ves::v1::InputLog kLog = [] {
    std::vector<ves::training::InputSample> samples(1000);
    std::mt19937_64 rng(9);
    for (size_t i = 0; i < samples.size(); ++i) {
      samples[i].tick = i;
      samples[i].push_force_N = 1e-4 * static_cast<double>(rng() % 64);
    }
    return ves::training::MakeInputLog(samples, 0.001);
  }();
  return kLog;
}

// A session record of typical size: metrics, a few events, a 1 KiB input log.
ves::v1::SessionRecord Record(const std::string& uuid, int seed) {
  ves::v1::SessionRecord r = ves::bench::BenchRecord(uuid, 1'700'000'000'000 + seed);
  r.mutable_metrics()->set_pain_s(4);
  r.set_score(70);
  for (int i = 0; i < 8; ++i) {
    r.add_events()->set_t_s(i);
    r.mutable_events(i)->set_kind(ves::v1::EVENT_KIND_LOOP);
  }
  *r.mutable_input_log() = InputLogBytes();
  return r;
}

double RawSqliteCommitsPerSecond(const std::filesystem::path& dir, double seconds) {
  ves::patient_db::SqliteDb db((dir / "raw.db").string());
  db.Exec("CREATE TABLE t (id INTEGER PRIMARY KEY, body BLOB NOT NULL)", nullptr);
  const std::string body = Record("x", 0).SerializeAsString();
  auto* insert = db.Prepare("INSERT INTO t (body) VALUES (?)", nullptr);
  int n = 0;
  const auto start = Clock::now();
  while (Seconds(start, Clock::now()) < seconds) {
    insert->BindBlob(1, body);  // autocommit: one durable transaction per row
    int rc = 0;
    insert->Step(&rc);
    insert->Reset();
    ++n;
  }
  return n / Seconds(start, Clock::now());
}

struct UploadFigures {
  double per_second = 0;
  double p50_ms = 0;
  double p99_ms = 0;
  int failures = 0;
};

UploadFigures RunUploads(const ClientOptions& client, int clients, double seconds, int seed) {
  std::vector<std::vector<double>> latencies(clients);
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  const auto start = Clock::now();
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      std::mt19937_64 rng(seed * 1000 + c);
      auto stub = ves::v1::Sessions::NewStub(ves::server::MakeClientChannel(client));
      ves::v1::UploadSessionRequest q;
      *q.mutable_record() = Record("", c);
      while (Seconds(start, Clock::now()) < seconds) {
        q.mutable_record()->set_uuid(Uuid(rng));
        grpc::ClientContext ctx;
        ves::server::PrepareContext(&ctx, client);
        ves::v1::UploadSessionResponse r;
        const auto t0 = Clock::now();
        if (!stub->UploadSession(&ctx, q, &r).ok()) ++failures;
        latencies[c].push_back(Seconds(t0, Clock::now()) * 1e3);
      }
    });
  }
  for (auto& t : threads) t.join();
  const double elapsed = Seconds(start, Clock::now());
  std::vector<double> all;
  for (auto& l : latencies) all.insert(all.end(), l.begin(), l.end());
  std::sort(all.begin(), all.end());
  UploadFigures f;
  f.per_second = all.size() / elapsed;
  f.p50_ms = all.empty() ? 0 : all[all.size() / 2];
  f.p99_ms = all.empty() ? 0 : all[std::min(all.size() - 1, all.size() * 99 / 100)];
  f.failures = failures;
  return f;
}

double DownloadMBps(const ClientOptions& client, const std::string& case_id, size_t expect) {
  auto stub = ves::v1::Cases::NewStub(ves::server::MakeClientChannel(client));
  double best = 0;
  for (int round = 0; round < 4; ++round) {  // round 0 warms the blob cache
    grpc::ClientContext ctx;
    ves::server::PrepareContext(&ctx, client);
    ves::v1::DownloadCaseRequest q;
    q.set_case_id(case_id);
    const auto t0 = Clock::now();
    auto reader = stub->DownloadCase(&ctx, q);
    ves::v1::CaseChunk chunk;
    size_t bytes = 0;
    while (reader->Read(&chunk)) bytes += chunk.data().size();
    const bool ok = reader->Finish().ok() && bytes == expect;
    const double mbps = bytes / 1e6 / Seconds(t0, Clock::now());
    if (!ok) std::fprintf(stderr, "download failed or short (%zu bytes)\n", bytes);
    if (round > 0) best = std::max(best, mbps);
  }
  return best;
}

// The same bytes through a plain loopback TCP socket: the transport's ceiling.
double RawTcpMBps(const std::string& bytes) {
  const int listener = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  socklen_t len = sizeof addr;
  ::getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len);
  ::listen(listener, 1);
  double best = 0;
  for (int round = 0; round < 3; ++round) {
    std::thread sender([&] {
      const int fd = ::accept(listener, nullptr, nullptr);
      size_t off = 0;
      while (off < bytes.size()) {
        const ssize_t n = ::send(fd, bytes.data() + off, bytes.size() - off, MSG_NOSIGNAL);
        if (n <= 0) break;
        off += n;
      }
      ::close(fd);
    });
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    const auto t0 = Clock::now();
    ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    std::vector<char> buf(1 << 20);
    std::string received;
    received.reserve(bytes.size());
    ssize_t n;
    while ((n = ::recv(fd, buf.data(), buf.size(), 0)) > 0) received.append(buf.data(), n);
    const double mbps = received.size() / 1e6 / Seconds(t0, Clock::now());
    ::close(fd);
    sender.join();
    best = std::max(best, mbps);
  }
  ::close(listener);
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 3;
  size_t case_mb = 50;
  std::string case_file = VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--case-mb")) case_mb = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--case-file")) case_file = argv[i + 1];
  }
  const auto dir = ves::bench::ScratchDir("ves_server_bench_");
  std::printf("server_bench: %u hardware threads, %.1f s per measurement, db in %s\n",
              std::thread::hardware_concurrency(), seconds, dir.c_str());

  std::printf("raw SQLite single-row commits (WAL, synchronous=FULL): %.0f commits/s\n",
              RawSqliteCommitsPerSecond(dir, seconds));

  const auto server_ptr = ves::bench::LoopbackServer(dir, /*http=*/false);
  ves::server::VesServer& server = *server_ptr;
  server.Start();
  auto& store = server.store();
  store.AddInstitution("bench", 1);
  store.AddTrainee({"bench-trainee", "bench", "Bench", 1});
  {
    // The case the records name (the server refuses sessions of unknown cases).
    ves::bench::PutBenchCase(store, ves::patient_db::LoadCaseFile(case_file), "bench");
  }
  const std::string token = ves::server::NewToken();
  store.AddToken({ves::server::Sha256Hex(token), ves::patient_db::StoreRole::kAdmin, "bench",
                  "", "bench", 1});
  ClientOptions client;
  client.address = "127.0.0.1:" + std::to_string(server.port());
  client.token = token;
  client.deadline = std::chrono::seconds(30);

  std::printf("UploadSession over loopback gRPC (durable, group commit):\n");
  std::printf("  %7s  %10s  %8s  %8s  %8s\n", "clients", "uploads/s", "p50 ms", "p99 ms",
              "failed");
  int seed = 1;
  for (int clients : {1, 16, 64}) {
    const uint64_t batches_before = server.commit_batches();
    const auto f = RunUploads(client, clients, seconds, seed++);
    const uint64_t batches = server.commit_batches() - batches_before;
    std::printf("  %7d  %10.0f  %8.2f  %8.2f  %8d   (%.1f records per commit)\n", clients,
                f.per_second, f.p50_ms, f.p99_ms, f.failures,
                batches ? f.per_second * seconds / batches : 0.0);
  }

  // A ~50 MB case: the sample case with a large (random, PNG-tagged) texture.
  auto colon_case = ves::patient_db::LoadCaseFile(case_file);
  std::string image = "\x89PNG\r\n\x1a\n";
  std::mt19937_64 rng(5);
  while (image.size() < case_mb << 20) {
    const uint64_t v = rng();
    image.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  colon_case.mutable_mucosa_texture()->set_media_type("image/png");
  colon_case.mutable_mucosa_texture()->set_image(image);
  colon_case.set_version(colon_case.version() + 1);  // the records' version stays as it is
  const std::string bundle = ves::bench::PutBenchCase(store, colon_case, "bench");
  const double grpc_mbps = DownloadMBps(client, colon_case.id(), bundle.size());
  const double tcp_mbps = RawTcpMBps(bundle);
  std::printf("case download, %.1f MB bundle, plaintext loopback:\n", bundle.size() / 1e6);
  std::printf("  gRPC DownloadCase (1 MiB chunks): %8.0f MB/s\n", grpc_mbps);
  std::printf("  raw TCP copy of the same bytes:   %8.0f MB/s\n", tcp_mbps);

  server.Shutdown(std::chrono::seconds(5));
  std::filesystem::remove_all(dir);
  return 0;
}
