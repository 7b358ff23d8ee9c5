#include "station/training/session_file.h"

#include <gtest/gtest.h>

#include <random>

namespace ves::training {
namespace {

v1::SessionRecord Record() {
  v1::SessionRecord r;
  r.set_uuid("01234567-89ab-4def-bedc-ba9876543210");
  r.set_case_id("standard-adult");
  r.set_score(72.5);
  r.mutable_metrics()->set_pain_s(3.25);
  r.mutable_input_log()->set_encoded(std::string(300, 'x'));
  return r;
}

TEST(SessionFile, RoundTrips) {
  const std::string bytes = EncodeSessionFile(Record());
  const v1::SessionRecord back = DecodeSessionFile(bytes);
  EXPECT_EQ(back.SerializeAsString(), Record().SerializeAsString());
}

TEST(SessionFile, EveryTruncationIsRefused) {
  const std::string bytes = EncodeSessionFile(Record());
  for (std::size_t length = 0; length < bytes.size(); ++length) {
    EXPECT_THROW(DecodeSessionFile(std::string_view(bytes).substr(0, length)), SessionFileError)
        << "length " << length;
  }
}

TEST(SessionFile, ByteFlipsAreRefused) {
  const std::string bytes = EncodeSessionFile(Record());
  std::mt19937 rng(11);
  std::uniform_int_distribution<std::size_t> where(0, bytes.size() - 1);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string corrupted = bytes;
    corrupted[where(rng)] ^= static_cast<char>(1 + trial % 255);
    EXPECT_THROW(DecodeSessionFile(corrupted), SessionFileError) << "trial " << trial;
  }
}

TEST(SessionFile, TrailingBytesAreRefused) {
  EXPECT_THROW(DecodeSessionFile(EncodeSessionFile(Record()) + "x"), SessionFileError);
}

}  // namespace
}  // namespace ves::training
