#include "station/app/journal_keeper.h"

#include <exception>
#include <iostream>
#include <utility>

#include "station/training/session.h"

namespace ves::station {

JournalKeeper::JournalKeeper(std::filesystem::path dir, const training::CaseRun& run,
                             const ves::v1::ColonCase& colon_case, double time_limit_s)
    : dir_(std::move(dir)), header_(training::RecordHeader(run.config, "", 0)) {
  *header_.mutable_replay_setup() = training::MakeReplaySetup(colon_case, {}, time_limit_s);
}

void JournalKeeper::Release(const std::string& uuid) {
  if (writer_ && writer_->uuid() == uuid) {
    writer_.reset();
    pending_.clear();
  }
  std::erase_if(retired_, [&](const auto& w) { return w->uuid() == uuid; });
}

void JournalKeeper::Take(const JournalEntry& entry) {
  if (entry.starts) {
    Flush();
    // The ended session's journal stays locked until its record is
    // committed (Release): a `sync` meanwhile must not recover it too.
    if (writer_) retired_.push_back(std::move(writer_));
    pending_.clear();
    next_tick_ = 0;
    header_.set_uuid(entry.uuid.data());
    header_.set_start_unix_ms(entry.start_unix_ms);
    try {
      writer_ = std::make_unique<sync::SessionJournalWriter>(dir_, header_);
    } catch (const std::exception& error) {
      Fail(error.what());
    }
    return;
  }
  if (!writer_) return;
  if (entry.sample.tick != next_tick_) {
    Fail("inputs from " + std::to_string(next_tick_) + " on were dropped (the screen stalled)");
    return;
  }
  ++next_tick_;
  pending_.push_back(entry.sample);
  if (pending_.size() >= kChunkSamples) Flush();
}

void JournalKeeper::Flush() {
  if (!writer_ || pending_.empty()) return;
  try {
    writer_->Append(training::EncodeInputSamples(pending_));
    pending_.clear();
  } catch (const std::exception& error) {
    Fail(error.what());
  }
}

void JournalKeeper::Fail(const std::string& why) {
  std::cerr << "ves-station: session " << header_.uuid() << " is no longer journaled (" << why
            << "); its record is still stored when it ends\n";
  writer_.reset();
  pending_.clear();
}

}  // namespace ves::station
