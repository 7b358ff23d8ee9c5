#include "patient_db/case_bundle.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <openssl/evp.h>

#include <array>
#include <stdexcept>

#include "patient_db/case_problem.h"
#include "patient_db/case_validate.h"

namespace ves::patient_db {
namespace {

std::array<unsigned char, kCaseBundleHashSize> Sha256(std::string_view bytes) {
  std::array<unsigned char, kCaseBundleHashSize> digest{};
  unsigned int size = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest.data(), &size, EVP_sha256(), nullptr) != 1 ||
      size != digest.size()) {
    throw std::runtime_error("SHA-256 failed (OpenSSL EVP_Digest)");
  }
  return digest;
}

std::string Hex(const unsigned char* bytes, size_t size) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(2 * size);
  for (size_t i = 0; i < size; ++i) {
    hex += kDigits[bytes[i] >> 4];
    hex += kDigits[bytes[i] & 0xf];
  }
  return hex;
}

void PutLittleEndian(std::string& out, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((value >> (8 * i)) & 0xff);
}

uint64_t GetLittleEndian(std::string_view in, size_t offset, int bytes) {
  uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) {
    value |= static_cast<uint64_t>(static_cast<unsigned char>(in[offset + i])) << (8 * i);
  }
  return value;
}

}  // namespace

std::string SerializeDeterministic(const google::protobuf::Message& message) {
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    message.SerializeToCodedStream(&coded);
  }
  return bytes;
}

std::string SerializeCaseDeterministic(const ves::v1::ColonCase& colon_case) {
  return SerializeDeterministic(colon_case);
}

std::string Sha256Hex(std::string_view bytes) {
  const auto digest = Sha256(bytes);
  return Hex(digest.data(), digest.size());
}

std::string CasePayloadSha256Hex(const ves::v1::ColonCase& colon_case) {
  return Sha256Hex(SerializeCaseDeterministic(colon_case));
}

std::string EncodeCaseBundle(const ves::v1::ColonCase& colon_case) {
  const std::string payload = SerializeCaseDeterministic(colon_case);
  const auto digest = Sha256(payload);
  std::string bundle(kCaseBundleMagic);
  PutLittleEndian(bundle, kCaseBundleFormatVersion, 4);
  PutLittleEndian(bundle, payload.size(), 8);
  bundle += payload;
  bundle.append(reinterpret_cast<const char*>(digest.data()), digest.size());
  return bundle;
}

void CheckCaseBundleHead(std::string_view head, uint64_t total_bytes,
                         const std::string& file_label) {
  auto fail = [&](std::string field, std::string value, std::string message) {
    throw CaseError(file_label, std::move(field), -1, std::move(value), std::move(message));
  };
  const std::string_view magic = head.substr(0, kCaseBundleMagic.size());
  if (magic != kCaseBundleMagic.substr(0, magic.size()) ||
      (head.size() == total_bytes && magic.size() < kCaseBundleMagic.size())) {
    if (total_bytes < kCaseBundleMagic.size()) {
      fail("bundle", std::to_string(total_bytes) + " bytes", "truncated: shorter than the magic");
    }
    fail("bundle.magic",
         "\"" + Hex(reinterpret_cast<const unsigned char*>(magic.data()), magic.size()) +
             "\" (hex)",
         "wrong magic: not a VES case bundle (expected \"VESCASE\\0\")");
  }
  if (head.size() < kCaseBundleHeaderSize) {
    if (head.size() == total_bytes) {
      fail("bundle", std::to_string(total_bytes) + " bytes", "truncated inside the header");
    }
    return;  // the rest is checked when more has arrived
  }
  const uint64_t version = GetLittleEndian(head, 8, 4);
  if (version != kCaseBundleFormatVersion) {
    fail("bundle.format_version", std::to_string(version),
         "unsupported format version (this build reads " +
             std::to_string(kCaseBundleFormatVersion) + ")");
  }
  const uint64_t payload_size = GetLittleEndian(head, 12, 8);
  if (payload_size > kMaxCaseBundlePayloadSize) {
    fail("bundle.payload_length", std::to_string(payload_size), "larger than 256 MiB");
  }
  const uint64_t expected_size = kCaseBundleHeaderSize + payload_size + kCaseBundleHashSize;
  if (total_bytes < expected_size) {
    fail("bundle", std::to_string(total_bytes) + " bytes",
         "truncated: header announces " + std::to_string(expected_size) + " bytes");
  }
  if (total_bytes > expected_size) {
    fail("bundle", std::to_string(total_bytes) + " bytes",
         "trailing bytes: header announces " + std::to_string(expected_size) + " bytes");
  }
}

ves::v1::ColonCase DecodeCaseBundle(std::string_view bytes, const std::string& file_label) {
  auto fail = [&](std::string field, std::string value, std::string message) {
    throw CaseError(file_label, std::move(field), -1, std::move(value), std::move(message));
  };
  CheckCaseBundleHead(bytes, bytes.size(), file_label);
  const uint64_t payload_size = GetLittleEndian(bytes, 12, 8);
  const std::string_view payload = bytes.substr(kCaseBundleHeaderSize, payload_size);
  const std::string_view stored_hash =
      bytes.substr(kCaseBundleHeaderSize + payload_size, kCaseBundleHashSize);
  const auto digest = Sha256(payload);
  if (stored_hash != std::string_view(reinterpret_cast<const char*>(digest.data()), digest.size())) {
    fail("bundle.sha256",
         Hex(reinterpret_cast<const unsigned char*>(stored_hash.data()), stored_hash.size()),
         "hash mismatch: the payload hashes to " + Hex(digest.data(), digest.size()));
  }
  ves::v1::ColonCase colon_case;
  if (!colon_case.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) {
    fail("bundle.payload", std::to_string(payload.size()) + " bytes",
         "not a ves.v1.ColonCase binary protobuf");
  }
  CheckCase(colon_case, file_label);
  return colon_case;
}

}  // namespace ves::patient_db
