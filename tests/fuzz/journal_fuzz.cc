// The journal of a running session (station/sync/session_journal.h), as the
// station's recovery reads it after a crash: the framed file, then each
// chunk as an input log. A journal on a damaged disk may hold anything.
#include <google/protobuf/util/message_differencer.h>

#include <string_view>

#include "station/sync/session_journal.h"
#include "station/training/input_log.h"
#include "tests/fuzz/fuzz_targets.h"

namespace ves::fuzz {

int FuzzJournal(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  sync::JournalContents contents;
  try {
    contents = sync::ParseSessionJournal(bytes, "fuzz");
  } catch (const sync::JournalError&) {
    return 0;
  }
  std::size_t chunk_bytes = 0;
  for (const std::string& chunk : contents.chunks) {
    Require(chunk.size() <= sync::kMaxJournalFrameBytes, "a chunk is within the frame limit");
    chunk_bytes += chunk.size();
  }
  Require(chunk_bytes <= bytes.size(), "the chunks are no larger than the journal");
  // What was read, written again, reads back whole and the same.
  const sync::JournalContents again = sync::ParseSessionJournal(
      sync::EncodeSessionJournal(contents.header, contents.chunks), "again");
  Require(!again.torn_tail, "a re-encoded journal has no torn tail");
  Require(again.chunks == contents.chunks, "the chunks survive a round trip");
  Require(google::protobuf::util::MessageDifferencer::Equals(again.header, contents.header),
          "the header survives a round trip");
  // Recovery decodes every chunk as an input log; only its own error may escape.
  for (const std::string& chunk : contents.chunks) {
    try {
      training::DecodeInputSamples(chunk);
    } catch (const training::InputLogError&) {
    }
  }
  return 0;
}

}  // namespace ves::fuzz
