#include "station/haptics/candump_log.h"

#include <gtest/gtest.h>
#include <linux/can/error.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "station/haptics/protocol.h"

namespace ves::haptics {
namespace {

TEST(CandumpLog, FormatsTheCanUtilsLogLine) {
  can_frame frame{};
  frame.can_id = 0x123;
  frame.can_dlc = 4;
  frame.data[0] = 0xDE;
  frame.data[1] = 0xAD;
  frame.data[2] = 0xBE;
  frame.data[3] = 0xEF;
  EXPECT_EQ(FormatCandumpLine(1700000000.123456, "can0", frame),
            "(1700000000.123456) can0 123#DEADBEEF");
}

TEST(CandumpLog, FormatsEmptyExtendedRemoteAndErrorFrames) {
  can_frame empty{};
  empty.can_id = 0x80;
  EXPECT_EQ(FormatCandumpLine(1.0, "can0", empty), "(1.000000) can0 080#");
  can_frame extended{};
  extended.can_id = 0x1ABCDEF0 | CAN_EFF_FLAG;
  extended.can_dlc = 1;
  extended.data[0] = 0x01;
  EXPECT_EQ(FormatCandumpLine(2.5, "vcan1", extended), "(2.500000) vcan1 1ABCDEF0#01");
  can_frame remote{};
  remote.can_id = 0x710 | CAN_RTR_FLAG;
  EXPECT_EQ(FormatCandumpLine(3.0, "can0", remote), "(3.000000) can0 710#R");
  const can_frame bus_off = EncodeBusError({.bus_off = true});
  EXPECT_EQ(FormatCandumpLine(4.0, "can0", bus_off), "(4.000000) can0 20000040#0000000000000000");
}

TEST(CandumpLog, ParsesWhatItFormats) {
  for (const can_frame& frame :
       {EncodeSensorPdo({1.5, -0.01, 3, 1}), EncodeSync(7), EncodeBusError({.error_passive = true}),
        EncodeNmt({NmtCommandSpecifier::kStop, kDeviceNodeId})}) {
    const std::string line = FormatCandumpLine(1700000000.5, "can0", frame);
    const auto record = ParseCandumpLine(line);
    ASSERT_TRUE(record.has_value()) << line;
    EXPECT_EQ(record->interface_name, "can0");
    EXPECT_NEAR(record->timestamp_s, 1700000000.5, 1e-6);
    EXPECT_EQ(record->frame.can_id, frame.can_id) << line;
    EXPECT_EQ(record->frame.can_dlc, frame.can_dlc) << line;
    for (int i = 0; i < frame.can_dlc; ++i) EXPECT_EQ(record->frame.data[i], frame.data[i]);
  }
  EXPECT_FALSE(ParseCandumpLine("garbage").has_value());
  EXPECT_FALSE(ParseCandumpLine("(1.000000) can0 12#00").has_value());
  EXPECT_FALSE(ParseCandumpLine("(1.000000) can0 123#0").has_value());
}

TEST(CanFrameRecorder, WritesEveryRecordedFrameInOrder) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("ves_haptics_recorder_" + std::to_string(::getpid()) + ".log");
  {
    CanFrameRecorder recorder(path.string(), "can0", 1700000000.0);
    for (int i = 1; i <= 100; ++i)
      recorder.Record(i * 0.001, EncodeSync(static_cast<std::uint8_t>(i)));
    recorder.Close();
    EXPECT_EQ(recorder.written(), 100u);
    EXPECT_EQ(recorder.dropped(), 0u);
  }
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::filesystem::remove(path);
  ASSERT_EQ(lines.size(), 100u);
  EXPECT_EQ(lines.front(), "(1700000000.001000) can0 080#01");
  EXPECT_EQ(lines.back(), "(1700000000.100000) can0 080#64");
}

TEST(CanFrameRecorder, CountsFramesThatDoNotFitInsteadOfBlocking) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("ves_haptics_recorder_small_" + std::to_string(::getpid()) + ".log");
  CanFrameRecorder recorder(path.string(), "can0", 0.0, 4);
  // The writer may drain concurrently, so at most 4 + what it drained are kept.
  for (int i = 0; i < 10000; ++i) recorder.Record(0.0, EncodeSync(1));
  recorder.Close();
  EXPECT_EQ(recorder.written() + recorder.dropped(), 10000u);
  EXPECT_GT(recorder.dropped(), 0u);
  std::filesystem::remove(path);
}

// Found by fuzzing (tests/fuzz/regressions/can_frame): lines whose frame or
// time cannot be written back the same way are not candump lines.
TEST(CandumpLog, LinesThatCannotBeWrittenBackAreRefused) {
  EXPECT_FALSE(ParseCandumpLine("(1700002000000000.250000) vcan0 710#05"));  // year 53 million
  EXPECT_FALSE(ParseCandumpLine("(1700000000.25) vcan0 710#05"));            // not six digits
  EXPECT_FALSE(ParseCandumpLine("(1700000000.250000) vcan0 FFF#05"));        // 12-bit "standard" id
  EXPECT_FALSE(ParseCandumpLine("(1700000000.250000) vcan0 C0000001#05"));   // EFF/RTR bits as id
  const auto ok = ParseCandumpLine("(1700000000.250000) vcan0 7FF#05");
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->frame.can_id, 0x7FFu);
}

}  // namespace
}  // namespace ves::haptics
