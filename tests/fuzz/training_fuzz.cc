// The training readers: the *.session file and the input log (pure
// decoders, station/training/session_file.h and input_log.h). Each may only
// throw its own error; what it accepts survives an encode round trip.
#include <google/protobuf/util/message_differencer.h>

#include <string_view>

#include "station/training/input_log.h"
#include "station/training/session_file.h"
#include "tests/fuzz/fuzz_targets.h"

namespace ves::fuzz {

int FuzzSessionFile(const std::uint8_t* data, std::size_t size) {
  v1::SessionRecord record;
  try {
    record = training::DecodeSessionFile({reinterpret_cast<const char*>(data), size});
  } catch (const training::SessionFileError&) {
    return 0;
  }
  const v1::SessionRecord again = training::DecodeSessionFile(training::EncodeSessionFile(record));
  Require(google::protobuf::util::MessageDifferencer::Equals(record, again),
          "a session survives a file round trip");
  return 0;
}

// The encoded samples; the header's count is what the decoder must not
// trust (a 177 KB log once claimed 20 million samples).
int FuzzInputLog(const std::uint8_t* data, std::size_t size) {
  const std::string_view encoded(reinterpret_cast<const char*>(data), size);
  std::vector<training::InputSample> samples;
  try {
    samples = training::DecodeInputSamples(encoded);
  } catch (const training::InputLogError&) {
    return 0;
  }
  Require(samples.size() == training::PeekInputSampleCount(encoded),
          "a decoded log holds the samples its header claims");
  Require(training::DecodeInputSamples(training::EncodeInputSamples(samples)) == samples,
          "decoded samples survive an encode round trip");
  if (training::PeekInputLogFormatVersion(encoded) == 1) {
    // Format 1 has no toolkit columns: its samples keep the defaults, so
    // format 1 can write them again.
    Require(training::DecodeInputSamples(training::EncodeInputSamples(samples, 1)) == samples,
            "a format 1 log's samples survive a format 1 round trip");
  }
  return 0;
}

}  // namespace ves::fuzz
