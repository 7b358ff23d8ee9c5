#include "server/live_notice.h"

#include <openssl/evp.h>

#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>

#include "patient_db/limits.h"

namespace ves::server {
namespace {

using nlohmann::json;

const char* KindName(LiveNoticeKind k) {
  switch (k) {
    case LiveNoticeKind::kBegin:
      return "begin";
    case LiveNoticeKind::kFrame:
      return "frame";
    case LiveNoticeKind::kEnd:
      return "end";
    case LiveNoticeKind::kImage:
      return "image";
  }
  return "?";
}

// Strict base64 (no whitespace, padded to a multiple of 4): EVP_DecodeBlock
// alone skips whitespace and counts padding as zero bytes.
bool DecodeBase64(const std::string& text, std::string* bytes) {
  if (text.size() % 4 != 0) return false;
  size_t pad = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const bool alnum = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    if (c == '=' && i + 2 >= text.size()) {
      ++pad;
    } else if (!alnum && c != '+' && c != '/') {
      return false;
    } else if (pad > 0) {
      return false;  // data after padding
    }
  }
  bytes->assign(text.size() / 4 * 3, '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(bytes->data()),
                                reinterpret_cast<const unsigned char*>(text.data()),
                                static_cast<int>(text.size()));
  if (n < 0 || static_cast<size_t>(n) < pad) return false;
  bytes->resize(static_cast<size_t>(n) - pad);
  return true;
}

// A label (the streaming token's) as an id-sized printable string.
std::string SafeLabel(const std::string& label) {
  if (label.empty() || patient_db::IsPrintableId(label)) return label;
  return patient_db::PrintableExcerpt(label, patient_db::kMaxIdBytes / 2);
}

// Field readers: each returns "" when fine, else what was wrong.
std::string ReadId(const json& j, const char* key, bool required, std::string* out,
                   size_t max_bytes = patient_db::kMaxIdBytes) {
  auto it = j.find(key);
  if (it == j.end()) return required ? std::string(key) + ": missing" : std::string();
  if (!it->is_string()) return std::string(key) + ": not a string";
  const std::string& s = it->get_ref<const std::string&>();
  if (s.empty() && !required) return {};
  if (s.size() > max_bytes || !patient_db::IsPrintableText(s) || s.empty()) {
    return std::string(key) + " = '" + patient_db::PrintableExcerpt(s) + "': not 1.." +
           std::to_string(max_bytes) + " bytes of printable text";
  }
  *out = s;
  return {};
}

std::string ReadUnsigned(const json& j, const char* key, uint64_t max, uint64_t* out) {
  auto it = j.find(key);
  if (it == j.end()) return std::string(key) + ": missing";
  if (!it->is_number_unsigned() || it->get<uint64_t>() > max) {
    return std::string(key) + " = " + patient_db::PrintableExcerpt(it->dump()) +
           ": not a whole number in 0.." + std::to_string(max);
  }
  *out = it->get<uint64_t>();
  return {};
}

// Image numbers count up from 1 per session; JSON keeps integers exact to 2^53.
constexpr uint64_t kMaxImageNumber = uint64_t{1} << 53;

// The rest of a kImage notice: which image, which part of how many, its
// bytes. Whether the parts make a JPEG is LiveImageAssembly's to check.
std::optional<LiveNotice> ParseImagePart(const json& j, LiveNotice n, std::string* why) {
  uint64_t image = 0, part = 0, parts = 0;
  std::string w = ReadUnsigned(j, "image", kMaxImageNumber, &image);
  if (w.empty()) w = ReadUnsigned(j, "parts", kMaxLiveImageParts, &parts);
  if (w.empty() && image == 0) w = "image = 0: images count from 1";
  if (w.empty() && parts == 0) w = "parts = 0: an image has at least one part";
  if (w.empty()) w = ReadUnsigned(j, "part", parts - 1, &part);
  if (w.empty()) {
    auto it = j.find("data");
    if (it == j.end() || !it->is_string()) {
      w = "data: missing or not a string";
    } else if (!DecodeBase64(it->get_ref<const std::string&>(), &n.part.bytes)) {
      w = "data: not base64";
    } else if (n.part.bytes.empty()) {
      w = "data: empty";
    }
  }
  if (!w.empty()) {
    *why = std::move(w);
    return std::nullopt;
  }
  n.image = image;
  n.part.part = static_cast<int>(part);
  n.part.parts = static_cast<int>(parts);
  return n;
}

}  // namespace

std::string EncodeLiveNotice(const LiveNotice& n) {
  json j = {{"v", 1},
            {"kind", KindName(n.kind)},
            {"replica", n.replica_id},
            {"session", n.info.session_uuid}};
  if (n.kind == LiveNoticeKind::kImage) {
    j["image"] = n.image;
    j["part"] = n.part.part;
    j["parts"] = n.part.parts;
    j["data"] = EncodeBase64(n.part.bytes);
  } else if (n.kind != LiveNoticeKind::kEnd) {
    j["institution"] = n.info.institution;
    j["trainee"] = n.info.trainee_id;
    j["case"] = n.info.case_id;
    j["case_version"] = n.info.case_version;
    j["station"] = SafeLabel(n.info.station);
    j["started_unix_ms"] = n.info.started_unix_ms;
    j["frames"] = n.info.frames;
  }
  if (n.kind == LiveNoticeKind::kFrame) {
    v1::LiveFrame frame = n.frame;
    frame.clear_session_uuid();  // in the envelope
    frame.clear_trainee_id();
    frame.clear_case_id();
    frame.clear_endoscope_jpeg();  // in image notices
    j["frame"] = EncodeBase64(frame.SerializeAsString());
    if (n.image != 0) j["image"] = n.image;
  }
  // ASCII only: the payload is text in whatever encoding the database has.
  std::string out = j.dump(-1, ' ', true, json::error_handler_t::replace);
  return out.size() <= kMaxLiveNoticeBytes ? out : std::string();
}

int LiveImagePartCount(size_t jpeg_bytes) {
  const size_t parts = (jpeg_bytes + kLiveImagePartBytes - 1) / kLiveImagePartBytes;
  return parts <= static_cast<size_t>(kMaxLiveImageParts) ? static_cast<int>(parts) : 0;
}

std::optional<LiveNotice> ParseLiveNotice(std::string_view payload, std::string* why) {
  const auto refuse = [&](std::string w) -> std::optional<LiveNotice> {
    *why = std::move(w);
    return std::nullopt;
  };
  if (payload.size() > kMaxLiveNoticeBytes) {
    return refuse(std::to_string(payload.size()) + " bytes, more than " +
                  std::to_string(kMaxLiveNoticeBytes));
  }
  const json j = json::parse(payload, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return refuse("not JSON");
  if (!j.is_object()) return refuse("not a JSON object");
  if (j.value("v", json()) != json(1)) return refuse("v: not 1 (an unknown notice version)");
  LiveNotice n;
  const json kind = j.value("kind", json());
  if (kind == "begin") {
    n.kind = LiveNoticeKind::kBegin;
  } else if (kind == "frame") {
    n.kind = LiveNoticeKind::kFrame;
  } else if (kind == "end") {
    n.kind = LiveNoticeKind::kEnd;
  } else if (kind == "image") {
    n.kind = LiveNoticeKind::kImage;
  } else {
    return refuse("kind = " + patient_db::PrintableExcerpt(kind.dump()) +
                  ": not begin, frame, end or image");
  }
  std::string w = ReadId(j, "replica", true, &n.replica_id, kMaxReplicaIdBytes);
  if (w.empty()) w = ReadId(j, "session", true, &n.info.session_uuid);
  if (!w.empty()) return refuse(w);
  if (n.kind == LiveNoticeKind::kEnd) return n;
  if (n.kind == LiveNoticeKind::kImage) return ParseImagePart(j, std::move(n), why);

  LiveSessionInfo& info = n.info;
  w = ReadId(j, "institution", true, &info.institution);
  if (w.empty()) w = ReadId(j, "trainee", true, &info.trainee_id);
  if (w.empty()) w = ReadId(j, "case", true, &info.case_id);
  if (w.empty()) w = ReadId(j, "station", false, &info.station);
  uint64_t version = 0, started = 0, frames = 0;
  if (w.empty())
    w = ReadUnsigned(j, "case_version", std::numeric_limits<uint32_t>::max(), &version);
  // Up to the year 9999 in ms: a clock, not an arbitrary 64-bit number.
  if (w.empty()) w = ReadUnsigned(j, "started_unix_ms", 253402300799999ull, &started);
  if (w.empty()) w = ReadUnsigned(j, "frames", uint64_t{1} << 53, &frames);
  if (!w.empty()) return refuse(w);
  info.case_version = static_cast<uint32_t>(version);
  info.started_unix_ms = static_cast<int64_t>(started);
  info.frames = frames;
  if (n.kind == LiveNoticeKind::kBegin) return n;

  auto it = j.find("frame");
  if (it == j.end() || !it->is_string()) return refuse("frame: missing or not a string");
  std::string bytes;
  if (!DecodeBase64(it->get_ref<const std::string&>(), &bytes)) {
    return refuse("frame: not base64");
  }
  if (!n.frame.ParseFromString(bytes)) return refuse("frame: not a LiveFrame (protobuf)");
  if (!n.frame.session_uuid().empty() || !n.frame.trainee_id().empty() ||
      !n.frame.case_id().empty()) {
    return refuse("frame: carries ids (they belong in the envelope)");
  }
  w = CheckLiveFrame(n.frame, /*first=*/false);
  if (!w.empty()) return refuse(w);
  info.t_s = n.frame.t_s();
  info.station_dropped = n.frame.dropped_frames();
  if (j.contains("image")) {
    w = ReadUnsigned(j, "image", kMaxImageNumber, &n.image);
    if (!w.empty()) return refuse(w);
  }
  return n;
}

}  // namespace ves::server
