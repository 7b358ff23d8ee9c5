#include "server/http_server.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <chrono>
#include <map>
#include <stdexcept>

#include "patient_db/net_address.h"
#include "server/live_hub.h"

namespace ves::server {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

struct HttpServer::Impl {
  asio::io_context io;
  std::unique_ptr<asio::ssl::context> ssl;
  tcp::acceptor acceptor{io};
  std::thread accept_thread;
  std::thread reaper_thread;
  std::mutex mutex;
  std::condition_variable cv;
  // Open connections: native handle -> the time after which it is shut down
  // (idle or too slow); guarded by mutex.
  std::map<int, std::chrono::steady_clock::time_point> deadlines;
  int active = 0;
  bool stopping = false;
};

namespace {

using Clock = std::chrono::steady_clock;

void SetDeadline(HttpServer::Impl* impl, int fd, std::chrono::seconds from_now) {
  std::lock_guard lock(impl->mutex);
  impl->deadlines[fd] = from_now.count() > 0 ? Clock::now() + from_now : Clock::time_point::max();
  // A connection that registers after Stop has shut the others down would
  // wait for a request that never comes, and Stop would wait for it.
  if (impl->stopping) ::shutdown(fd, SHUT_RDWR);
}

std::pair<std::string, std::string> SplitHostPort(const std::string& listen) {
  const size_t colon = listen.rfind(':');
  if (colon == std::string::npos) {
    throw std::invalid_argument("--http '" + listen + "': must be HOST:PORT");
  }
  std::string host = listen.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  if (host == "localhost") host = "127.0.0.1";
  return {host, listen.substr(colon + 1)};
}

// Forgets a connection's deadline when it goes out of scope.
struct ForgetDeadline {
  HttpServer::Impl* impl;
  int fd;
  ~ForgetDeadline() {
    std::lock_guard lock(impl->mutex);
    impl->deadlines.erase(fd);
  }
};

HttpRequest ToRequest(const http::request<http::string_body>& r, const std::string& peer) {
  HttpRequest out;
  out.peer = peer;
  out.method = std::string(r.method_string());
  out.target = std::string(r.target());
  out.authorization = std::string(r[http::field::authorization]);
  out.cookie = std::string(r[http::field::cookie]);
  out.csrf_token = std::string(r["X-CSRF-Token"]);
  out.content_type = std::string(r[http::field::content_type]);
  out.body = r.body();
  out.origin = std::string(r[http::field::origin]);
  out.host = std::string(r[http::field::host]);
  out.websocket = beast::websocket::is_upgrade(r);
  return out;
}

http::response<http::string_body> ToResponse(const HttpReply& reply, unsigned version,
                                             bool keep_alive, bool head, bool tls) {
  http::response<http::string_body> res{static_cast<http::status>(reply.status), version};
  res.set(http::field::server, "ves-server");
  res.set(http::field::content_type, reply.content_type);
  // Pages use only their own scripts and styles; nothing may frame them.
  res.set("Content-Security-Policy",
          "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
          "connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'self'");
  res.set("X-Content-Type-Options", "nosniff");
  res.set("Referrer-Policy", "no-referrer");
  res.set("X-Frame-Options", "DENY");
  if (tls) res.set("Strict-Transport-Security", "max-age=31536000");
  for (const auto& [name, value] : reply.headers) res.insert(name, value);
  res.keep_alive(keep_alive);
  if (head) {
    res.content_length(reply.body.size());
  } else {
    res.body() = reply.body;
    res.prepare_payload();
  }
  return res;
}

HttpReply LimitReply(int status, const std::string& message) {
  HttpReply r;
  r.status = status;
  r.body = WebApi::HtmlSafeJson("{\"error\":{\"code\":\"INVALID_ARGUMENT\",\"message\":\"" +
                                message + "\"}}");
  return r;
}

bool Stopping(HttpServer::Impl* impl) {
  std::lock_guard lock(impl->mutex);
  return impl->stopping;
}

// A live viewer's WebSocket (docs/web.md): the newest frame of its one-slot
// buffer whenever there is one. Only this connection's thread waits on a slow
// browser (its write, bounded by io_timeout_s); the station and the other
// viewers never do. Messages from the browser are not read: it only listens.
template <class Stream>
void ServeLiveViewer(Stream& stream, const http::request<http::string_body>& req, int fd,
                     HttpServer::Impl* impl, WebApi* api, const HttpOptions& options,
                     const std::string& uuid, const std::shared_ptr<LiveViewer>& viewer) {
  namespace websocket = beast::websocket;
  const auto timeout = std::chrono::seconds(options.io_timeout_s);
  websocket::stream<Stream&> ws(stream);
  ws.set_option(websocket::stream_base::decorator(
      [](websocket::response_type& res) { res.set(http::field::server, "ves-server"); }));
  ws.read_message_max(4096);
  // A frame with a JPEG (20-30 KB of JSON) goes out in more than one write;
  // with Nagle the last waits for the viewer's delayed ACK (~40 ms measured).
  const int no_delay = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &no_delay, sizeof no_delay);
  beast::error_code ec;
  SetDeadline(impl, fd, timeout);
  ws.accept(req, ec);
  while (!ec && !Stopping(impl)) {
    SetDeadline(impl, fd, std::chrono::seconds(0));  // waiting for a frame is not idling
    bool ended = false;
    const std::string frame = viewer->Next(250, &ended);
    SetDeadline(impl, fd, timeout);
    if (ended) {
      ws.text(true);
      ws.write(asio::buffer(std::string("{\"ended\":true}")), ec);
      if (!ec)
        ws.close(websocket::close_reason(websocket::close_code::normal, "session ended"), ec);
      break;
    }
    if (frame.empty()) continue;
    ws.text(true);
    ws.write(asio::buffer(frame), ec);
  }
  api->LiveUnwatch(uuid, viewer);
}

template <class Stream>
void ServeStream(Stream& stream, int fd, HttpServer::Impl* impl, WebApi* api,
                 const HttpOptions& options, bool tls, const std::string& peer) {
  beast::flat_buffer buffer;
  const auto timeout = std::chrono::seconds(options.io_timeout_s);
  while (true) {
    SetDeadline(impl, fd, timeout);
    http::request_parser<http::string_body> parser;
    parser.header_limit(kMaxHttpHeaderBytes);
    parser.body_limit(kMaxHttpBodyBytes);
    beast::error_code ec;
    http::read(stream, buffer, parser, ec);
    if (ec == http::error::end_of_stream || ec == asio::error::eof) return;
    if (ec == http::error::header_limit || ec == http::error::body_limit ||
        ec == http::error::buffer_overflow) {
      const bool header = ec != http::error::body_limit;
      const HttpReply reply =
          LimitReply(header ? 431 : 413, header ? "request header: over the limit of " +
                                                      std::to_string(kMaxHttpHeaderBytes) + " bytes"
                                                : "body: over the limit of " +
                                                      std::to_string(kMaxHttpBodyBytes) + " bytes");
      auto res = ToResponse(reply, 11, false, false, tls);
      http::write(stream, res, ec);
      return;
    }
    if (ec) {
      if (ec != asio::error::operation_aborted && ec != asio::error::connection_reset &&
          ec != asio::error::bad_descriptor && ec != asio::error::shut_down) {
        const HttpReply reply = LimitReply(400, "not an HTTP/1.1 request");
        auto res = ToResponse(reply, 11, false, false, tls);
        beast::error_code ignored;
        http::write(stream, res, ignored);
      }
      return;
    }
    const auto& req = parser.get();
    if (beast::websocket::is_upgrade(req)) {
      std::string uuid;
      std::shared_ptr<LiveViewer> viewer;
      const HttpReply refusal = api->LiveWatch(ToRequest(req, peer), &uuid, &viewer);
      if (options.log_calls)
        spdlog::info("http websocket {} {} peer={}",
                     patient_db::PrintableExcerpt(
                         std::string(req.target().substr(0, req.target().find('?'))), 120),
                     refusal.status, peer);
      if (refusal.status == 101) {
        ServeLiveViewer(stream, req, fd, impl, api, options, uuid, viewer);
      } else {
        auto res = ToResponse(refusal, req.version(), false, false, tls);
        http::write(stream, res, ec);
      }
      return;
    }
    SetDeadline(impl, fd, std::chrono::seconds(0));  // a replay may take a while
    const auto start = Clock::now();
    const HttpReply reply = api->Handle(ToRequest(req, peer));
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    if (options.log_calls)
      spdlog::info("http {} {} {} {:.2f} ms peer={}", std::string(req.method_string()),
                   patient_db::PrintableExcerpt(
                       std::string(req.target().substr(0, req.target().find('?'))), 120),
                   reply.status, ms, peer);
    auto res =
        ToResponse(reply, req.version(), req.keep_alive(), req.method() == http::verb::head, tls);
    SetDeadline(impl, fd, timeout);
    http::write(stream, res, ec);
    if (ec || !res.keep_alive()) return;
  }
}

}  // namespace

HttpServer::HttpServer(HttpOptions options, ServiceDeps deps)
    : options_(std::move(options)), impl_(std::make_unique<Impl>()) {
  WebOptions web;
  web.secure_cookies = !options_.tls_cert_file.empty();
  web.oidc = options_.oidc;
  api_ = std::make_unique<WebApi>(deps, web);
}

HttpServer::~HttpServer() { Stop(); }

namespace {

// The TLS context of the server's certificate and key; throws
// std::invalid_argument when they cannot be used.
std::unique_ptr<asio::ssl::context> TlsContext(const HttpOptions& options) {
  if (options.tls_cert_file.empty() || options.tls_key_file.empty()) {
    throw std::invalid_argument("HTTPS needs both --tls-cert and --tls-key");
  }
  auto ssl = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_server);
  ssl->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                   asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                   asio::ssl::context::no_tlsv1_1);
  beast::error_code ec;
  ssl->use_certificate_chain_file(options.tls_cert_file, ec);
  if (!ec) ssl->use_private_key_file(options.tls_key_file, asio::ssl::context::pem, ec);
  if (ec) {
    throw std::invalid_argument("--http with --tls-cert " + options.tls_cert_file + " --tls-key " +
                                options.tls_key_file + ": " + ec.message());
  }
  return ssl;
}

// The address of --http; throws std::invalid_argument when it is not one.
tcp::endpoint ListenEndpoint(const std::string& listen) {
  const auto [host, port_text] = SplitHostPort(listen);
  beast::error_code ec;
  const auto address = asio::ip::make_address(host, ec);
  int port = -1;
  try {
    port = std::stoi(port_text);
  } catch (const std::exception&) {
  }
  if (ec || port < 0 || port > 65535) {
    throw std::invalid_argument("--http '" + listen + "': not a HOST:PORT address");
  }
  return tcp::endpoint(address, static_cast<unsigned short>(port));
}

// Shuts down every connection past its deadline (or all, once stopping), so
// that its blocking read or write returns.
void ReapConnections(HttpServer::Impl* impl) {
  std::unique_lock lock(impl->mutex);
  while (!impl->stopping) {
    impl->cv.wait_for(lock, std::chrono::milliseconds(500));
    const auto now = Clock::now();
    for (auto& [fd, deadline] : impl->deadlines) {
      if (impl->stopping || deadline <= now) {
        ::shutdown(fd, SHUT_RDWR);
        deadline = Clock::time_point::max();
      }
    }
  }
}

// One connection's thread: owns the socket of `fd`, speaks TLS when the
// server has it, serves requests until the connection ends.
void ServeConnection(HttpServer::Impl* impl, WebApi* api, const HttpOptions& options, int fd,
                     tcp protocol) {
  {
    tcp::socket s(impl->io);
    beast::error_code assign_ec;
    s.assign(protocol, fd, assign_ec);
    // Destroyed before the socket: the reaper never shuts down a descriptor
    // number that has been closed (and maybe reused).
    ForgetDeadline forget_plain{impl, fd};
    beast::error_code peer_ec;
    const auto remote = s.remote_endpoint(peer_ec);
    const std::string peer = peer_ec ? std::string("?")
                                     : remote.address().to_string() + ":" +
                                           std::to_string(remote.port());
    SetDeadline(impl, fd, std::chrono::seconds(options.io_timeout_s));
    try {
      if (assign_ec) {
        spdlog::warn("http connection: {}", assign_ec.message());
      } else if (impl->ssl) {
        beast::ssl_stream<tcp::socket> stream(std::move(s), *impl->ssl);
        ForgetDeadline forget_tls{impl, fd};
        beast::error_code ec;
        stream.handshake(asio::ssl::stream_base::server, ec);
        if (!ec) {
          ServeStream(stream, fd, impl, api, options, true, peer);
          stream.shutdown(ec);
        }
      } else {
        ServeStream(s, fd, impl, api, options, false, peer);
        beast::error_code ec;
        s.shutdown(tcp::socket::shutdown_both, ec);
      }
    } catch (const std::exception& e) {
      spdlog::warn("http connection from {}: {}", peer, e.what());
    }
  }
  std::lock_guard lock(impl->mutex);
  --impl->active;
  impl->cv.notify_all();
}

// Accepts connections until Stop, each on a thread of its own, at most
// max_connections at once (more are closed, not queued).
void AcceptConnections(HttpServer::Impl* impl, WebApi* api, const HttpOptions& options,
                       tcp protocol) {
  while (true) {
    tcp::socket socket(impl->io);
    beast::error_code accept_ec;
    impl->acceptor.accept(socket, accept_ec);
    {
      std::unique_lock lock(impl->mutex);
      if (impl->stopping) return;
      if (accept_ec) continue;
      if (impl->active >= options.max_connections) {
        lock.unlock();
        socket.close(accept_ec);
        continue;
      }
      ++impl->active;
    }
    // The thread gets the bare descriptor and owns its socket as a local,
    // so every socket is closed before `active` drops and Stop may return.
    beast::error_code release_ec;
    const int fd = socket.release(release_ec);
    if (release_ec) {
      std::lock_guard lock(impl->mutex);
      --impl->active;
      continue;
    }
    std::thread(ServeConnection, impl, api, std::cref(options), fd, protocol).detach();
  }
}

}  // namespace

void HttpServer::Start() {
  const bool tls = !options_.tls_cert_file.empty() || !options_.tls_key_file.empty();
  if (!tls && !patient_db::IsLoopbackAddress(options_.listen)) {
    throw std::invalid_argument("refusing plain HTTP on '" + options_.listen +
                                "': without --tls-cert/--tls-key, --http needs a loopback "
                                "address such as 127.0.0.1:8080");
  }
  if (std::string why = CheckOidcConfig(options_.oidc); !why.empty()) {
    throw std::invalid_argument(why);
  }
  if (tls) impl_->ssl = TlsContext(options_);
  const tcp::endpoint endpoint = ListenEndpoint(options_.listen);
  auto& acceptor = impl_->acceptor;
  beast::error_code ec;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("cannot listen for HTTP on '" + options_.listen +
                             "': " + ec.message());
  }
  port_ = acceptor.local_endpoint().port();
  impl_->reaper_thread = std::thread(ReapConnections, impl_.get());
  impl_->accept_thread = std::thread(AcceptConnections, impl_.get(), api_.get(),
                                     std::cref(options_), endpoint.protocol());
}

void HttpServer::Stop() {
  if (!impl_->accept_thread.joinable()) return;
  {
    std::lock_guard lock(impl_->mutex);
    impl_->stopping = true;
    for (auto& [fd, deadline] : impl_->deadlines) ::shutdown(fd, SHUT_RDWR);
  }
  ::shutdown(impl_->acceptor.native_handle(), SHUT_RDWR);  // wakes the blocking accept
  impl_->accept_thread.join();
  impl_->cv.notify_all();
  impl_->reaper_thread.join();
  std::unique_lock lock(impl_->mutex);
  // A connection busy in a handler finishes it, then finds its socket shut.
  impl_->cv.wait(lock, [&] {
    for (auto& [fd, deadline] : impl_->deadlines) ::shutdown(fd, SHUT_RDWR);
    return impl_->active == 0;
  });
  lock.unlock();
  beast::error_code ec;
  impl_->acceptor.close(ec);
}

}  // namespace ves::server
