// replica_bench: durable session uploads through 1..N ves-server replicas on
// one PostgreSQL database, beside pgbench's single-row insert rate on the same
// server in the same run (docs/operations.md, "Scaling out").
//
//   replica_bench --db postgresql://USER@HOST:PORT/DB [--server PATH]
//                 [--replicas 1,2] [--clients 1,16,64] [--seconds 5] [--pgbench PATH]
//
// Every replica is the real ves-server binary, a child on 127.0.0.1:0. Each
// client uploads fresh records (new UUIDs) in a loop, round-robin over the
// replicas, and counts an upload once it is acknowledged (durable: committed
// with synchronous_commit=on). Prints uploads/s and p50/p99 latency per
// configuration, then pgbench (-c clients) inserting one row per transaction.
// The benchmark works in its own schema, dropped at the end.
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/program_options.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <pqxx/pqxx>
#include <random>
#include <sstream>
#include <thread>

#include "bench/server/bench_server.h"
#include "patient_db/case_format.h"
#include "patient_db/pg_store.h"
#include "server/auth.h"
#include "server/client.h"
#include "station/training/input_log.h"
#include "ves/v1/services.grpc.pb.h"

namespace {

namespace po = boost::program_options;
using Clock = std::chrono::steady_clock;

std::vector<int> ParseList(const std::string& text, const std::string& what) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    int v = 0;
    try {
      v = std::stoi(item);
    } catch (const std::exception&) {
      v = 0;
    }
    if (v <= 0) throw std::invalid_argument(what + " '" + text + "' is not a list of counts > 0");
    out.push_back(v);
  }
  return out;
}

std::string Uuid(std::mt19937_64& rng) {
  static const char kHex[] = "0123456789abcdef";
  std::string s(36, '-');
  for (size_t i = 0; i < s.size(); ++i) {
    if (i != 8 && i != 13 && i != 18 && i != 23) s[i] = kHex[rng() & 0xf];
  }
  s[14] = '4';
  s[19] = kHex[8 + (rng() & 3)];
  return s;
}

constexpr char kCaseFile[] = VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto";

// A record of realistic size (a few KiB with its input log).
ves::v1::SessionRecord Record(std::mt19937_64& rng, int i) {
  ves::v1::SessionRecord r = ves::bench::BenchRecord(Uuid(rng), 1'700'000'000'000 + i);
  r.set_score(75);
  // A well-formed log (its header is checked at upload) of 1000 steps.
  std::vector<ves::training::InputSample> samples(1000);
  for (size_t k = 0; k < samples.size(); ++k) {
    samples[k].tick = k;
    samples[k].push_force_N = 1e-4 * static_cast<double>((k * 7 + i) % 97);
  }
  *r.mutable_input_log() = ves::training::MakeInputLog(samples, 0.001);
  r.set_operator_kind("scripted");
  return r;
}

struct Replica {
  pid_t pid = -1;
  int port = 0;
};

Replica StartReplica(const std::string& server, const std::string& url,
                     const std::filesystem::path& dir, int n) {
  const std::string port_file = (dir / ("port" + std::to_string(n))).string();
  const std::string log = (dir / ("server" + std::to_string(n) + ".log")).string();
  std::filesystem::remove(port_file);
  Replica r;
  r.pid = ::fork();
  if (r.pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive this process
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execl(server.c_str(), "ves-server", "--listen", "127.0.0.1:0", "--db", url.c_str(),
            "--insecure-loopback", "--quiet", "--port-file", port_file.c_str(), nullptr);
    ::_exit(127);
  }
  for (int i = 0; i < 400 && !std::filesystem::exists(port_file); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  std::ifstream(port_file) >> r.port;
  if (r.port <= 0) throw std::runtime_error("ves-server did not start, see " + log);
  return r;
}

void StopReplica(Replica* r) {
  if (r->pid <= 0) return;
  ::kill(r->pid, SIGTERM);
  int status = 0;
  ::waitpid(r->pid, &status, 0);
  r->pid = -1;
}

struct Result {
  double uploads_per_s = 0;
  double p50_ms = 0;
  double p99_ms = 0;
  int errors = 0;
};

Result RunClients(const std::vector<Replica>& replicas, const std::string& token, int clients,
                  double seconds) {
  std::vector<std::vector<double>> latencies(clients);
  std::atomic<int> errors{0};
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      ves::server::ClientOptions o;
      o.address = "127.0.0.1:" + std::to_string(replicas[c % replicas.size()].port);
      o.token = token;
      o.deadline = std::chrono::seconds(30);
      auto stub = ves::v1::Sessions::NewStub(ves::server::MakeClientChannel(o));
      std::mt19937_64 rng(std::random_device{}() ^ (uint64_t(c) << 32));
      for (int i = 0; !stop; ++i) {
        ves::v1::UploadSessionRequest q;
        *q.mutable_record() = Record(rng, i);
        ves::v1::UploadSessionResponse resp;
        grpc::ClientContext ctx;
        ves::server::PrepareContext(&ctx, o);
        const auto t0 = Clock::now();
        const grpc::Status st = stub->UploadSession(&ctx, q, &resp);
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        if (st.ok()) {
          latencies[c].push_back(ms);
        } else if (errors++ == 0) {
          std::cerr << "replica_bench: upload failed: " << st.error_message() << "\n";
        }
      }
    });
  }
  const auto start = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  stop = true;
  for (auto& t : threads) t.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::vector<double> all;
  for (auto& l : latencies) all.insert(all.end(), l.begin(), l.end());
  std::sort(all.begin(), all.end());
  Result r;
  r.errors = errors;
  if (all.empty()) return r;
  r.uploads_per_s = all.size() / elapsed;
  r.p50_ms = all[all.size() / 2];
  r.p99_ms = all[std::min(all.size() - 1, all.size() * 99 / 100)];
  return r;
}

// pgbench inserting one row per transaction into a table of this schema.
double PgbenchInsertTps(const std::string& pgbench, const std::string& url,
                        const std::filesystem::path& dir, int clients, double seconds) {
  const auto script = dir / "insert.sql";
  std::ofstream(script) << "INSERT INTO bench_rows (payload) VALUES (repeat('x', 100));\n";
  const std::string out = (dir / "pgbench.out").string();
  const std::string cmd = pgbench + " -n -f " + script.string() + " -c " +
                          std::to_string(clients) + " -j " +
                          std::to_string(std::min(clients, 16)) + " -T " +
                          std::to_string(static_cast<int>(std::max(1.0, seconds))) + " '" + url +
                          "' > " + out + " 2>&1";
  if (std::system(cmd.c_str()) != 0) {
    std::cerr << "replica_bench: pgbench failed, see " << out << "\n";
    return 0;
  }
  std::ifstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    const auto at = line.find("tps = ");
    if (at != std::string::npos) return std::stod(line.substr(at + 6));
  }
  return 0;
}

std::string FindTool(const std::string& name) {
  for (const char* dir : {"/usr/lib/postgresql/17/bin", "/usr/lib/postgresql/16/bin",
                          "/usr/lib/postgresql/15/bin"}) {
    const std::string p = std::string(dir) + "/" + name;
    if (std::filesystem::exists(p)) return p;
  }
  return name;
}

}  // namespace

int main(int argc, char** argv) {
  std::string db, server = VES_SERVER_PATH, replicas_text = "1,2", clients_text = "1,16,64";
  std::string pgbench = FindTool("pgbench");
  double seconds = 5;
  po::options_description desc("replica_bench options");
  desc.add_options()("help,h", "show this help")(
      "db", po::value(&db), "postgresql:// URL (default: $VES_TEST_POSTGRES_URL)")(
      "server", po::value(&server)->default_value(server), "ves-server binary")(
      "replicas", po::value(&replicas_text)->default_value(replicas_text), "replica counts")(
      "clients", po::value(&clients_text)->default_value(clients_text), "client counts")(
      "seconds", po::value(&seconds)->default_value(seconds), "per configuration")(
      "pgbench", po::value(&pgbench)->default_value(pgbench), "pgbench binary");
  std::vector<int> replica_counts, client_counts;
  try {
    po::variables_map vm;
    po::store(po::parse_command_line(argc, argv, desc), vm);
    if (vm.count("help")) {
      std::cout << desc;
      return 0;
    }
    po::notify(vm);
    if (db.empty() && std::getenv("VES_TEST_POSTGRES_URL")) db = std::getenv("VES_TEST_POSTGRES_URL");
    if (db.rfind("postgres", 0) != 0) throw std::invalid_argument("--db must be a postgresql:// URL");
    if (!(seconds > 0)) throw std::invalid_argument("--seconds must be > 0");
    replica_counts = ParseList(replicas_text, "--replicas");
    client_counts = ParseList(clients_text, "--clients");
  } catch (const std::exception& e) {
    std::cerr << "replica_bench: " << e.what() << "\n";
    return 2;
  }

  const std::string schema = "ves_bench_" + std::to_string(::getpid());
  const std::string url = db + (db.find('?') == std::string::npos ? "?" : "&") +
                          "options=-csearch_path%3D" + schema;
  const auto dir = std::filesystem::temp_directory_path() / schema;
  std::filesystem::create_directories(dir);
  int status = 0;
  try {
    {
      pqxx::connection conn(db);
      pqxx::nontransaction q(conn);
      q.exec("CREATE SCHEMA " + schema);
      q.exec("CREATE TABLE " + schema + ".bench_rows (id BIGSERIAL PRIMARY KEY, payload TEXT)");
      std::cout << "PostgreSQL " << q.exec("SHOW server_version")[0][0].c_str()
                << ", synchronous_commit=" << q.exec("SHOW synchronous_commit")[0][0].c_str()
                << ", fsync=" << q.exec("SHOW fsync")[0][0].c_str() << "; "
                << std::thread::hardware_concurrency() << " CPUs; " << seconds
                << " s per configuration\n";
    }
    const std::string token = ves::server::NewToken();
    {
      ves::patient_db::PgStoreOptions o;
      o.url = url;
      ves::patient_db::PgStore store(o);
      store.AddInstitution("bench", 1);
      store.AddTrainee({"bench-trainee", "bench", "Bench", 1});
      // The case the records name (the server refuses sessions of unknown cases).
      ves::bench::PutBenchCase(store, ves::patient_db::LoadCaseFile(kCaseFile), "bench");
      store.AddToken({ves::server::Sha256Hex(token), ves::patient_db::StoreRole::kStation,
                      "bench", "", "bench", 1});
    }
    std::printf("%-9s %-8s %12s %9s %9s %7s\n", "replicas", "clients", "uploads/s", "p50 ms",
                "p99 ms", "errors");
    for (int n : replica_counts) {
      std::vector<Replica> replicas;
      for (int i = 0; i < n; ++i) replicas.push_back(StartReplica(server, url, dir, i));
      for (int c : client_counts) {
        const Result r = RunClients(replicas, token, c, seconds);
        std::printf("%-9d %-8d %12.0f %9.2f %9.2f %7d\n", n, c, r.uploads_per_s, r.p50_ms,
                    r.p99_ms, r.errors);
        std::fflush(stdout);
      }
      for (auto& r : replicas) StopReplica(&r);
    }
    std::printf("pgbench single-row INSERT, one per transaction, same server:\n");
    for (int c : client_counts) {
      std::printf("  clients %-4d %10.0f tps\n", c, PgbenchInsertTps(pgbench, url, dir, c, seconds));
    }
  } catch (const std::exception& e) {
    std::cerr << "replica_bench: " << e.what() << "\n";
    status = 1;
  }
  try {
    pqxx::connection conn(db);
    pqxx::nontransaction(conn).exec("DROP SCHEMA IF EXISTS " + schema + " CASCADE");
  } catch (const std::exception&) {
  }
  std::filesystem::remove_all(dir);
  return status;
}
