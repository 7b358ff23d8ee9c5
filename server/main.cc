// ves-server: the central gRPC server (docs/server.md) and, with --http, the
// web front end (docs/web.md).
//   ves-server --listen 127.0.0.1:50051 --db sqlite:PATH|postgresql://URL [--http HOST:PORT]
//              [--tls-cert F --tls-key F [--tls-client-ca F] | --insecure-loopback]
// SIGTERM or SIGINT drains in-flight calls, commits pending writes and exits 0.
#include <spdlog/spdlog.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/program_options.hpp>
#include <fstream>
#include <iostream>

#include "patient_db/store_factory.h"
#include "server/server.h"

namespace po = boost::program_options;

namespace {

// The command line, as read.
struct Flags {
  ves::server::ServerOptions options;
  std::string db_url;
  std::string port_file;
  std::string http_port_file;
  int drain_s = 20;
};

// The flags, read into `f`.
void Describe(Flags* f, po::options_description* desc) {
  desc->add_options()("help,h", "show this help")(
      "listen", po::value(&f->options.listen)->default_value(f->options.listen),
      "host:port to serve")(
      "http", po::value(&f->options.http_listen),
      "host:port of the web front end and JSON API (HTTPS with the TLS flags; plain HTTP "
      "only on loopback)")(
      "http-port-file", po::value(&f->http_port_file),
      "write the bound HTTP port here (for --http ...:0)")(
      "db", po::value(&f->db_url)->required(),
      "database URL: sqlite:/var/lib/ves/ves.db or postgresql://USER@HOST/DB")(
      "tls-cert", po::value(&f->options.tls_cert_file), "server certificate chain (PEM)")(
      "tls-key", po::value(&f->options.tls_key_file), "server private key (PEM)")(
      "tls-client-ca", po::value(&f->options.tls_client_ca_file),
      "require client certificates signed by this CA (PEM)")(
      "insecure-loopback", po::bool_switch(&f->options.insecure_loopback),
      "serve plaintext (only on a loopback --listen address)")(
      "max-message-mb", po::value<int>()->default_value(16), "largest message accepted, MiB")(
      "drain-s", po::value(&f->drain_s)->default_value(f->drain_s),
      "on SIGTERM, seconds in-flight calls get to finish")(
      "port-file", po::value(&f->port_file), "write the bound port here (for --listen ...:0)")(
      "judge-memory-mb", po::value<int>()->default_value(1024),
      "memory one judged lesson session's input log may take, MiB")(
      "judge-cpu-s", po::value(&f->options.judge_budget.cpu_base_s)->default_value(60.0),
      "CPU seconds a judged replay may use, plus half a second per second of the lesson")(
      "oidc-issuer", po::value(&f->options.oidc.issuer),
      "sign-in through this OpenID Connect provider (its issuer URL; docs/web.md)")(
      "oidc-client-id", po::value(&f->options.oidc.client_id), "this server's client id there")(
      "oidc-client-secret-file", po::value<std::string>(),
      "file holding the client secret (one line; kept off the command line)")(
      "oidc-redirect-uri", po::value(&f->options.oidc.redirect_uri),
      "https://HOST:PORT/api/v1/oidc/callback, as registered with the provider")(
      "oidc-ca", po::value(&f->options.oidc.ca_file),
      "CA of the provider's certificate (PEM; default: the system's CAs)")(
      "quiet", "do not log every call");
}

// One line on stderr for a flag out of range; false.
bool Refuse(const std::string& why) {
  std::cerr << "ves-server: " << why << "\n";
  return false;
}

// The numbers' ranges and the OpenID Connect settings; fills what derives
// from them into f->options.
bool CheckFlags(const po::variables_map& vm, Flags* f) {
  ves::server::ServerOptions& options = f->options;
  const int max_message_mb = vm["max-message-mb"].as<int>();
  const int judge_memory_mb = vm["judge-memory-mb"].as<int>();
  if (max_message_mb < 1 || max_message_mb > 1024) {
    return Refuse("--max-message-mb " + std::to_string(max_message_mb) + ": must be in 1..1024");
  }
  if (f->drain_s < 0 || f->drain_s > 3600) {
    return Refuse("--drain-s " + std::to_string(f->drain_s) + ": must be in 0..3600");
  }
  if (judge_memory_mb < 16 || judge_memory_mb > 65536) {
    return Refuse("--judge-memory-mb " + std::to_string(judge_memory_mb) +
                  ": must be in 16..65536");
  }
  if (!(options.judge_budget.cpu_base_s >= 1.0 && options.judge_budget.cpu_base_s <= 86400.0)) {
    std::cerr << "ves-server: --judge-cpu-s " << options.judge_budget.cpu_base_s
              << ": must be in 1..86400\n";
    return false;
  }
  if (vm.count("oidc-client-secret-file")) {
    const std::string path = vm["oidc-client-secret-file"].as<std::string>();
    std::ifstream in(path);
    if (!in || !std::getline(in, options.oidc.client_secret)) {
      return Refuse("--oidc-client-secret-file '" + path + "': cannot read a line");
    }
  }
  if (!options.oidc.issuer.empty() && options.http_listen.empty()) {
    return Refuse("--oidc-issuer needs --http (the sign-in is on the web pages)");
  }
  if (std::string why = ves::server::CheckOidcConfig(options.oidc); !why.empty()) {
    return Refuse(why);
  }
  options.judge_budget.memory_bytes = static_cast<uint64_t>(judge_memory_mb) << 20;
  options.max_receive_message_bytes = max_message_mb << 20;
  options.log_calls = vm.count("quiet") == 0;
  // Replicas on one PostgreSQL show each other's live sessions (docs/web.md).
  if (ves::patient_db::IsPostgresUrl(f->db_url)) options.live_relay_url = f->db_url;
  return true;
}

// Written whole or not at all (renamed into place).
void WritePortFile(const std::string& path, int port) {
  std::ofstream(path + ".tmp") << port << "\n";
  std::rename((path + ".tmp").c_str(), path.c_str());
}

// Serves until SIGTERM or SIGINT, then drains; the exit status.
int Serve(const Flags& f) {
  const ves::server::ServerOptions& options = f.options;
  try {
    ves::server::MakeServerCredentials(options);  // refuse bad TLS choices before opening the DB
    ves::server::VesServer server(options, ves::patient_db::OpenStoreFromUrl(f.db_url));
    server.Start();
    spdlog::info("ves-server listening on port {} ({}), database {}", server.port(),
                 options.tls_cert_file.empty() ? "plaintext loopback" : "TLS", f.db_url);
    if (!f.port_file.empty()) WritePortFile(f.port_file, server.port());
    if (server.http_port() != 0) {
      spdlog::info("ves-server web front end on port {} ({})", server.http_port(),
                   options.tls_cert_file.empty() ? "plain HTTP, loopback" : "HTTPS");
      if (!f.http_port_file.empty()) WritePortFile(f.http_port_file, server.http_port());
    }
    boost::asio::io_context io;
    boost::asio::signal_set signals(io, SIGTERM, SIGINT);
    signals.async_wait([&](const boost::system::error_code&, int signal_number) {
      spdlog::info("signal {}: draining in-flight calls (up to {} s)", signal_number, f.drain_s);
    });
    io.run();
    server.Shutdown(std::chrono::seconds(f.drain_s));
    spdlog::info("ves-server stopped after {} commit batches", server.commit_batches());
  } catch (const std::invalid_argument& e) {
    std::cerr << "ves-server: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "ves-server: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Flags flags;
  po::options_description desc("ves-server options");
  Describe(&flags, &desc);
  po::variables_map vm;
  try {
    po::store(po::parse_command_line(argc, argv, desc), vm);
    if (vm.count("help")) {
      std::cout << "usage: ves-server --db sqlite:PATH|postgresql://URL [--listen ADDR] [TLS flags]\n"
                << desc;
      return 0;
    }
    po::notify(vm);
  } catch (const po::error& e) {
    std::cerr << "ves-server: " << e.what() << " (see ves-server --help)\n";
    return 2;
  }
  if (!CheckFlags(vm, &flags)) return 2;
  return Serve(flags);
}
