#include "tests/server/web_client.h"

#include <algorithm>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>

namespace ves::server::testing {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

namespace {

template <class Stream>
HttpResult Exchange(Stream& stream, const std::string& method, const std::string& target,
                    const Headers& headers, const std::string& body) {
  http::request<http::string_body> req{http::string_to_verb(method), target, 11};
  req.set(http::field::host, "127.0.0.1");
  for (const auto& [k, v] : headers) req.set(k, v);
  req.body() = body;
  req.prepare_payload();
  http::write(stream, req);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(256u << 20);
  http::read(stream, buffer, parser);
  const auto& res = parser.get();
  HttpResult out;
  out.status = res.result_int();
  out.body = res.body();
  for (const auto& field : res) {
    std::string name(field.name_string());
    std::transform(name.begin(), name.end(), name.begin(), ::tolower);
    out.headers.emplace(name, std::string(field.value()));
  }
  return out;
}

}  // namespace

HttpResult HttpCall(int port, const std::string& method, const std::string& target,
                    const Headers& headers, const std::string& body, bool tls) {
  asio::io_context io;
  tcp::endpoint endpoint(asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port));
  if (!tls) {
    tcp::socket socket(io);
    socket.connect(endpoint);
    return Exchange(socket, method, target, headers, body);
  }
  asio::ssl::context ctx(asio::ssl::context::tls_client);
  ctx.set_verify_mode(asio::ssl::verify_none);
  beast::ssl_stream<tcp::socket> stream(io, ctx);
  stream.next_layer().connect(endpoint);
  stream.handshake(asio::ssl::stream_base::client);
  return Exchange(stream, method, target, headers, body);
}

HttpResult HttpRaw(int port, const std::string& bytes) {
  asio::io_context io;
  tcp::socket socket(io);
  socket.connect(
      tcp::endpoint(asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)));
  beast::error_code ec;
  asio::write(socket, asio::buffer(bytes), ec);  // the server may stop reading early
  beast::flat_buffer buffer;
  http::response<http::string_body> res;
  http::read(socket, buffer, res, ec);
  HttpResult out;
  if (ec) return out;  // status 0: no reply
  out.status = res.result_int();
  out.body = res.body();
  return out;
}

}  // namespace ves::server::testing
