#include "server/server.h"

#include <google/protobuf/stubs/logging.h>
#include <grpcpp/support/server_interceptor.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <spdlog/spdlog.h>

#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "patient_db/limits.h"
#include "patient_db/net_address.h"

namespace ves::server {
namespace {

std::string ReadPem(const std::string& path, const std::string& flag) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in || text.str().empty()) {
    throw std::invalid_argument(flag + " " + path + ": cannot read the file");
  }
  return text.str();
}

// The key pair said what was wrong when the pair was bad: gRPC only fails
// to listen later ("address in use or invalid").
void CheckKeyMatchesCertificate(const std::string& key_pem, const std::string& cert_pem,
                                const ServerOptions& o) {
  BIO* cert_bio = BIO_new_mem_buf(cert_pem.data(), static_cast<int>(cert_pem.size()));
  X509* cert = PEM_read_bio_X509(cert_bio, nullptr, nullptr, nullptr);
  BIO_free(cert_bio);
  BIO* key_bio = BIO_new_mem_buf(key_pem.data(), static_cast<int>(key_pem.size()));
  EVP_PKEY* key = PEM_read_bio_PrivateKey(key_bio, nullptr, nullptr, nullptr);
  BIO_free(key_bio);
  const bool matches = cert != nullptr && key != nullptr && X509_check_private_key(cert, key) == 1;
  ERR_clear_error();
  X509_free(cert);
  EVP_PKEY_free(key);
  if (cert == nullptr) {
    throw std::invalid_argument("--tls-cert " + o.tls_cert_file + ": not a PEM certificate");
  }
  if (key == nullptr) {
    throw std::invalid_argument("--tls-key " + o.tls_key_file +
                                ": not a PEM private key (or it is encrypted)");
  }
  if (!matches) {
    throw std::invalid_argument("--tls-key " + o.tls_key_file + " is not the key of --tls-cert " +
                                o.tls_cert_file);
  }
}

// One log line per call: method, status, duration, peer.
class CallLogInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit CallLogInterceptor(grpc::experimental::ServerRpcInfo* info)
      : info_(info), start_(std::chrono::steady_clock::now()) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    using grpc::experimental::InterceptionHookPoints;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      const grpc::Status status = methods->GetSendStatus();
      const double ms = std::chrono::duration<double, std::milli>(
                            std::chrono::steady_clock::now() - start_)
                            .count();
      const std::string peer = info_->server_context()->peer();
      if (status.ok()) {
        spdlog::info("{} OK {:.2f} ms peer={}", info_->method(), ms, peer);
      } else {
        spdlog::warn("{} {} {:.2f} ms peer={}: {}", info_->method(),
                     StatusCodeName(status.error_code()), ms, peer, status.error_message());
      }
    }
    methods->Proceed();
  }

 private:
  grpc::experimental::ServerRpcInfo* info_;
  std::chrono::steady_clock::time_point start_;
};

// What protobuf last logged on this thread while parsing (it names a string
// field that is not UTF-8); gRPC parses a request on the thread that then
// runs the interceptors below.
thread_local std::string last_parse_error;
google::protobuf::LogHandler* previous_log_handler = nullptr;

void RecordParseError(google::protobuf::LogLevel level, const char* file, int line,
                      const std::string& message) {
  if (level >= google::protobuf::LOGLEVEL_ERROR) last_parse_error = message;
  if (previous_log_handler != nullptr) previous_log_handler(level, file, line, message);
}

void InstallParseErrorRecorder() {
  static std::once_flag once;
  std::call_once(once, [] {
    previous_log_handler = google::protobuf::SetLogHandler(&RecordParseError);
  });
}

// gRPC answers a request it cannot parse (not protobuf, or a string field
// that is not UTF-8) UNIMPLEMENTED with no message, before any handler runs.
// This turns that answer into INVALID_ARGUMENT saying what was wrong.
class MalformedRequestInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit MalformedRequestInterceptor(grpc::experimental::ServerRpcInfo* info) : info_(info) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    using grpc::experimental::InterceptionHookPoints;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE) &&
        methods->GetRecvMessage() == nullptr &&
        info_->type() == grpc::experimental::ServerRpcInfo::Type::UNARY) {
      malformed_ = true;
      why_ = std::move(last_parse_error);
      last_parse_error.clear();
    }
    if (malformed_ &&
        methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS) &&
        methods->GetSendStatus().error_code() == grpc::StatusCode::UNIMPLEMENTED) {
      methods->ModifySendStatus(grpc::Status(
          grpc::StatusCode::INVALID_ARGUMENT,
          std::string("request is not a valid message for ") + info_->method() +
              ": malformed protobuf, or a string field that is not UTF-8" +
              (why_.empty() ? std::string()
                            : " (" + patient_db::PrintableExcerpt(why_, 200) + ")")));
    }
    methods->Proceed();
  }

 private:
  grpc::experimental::ServerRpcInfo* info_;
  bool malformed_ = false;
  std::string why_;  // protobuf's own words, when it logged any
};

class MalformedRequestFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override {
    return new MalformedRequestInterceptor(info);
  }
};

class CallLogFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override {
    return new CallLogInterceptor(info);
  }
};

}  // namespace

std::shared_ptr<grpc::ServerCredentials> MakeServerCredentials(const ServerOptions& o) {
  const bool tls = !o.tls_cert_file.empty() || !o.tls_key_file.empty();
  if (!tls) {
    if (!o.tls_client_ca_file.empty()) {
      throw std::invalid_argument("--tls-client-ca needs --tls-cert and --tls-key");
    }
    if (!o.insecure_loopback) {
      throw std::invalid_argument(
          "refusing to serve without TLS: give --tls-cert and --tls-key, or "
          "--insecure-loopback with a loopback --listen address");
    }
    if (!patient_db::IsLoopbackAddress(o.listen)) {
      throw std::invalid_argument("refusing plaintext on '" + o.listen +
                                  "': --insecure-loopback needs a loopback address such as "
                                  "127.0.0.1:50051");
    }
    return grpc::InsecureServerCredentials();
  }
  if (o.tls_cert_file.empty() || o.tls_key_file.empty()) {
    throw std::invalid_argument("TLS needs both --tls-cert and --tls-key");
  }
  if (o.insecure_loopback) {
    throw std::invalid_argument("--insecure-loopback cannot be combined with TLS flags");
  }
  grpc::SslServerCredentialsOptions ssl;
  const std::string key = ReadPem(o.tls_key_file, "--tls-key");
  const std::string cert = ReadPem(o.tls_cert_file, "--tls-cert");
  CheckKeyMatchesCertificate(key, cert, o);
  ssl.pem_key_cert_pairs.push_back({key, cert});
  if (!o.tls_client_ca_file.empty()) {
    ssl.pem_root_certs = ReadPem(o.tls_client_ca_file, "--tls-client-ca");
    ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(ssl);
}

VesServer::VesServer(ServerOptions options, std::unique_ptr<patient_db::Store> store)
    : options_(std::move(options)), store_(std::move(store)) {
  writer_ = std::make_unique<SessionWriter>(store_.get());
  auth_ = std::make_unique<Authenticator>(store_.get());
  series_ = std::make_unique<SessionSeries>(store_.get());
  judge_ = std::make_unique<LessonJudge>(store_.get(), options_.judge_budget, series_.get());
  live_ = std::make_unique<LiveHub>();
  if (!options_.live_relay_url.empty()) {
    LivePgRelayOptions relay;
    relay.url = options_.live_relay_url;
    relay_ = std::make_unique<LivePgRelay>(relay, live_.get());
    live_->SetRelay(relay_.get());
  }
  const ServiceDeps deps{store_.get(), writer_.get(), auth_.get(),
                         judge_.get(), live_.get(),   series_.get()};
  cases_ = std::make_unique<CasesService>(deps);
  sessions_ = std::make_unique<SessionsService>(deps);
  trainees_ = std::make_unique<TraineesService>(deps);
  admin_ = std::make_unique<AdminService>(deps);
  lessons_ = std::make_unique<LessonsService>(deps);
  live_service_ = std::make_unique<LiveService>(deps);
}

VesServer::~VesServer() { Shutdown(std::chrono::milliseconds(0)); }

void VesServer::Start() {
  auto credentials = MakeServerCredentials(options_);
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options_.listen, credentials, &port_);
  builder.RegisterService(cases_.get());
  builder.RegisterService(sessions_.get());
  builder.RegisterService(trainees_.get());
  builder.RegisterService(admin_.get());
  builder.RegisterService(lessons_.get());
  builder.RegisterService(live_service_.get());
  builder.SetMaxReceiveMessageSize(options_.max_receive_message_bytes);
  builder.SetMaxSendMessageSize(options_.max_send_message_bytes);
  // Keepalive: ping idle clients every 30 s, drop them after 10 s of silence;
  // accept client pings no more often than every 10 s.
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, 30000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10000);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 2);
  InstallParseErrorRecorder();
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
  creators.push_back(std::make_unique<MalformedRequestFactory>());
  if (options_.log_calls) creators.push_back(std::make_unique<CallLogFactory>());
  builder.experimental().SetInterceptorCreators(std::move(creators));
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    server_.reset();
    throw std::runtime_error("cannot listen on '" + options_.listen +
                             "' (address in use or invalid)");
  }
  if (!options_.http_listen.empty()) {
    HttpOptions http;
    http.listen = options_.http_listen;
    http.tls_cert_file = options_.tls_cert_file;
    http.tls_key_file = options_.tls_key_file;
    http.log_calls = options_.log_calls;
    http.oidc = options_.oidc;
    http_ =
        std::make_unique<HttpServer>(http, ServiceDeps{store_.get(), writer_.get(), auth_.get(),
                                                       judge_.get(), live_.get(), series_.get()});
    try {
      http_->Start();
    } catch (...) {
      server_->Shutdown();
      server_.reset();
      throw;
    }
  }
  judge_->Start();
  series_->Start();
  if (relay_) relay_->Start();
}

void VesServer::Shutdown(std::chrono::milliseconds grace) {
  if (shut_down_) return;
  shut_down_ = true;
  if (http_) http_->Stop();
  if (server_) {
    server_->Shutdown(std::chrono::system_clock::now() + grace);
    server_->Wait();
  }
  judge_->Stop();  // sessions it did not reach are judged on the next start
  series_->Stop();  // the rest get their series on first view
  // The ends of the streams just closed reach the other replicas (or they
  // expire there by silence).
  if (relay_) relay_->Stop(std::chrono::seconds(1));
  writer_->Stop();
}

}  // namespace ves::server
