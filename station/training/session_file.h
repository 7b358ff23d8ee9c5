#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

#include "ves/v1/session.pb.h"

namespace ves::training {

// Refusal of a session file that is truncated, corrupted or not one.
class SessionFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A *.session file: 8-byte magic "VESSESS1", the payload length (u64 LE), the
// CRC-32 of the payload (u32 LE), then the serialized ves.v1.SessionRecord.
// Pure: reading and writing the bytes is the caller's job.
std::string EncodeSessionFile(const v1::SessionRecord& record);
// Throws SessionFileError naming what is wrong; never reads out of bounds.
v1::SessionRecord DecodeSessionFile(std::string_view bytes);

}  // namespace ves::training
