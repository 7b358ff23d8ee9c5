#pragma once

#include <sys/socket.h>
#include <sys/time.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>
#include <string>

// A WebSocket viewer of /api/v1/live/ws for the live tests (synchronous,
// loopback). A read waits at most 10 s, so a frame that never comes fails the
// test instead of hanging it.
namespace ves::server::testing {

class WsViewer {
 public:
  // The handshake's HTTP status: 101 when accepted (body() says why not).
  int Connect(int port, const std::string& session_uuid, const std::string& token,
              const std::string& cookie = "") {
    namespace beast = boost::beast;
    namespace websocket = beast::websocket;
    boost::asio::ip::tcp::resolver resolver(io_);
    boost::asio::connect(ws_.next_layer(), resolver.resolve("127.0.0.1", std::to_string(port)));
    const timeval timeout{10, 0};
    ::setsockopt(ws_.next_layer().native_handle(), SOL_SOCKET, SO_RCVTIMEO, &timeout,
                 sizeof timeout);
    ws_.set_option(websocket::stream_base::decorator([=](websocket::request_type& req) {
      if (!token.empty()) req.set(beast::http::field::authorization, "Bearer " + token);
      if (!cookie.empty()) req.set(beast::http::field::cookie, cookie);
    }));
    websocket::response_type res;
    beast::error_code ec;
    ws_.handshake(res, "127.0.0.1:" + std::to_string(port),
                  "/api/v1/live/ws?session=" + session_uuid, ec);
    body_ = res.body();
    return static_cast<int>(res.result_int());
  }
  // The next message as JSON; null when the socket closed or nothing came.
  nlohmann::json Read() {
    boost::beast::flat_buffer buffer;
    boost::beast::error_code ec;
    ws_.read(buffer, ec);
    if (ec) return nlohmann::json();
    return nlohmann::json::parse(boost::beast::buffers_to_string(buffer.data()));
  }
  const std::string& body() const { return body_; }

 private:
  boost::asio::io_context io_;
  boost::beast::websocket::stream<boost::asio::ip::tcp::socket> ws_{io_};
  std::string body_;
};

}  // namespace ves::server::testing
