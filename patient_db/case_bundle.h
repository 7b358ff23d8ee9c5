#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include <google/protobuf/message.h>

#include "ves/v1/case.pb.h"

// The distribution format (*.vescase), the file a hospital carries on removable
// media. Byte layout (docs/case-format.md), integers little-endian:
//   0  8  magic "VESCASE\0"
//   8  4  format version (uint32) = kCaseBundleFormatVersion
//  12  8  payload length n (uint64)
//  20  n  payload: ColonCase, deterministic binary protobuf
//  20+n 32 SHA-256 of the payload
// Nothing follows. Total size 52 + n.
namespace ves::patient_db {

inline constexpr std::string_view kCaseBundleMagic{"VESCASE\0", 8};
inline constexpr uint32_t kCaseBundleFormatVersion = 1;
inline constexpr size_t kCaseBundleHeaderSize = 20;
inline constexpr size_t kCaseBundleHashSize = 32;
inline constexpr uint64_t kMaxCaseBundlePayloadSize = 256ull << 20;  // 256 MiB

// Deterministic binary serialization (map entries in key order): the same
// message gives the same bytes, so stored bodies (cases, sessions,
// curricula) hash the same.
std::string SerializeDeterministic(const google::protobuf::Message& message);
std::string SerializeCaseDeterministic(const ves::v1::ColonCase& colon_case);

// Lowercase hex SHA-256 of `bytes`.
std::string Sha256Hex(std::string_view bytes);

// Hex SHA-256 of SerializeCaseDeterministic(case): the case's content address,
// used by the server, the station cache and SessionRecord.
std::string CasePayloadSha256Hex(const ves::v1::ColonCase& colon_case);

// Encodes without validating (WriteCaseFile validates first).
std::string EncodeCaseBundle(const ves::v1::ColonCase& colon_case);

// Checks the first bytes of a bundle of `total_bytes` as soon as they are in
// (a stream need not wait for the rest): the magic once some bytes are there,
// then format version and payload length against `total_bytes`. Throws
// CaseError naming the problem; returns when nothing is wrong so far.
void CheckCaseBundleHead(std::string_view head, uint64_t total_bytes,
                         const std::string& file_label);

// Decodes and validates; throws CaseError naming the problem (truncated, wrong
// magic, unsupported version, hash mismatch, trailing bytes, bad payload,
// invalid case).
ves::v1::ColonCase DecodeCaseBundle(std::string_view bytes, const std::string& file_label);

}  // namespace ves::patient_db
