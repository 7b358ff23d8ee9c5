#include "server/web_reply.h"

#include <google/protobuf/util/json_util.h>

#include <cctype>
#include <charconv>
#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/services.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

int HttpStatusOf(StatusCode code) {
  switch (code) {
    case StatusCode::OK:
      return 200;
    case StatusCode::INVALID_ARGUMENT:
    case StatusCode::OUT_OF_RANGE:
      return 400;
    case StatusCode::UNAUTHENTICATED:
      return 401;
    case StatusCode::PERMISSION_DENIED:
      return 403;
    case StatusCode::NOT_FOUND:
      return 404;
    case StatusCode::ALREADY_EXISTS:
    case StatusCode::FAILED_PRECONDITION:
    case StatusCode::ABORTED:
      return 409;
    case StatusCode::RESOURCE_EXHAUSTED:
      return 429;
    case StatusCode::UNIMPLEMENTED:
      return 501;
    case StatusCode::UNAVAILABLE:
      return 503;
    default:
      return 500;
  }
}

std::string Dump(const json& j) {
  return WebApi::HtmlSafeJson(j.dump(-1, ' ', false, json::error_handler_t::replace));
}

}  // namespace

HttpReply JsonReply(int status, const json& body) {
  HttpReply r;
  r.status = status;
  r.body = Dump(body);
  return r;
}

HttpReply Error(int status, const std::string& code, const std::string& message) {
  return JsonReply(status, {{"error", {{"code", code}, {"message", message}}}});
}

HttpReply ErrorOf(const Status& s) {
  return Error(HttpStatusOf(s.error_code()), StatusCodeName(s.error_code()), s.error_message());
}

// A proto message as JSON: field names as in the .proto, defaults printed.
json ProtoJson(const google::protobuf::Message& m) {
  google::protobuf::util::JsonPrintOptions o;
  o.always_print_primitive_fields = true;
  o.preserve_proto_field_names = true;
  std::string text;
  if (!google::protobuf::util::MessageToJsonString(m, &text, o).ok()) return json::object();
  return json::parse(text, nullptr, false);
}

namespace {

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

bool PercentDecode(std::string_view in, std::string* out, bool plus_is_space) {
  out->clear();
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '%') {
      if (i + 2 >= in.size()) return false;
      const int hi = HexValue(in[i + 1]);
      const int lo = HexValue(in[i + 2]);
      if (hi < 0 || lo < 0) return false;
      out->push_back(static_cast<char>(hi * 16 + lo));
      i += 2;
    } else if (in[i] == '+' && plus_is_space) {
      out->push_back(' ');
    } else {
      out->push_back(in[i]);
    }
  }
  return true;
}

std::vector<std::string> SplitText(std::string_view s, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t end = s.find(sep, start);
    parts.emplace_back(s.substr(start, end == std::string_view::npos ? s.npos : end - start));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return parts;
}

std::string CookieValue(const std::string& header, const std::string& name) {
  for (std::string part : SplitText(header, ';')) {
    const size_t b = part.find_first_not_of(' ');
    if (b == std::string::npos) continue;
    part = part.substr(b);
    if (part.compare(0, name.size() + 1, name + "=") == 0) return part.substr(name.size() + 1);
  }
  return {};
}

bool QueryNumber(const std::map<std::string, std::string>& q, const std::string& name, uint64_t max,
                 uint64_t* value, HttpReply* error) {
  auto it = q.find(name);
  if (it == q.end()) return true;
  uint64_t v = 0;
  const auto [end, ec] =
      std::from_chars(it->second.data(), it->second.data() + it->second.size(), v);
  if (it->second.empty() || ec != std::errc() || end != it->second.data() + it->second.size() ||
      v > max) {
    *error = Error(400, "INVALID_ARGUMENT",
                   "query " + name + " = '" + patient_db::PrintableExcerpt(it->second, 40) +
                       "': must be a whole number in 0.." + std::to_string(max));
    return false;
  }
  *value = v;
  return true;
}

bool QueryTimeRange(const std::map<std::string, std::string>& q, int64_t* from_unix_ms,
                    int64_t* to_unix_ms, HttpReply* error) {
  uint64_t from = 0, to = 0;
  if (!QueryNumber(q, "from_unix_ms", INT64_MAX, &from, error)) return false;
  if (!QueryNumber(q, "to_unix_ms", INT64_MAX, &to, error)) return false;
  if (to != 0 && to <= from) {
    *error = Error(400, "INVALID_ARGUMENT",
                   "query to_unix_ms = " + std::to_string(to) +
                       ": must be after from_unix_ms = " + std::to_string(from));
    return false;
  }
  *from_unix_ms = static_cast<int64_t>(from);
  *to_unix_ms = static_cast<int64_t>(to);
  return true;
}

std::string QueryText(const std::map<std::string, std::string>& q, const std::string& name) {
  auto it = q.find(name);
  return it == q.end() ? std::string() : it->second;
}

std::string FileNamePart(const std::string& id) {
  std::string out;
  for (char c : id) {
    const bool kept =
        std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_';
    out += kept ? c : '_';
  }
  return out.substr(0, 64);
}

std::string WebApi::HtmlSafeJson(std::string in) {
  std::string out;
  out.reserve(in.size());
  for (char c : in) {
    switch (c) {
      case '<':
        out += "\\u003c";
        break;
      case '>':
        out += "\\u003e";
        break;
      case '&':
        out += "\\u0026";
        break;
      default:
        out.push_back(c);
    }
  }
  return out;
}

}  // namespace ves::server
