#include "station/training/session_file.h"

#include <zlib.h>

#include <cstdint>
#include <cstring>

namespace ves::training {
namespace {

constexpr char kMagic[8] = {'V', 'E', 'S', 'S', 'E', 'S', 'S', '1'};
constexpr std::size_t kHeaderBytes = 8 + 8 + 4;

std::uint32_t Crc32(std::string_view data) {
  return static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
}

std::uint64_t GetLe(std::string_view in, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) {
    v |= static_cast<std::uint64_t>(static_cast<std::uint8_t>(in[at + i])) << (8 * i);
  }
  return v;
}

void PutLe(std::string* out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

}  // namespace

std::string EncodeSessionFile(const v1::SessionRecord& record) {
  std::string payload;
  if (!record.SerializeToString(&payload)) {
    throw std::runtime_error("session file: cannot serialize the session record");
  }
  std::string out(kMagic, sizeof(kMagic));
  PutLe(&out, payload.size(), 8);
  PutLe(&out, Crc32(payload), 4);
  out += payload;
  return out;
}

v1::SessionRecord DecodeSessionFile(std::string_view bytes) {
  if (bytes.size() < kHeaderBytes) {
    throw SessionFileError("session file: truncated header (" + std::to_string(bytes.size()) +
                           " bytes, need " + std::to_string(kHeaderBytes) + ")");
  }
  if (std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    throw SessionFileError("session file: not a VES session file (bad magic)");
  }
  const std::uint64_t length = GetLe(bytes, 8, 8);
  const auto crc = static_cast<std::uint32_t>(GetLe(bytes, 16, 4));
  const std::string_view payload = bytes.substr(kHeaderBytes);
  if (payload.size() != length) {
    throw SessionFileError(
        "session file: " + std::string(payload.size() < length ? "truncated" : "trailing bytes") +
        " (header says " + std::to_string(length) + " bytes, file has " +
        std::to_string(payload.size()) + ")");
  }
  if (Crc32(payload) != crc) throw SessionFileError("session file: CRC-32 mismatch (corrupted)");
  v1::SessionRecord record;
  if (!record.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) {
    throw SessionFileError("session file: payload is not a ves.v1.SessionRecord");
  }
  return record;
}

}  // namespace ves::training
