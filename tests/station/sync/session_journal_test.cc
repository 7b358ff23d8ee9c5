// The journal of a running session (sync/session_journal.h,
// docs/station-run.md, "Journal"): what was written reads back, a chunk the
// station was writing when it died is dropped and said, and a file that is
// not a journal is refused by name.
#include "station/sync/session_journal.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace ves::sync {
namespace {

namespace fs = std::filesystem;

class SessionJournal : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ves-journal-test-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    header_.set_uuid("6f1c8a0e-2b7d-4c55-9e0a-3d2f1b4c5a6e");
    header_.set_trainee_id("t-1");
    header_.set_start_unix_ms(1'700'000'000'000);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path Write(const std::vector<std::string>& chunks) {
    SessionJournalWriter writer(dir_ / "journal", header_);
    for (const std::string& chunk : chunks) writer.Append(chunk);
    return writer.path();
  }

  fs::path dir_;
  ves::v1::SessionRecord header_;
};

TEST_F(SessionJournal, WhatWasWrittenReadsBack) {
  const std::vector<std::string> chunks = {"first", std::string(70'000, 'x'), "", "last"};
  const fs::path path = Write(chunks);
  EXPECT_EQ(path, JournalPath(dir_ / "journal", header_.uuid()));
  const JournalContents read = ReadSessionJournal(path);
  EXPECT_EQ(read.header.SerializeAsString(), header_.SerializeAsString());
  EXPECT_EQ(read.chunks, chunks);
  EXPECT_FALSE(read.torn_tail);
  EXPECT_EQ(ListJournals(dir_ / "journal"), std::vector<fs::path>{path});
}

// EncodeSessionJournal (the fuzz target's round trip and seeds) writes what
// the writer writes, so what the fuzzer learns holds for real journals.
TEST_F(SessionJournal, TheEncoderWritesTheWritersBytes) {
  const std::vector<std::string> chunks = {"first", std::string(300, '\0'), ""};
  const fs::path path = Write(chunks);
  std::ifstream in(path, std::ios::binary);
  const std::string written((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(EncodeSessionJournal(header_, chunks), written);
  const JournalContents parsed = ParseSessionJournal(written, "here");
  EXPECT_EQ(parsed.chunks, chunks);
  EXPECT_FALSE(parsed.torn_tail);
  try {
    ParseSessionJournal(written.substr(1), "here");
    FAIL() << "a journal without its magic was parsed";
  } catch (const JournalError& e) {
    EXPECT_NE(std::string(e.what()).find("journal 'here': not a session journal"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(SessionJournal, AChunkCutShortOrDamagedIsDroppedWithTheRest) {
  const fs::path path = Write({"one", "two", "three"});
  const auto size = fs::file_size(path);
  // The station died while writing the last chunk.
  fs::resize_file(path, size - 2);
  JournalContents read = ReadSessionJournal(path);
  EXPECT_EQ(read.chunks, (std::vector<std::string>{"one", "two"}));
  EXPECT_TRUE(read.torn_tail);
  // A byte of the second chunk flipped: its CRC fails, it and what follows go.
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    // The frames end with "two" (8 + 3 bytes), then "three" (8 + 5 bytes).
    f.seekp(static_cast<std::streamoff>(size - (8 + 5) - 2));  // inside "two"
    f.put('?');
  }
  read = ReadSessionJournal(path);
  EXPECT_EQ(read.chunks, (std::vector<std::string>{"one"}));
  EXPECT_TRUE(read.torn_tail);
}

TEST_F(SessionJournal, AFileThatIsNotAJournalIsRefusedByName) {
  fs::create_directories(dir_);
  const fs::path other = dir_ / "other.journal";
  std::ofstream(other) << "not a journal";
  try {
    ReadSessionJournal(other);
    FAIL() << "read a file that is not a journal";
  } catch (const JournalError& error) {
    EXPECT_NE(std::string(error.what()).find(other.string()), std::string::npos) << error.what();
  }
  // The magic, then a header cut short.
  const fs::path path = Write({"chunk"});
  fs::resize_file(path, 20);
  EXPECT_THROW(ReadSessionJournal(path), JournalError);
  EXPECT_THROW(ReadSessionJournal(dir_ / "missing.journal"), JournalError);
  // A whole journal under another session's name.
  header_.set_uuid("1d2e3f40-5a6b-4c7d-8e9f-a0b1c2d3e4f5");
  const fs::path renamed = dir_ / "journal" / "0a1c8a0e-2b7d-4c55-9e0a-3d2f1b4c5a6e.journal";
  fs::copy_file(Write({"chunk"}), renamed);
  EXPECT_THROW(ReadSessionJournal(renamed), JournalError);
}

TEST_F(SessionJournal, AJournalIsInUseWhileItsWriterLives) {
  fs::path path;
  {
    SessionJournalWriter writer(dir_ / "journal", header_);
    path = writer.path();
    EXPECT_TRUE(JournalInUse(path));
    // Only the whole journal is listed, never its temporary name.
    EXPECT_EQ(ListJournals(dir_ / "journal"), std::vector<fs::path>{path});
  }
  EXPECT_FALSE(JournalInUse(path));
  EXPECT_FALSE(JournalInUse(dir_ / "missing.journal"));
}

TEST_F(SessionJournal, OnlyTheTemporaryFilesOfDeadWritersAreRemoved) {
  SessionJournalWriter live(dir_ / "journal", header_);
  // A writer that died before its rename left this one (unlocked).
  const fs::path stale = dir_ / "journal" / "0a1c8a0e-2b7d-4c55-9e0a-3d2f1b4c5a6e.journal.part";
  std::ofstream(stale) << "VES-JOURNAL-1\n";
  // One a live writer holds (as between its creation and its rename).
  const fs::path held = dir_ / "journal" / "1d2e3f40-5a6b-4c7d-8e9f-a0b1c2d3e4f5.journal.part";
  std::ofstream(held) << "VES-JOURNAL-1\n";
  const int fd = ::open(held.c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
  EXPECT_EQ(RemoveStaleJournalParts(dir_ / "journal"), 1);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(held));
  EXPECT_TRUE(fs::exists(live.path()));  // a whole journal is never touched here
  ::close(fd);
  EXPECT_EQ(RemoveStaleJournalParts(dir_ / "journal"), 1);
  EXPECT_FALSE(fs::exists(held));
  EXPECT_EQ(RemoveStaleJournalParts(dir_ / "nowhere"), 0);
}

TEST_F(SessionJournal, ASessionsJournalIsNeverOverwritten) {
  const fs::path path = Write({"kept"});
  EXPECT_THROW(SessionJournalWriter(dir_ / "journal", header_), std::runtime_error);
  EXPECT_EQ(ReadSessionJournal(path).chunks, std::vector<std::string>{"kept"});
  ves::v1::SessionRecord bad = header_;
  bad.set_uuid("../escape");
  EXPECT_THROW(SessionJournalWriter(dir_ / "journal", bad), std::runtime_error);
  bad.set_uuid("");
  EXPECT_THROW(SessionJournalWriter(dir_ / "journal", bad), std::runtime_error);
}

TEST_F(SessionJournal, OnlyJournalsAreListedInNameOrder) {
  EXPECT_TRUE(ListJournals(dir_ / "nowhere").empty());
  const fs::path a = Write({});
  header_.set_uuid("0a1c8a0e-2b7d-4c55-9e0a-3d2f1b4c5a6e");
  const fs::path b = Write({});
  std::ofstream(dir_ / "journal" / "notes.txt") << "x";
  fs::create_directories(dir_ / "journal" / "unreadable");
  EXPECT_EQ(ListJournals(dir_ / "journal"), (std::vector<fs::path>{b, a}));
}

}  // namespace
}  // namespace ves::sync
