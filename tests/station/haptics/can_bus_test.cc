#include "station/haptics/can_bus.h"

#include <gtest/gtest.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

#include "station/haptics/protocol.h"

namespace ves::haptics {
namespace {

TEST(CanBusSocketPair, CarriesOneFramePerReadBothWays) {
  auto [host, device] = CanBus::CreateSocketPair();
  ASSERT_TRUE(host.Write(EncodeSync(1)));
  ASSERT_TRUE(host.Write(EncodeSync(2)));
  can_frame frame{};
  ASSERT_EQ(device.Read(&frame, 0), CanBus::ReadResult::kFrame);
  EXPECT_EQ(DecodeSyncFrame(frame), 1);
  ASSERT_EQ(device.Read(&frame, 0), CanBus::ReadResult::kFrame);
  EXPECT_EQ(DecodeSyncFrame(frame), 2);
  EXPECT_EQ(device.Read(&frame, 0), CanBus::ReadResult::kTimeout);
  ASSERT_TRUE(device.Write(EncodeHeartbeat({kDeviceNodeId, NmtState::kOperational})));
  ASSERT_EQ(host.Read(&frame, 10), CanBus::ReadResult::kFrame);
  EXPECT_EQ(frame.can_id, 0x710u);
}

TEST(CanBusSocketPair, ReadTimesOutWhenNothingArrives) {
  auto [host, device] = CanBus::CreateSocketPair();
  can_frame frame{};
  EXPECT_EQ(host.Read(&frame, 5), CanBus::ReadResult::kTimeout);
}

TEST(CanBusSocketPair, RecordOfTheWrongSizeIsReportedMalformed) {
  auto [host, device] = CanBus::CreateSocketPair();
  const unsigned char junk[5] = {1, 2, 3, 4, 5};
  ASSERT_EQ(send(device.fd(), junk, sizeof(junk), 0), 5);
  can_frame frame{};
  EXPECT_EQ(host.Read(&frame, 0), CanBus::ReadResult::kMalformed);
  ASSERT_TRUE(device.Write(EncodeSync(3)));  // the next frame still comes through
  ASSERT_EQ(host.Read(&frame, 0), CanBus::ReadResult::kFrame);
  EXPECT_EQ(DecodeSyncFrame(frame), 3);
}

TEST(CanBusSocketPair, ClosedPeerIsReported) {
  auto [host, device] = CanBus::CreateSocketPair();
  { CanBus gone = std::move(device); }
  can_frame frame{};
  EXPECT_EQ(host.Read(&frame, 10), CanBus::ReadResult::kClosed);
}

TEST(CanBusSocketCan, OpeningAMissingInterfaceThrowsOneLineNamingIt) {
  // On this kernel socket(PF_CAN) itself fails; with SocketCAN the interface
  // lookup fails. Either way: an exception naming the interface.
  try {
    CanBus::OpenSocketCan("vesnone0");
    FAIL() << "opened a CAN interface that does not exist";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("vesnone0"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST(CanBusSocketCan, RealInterfaceCarriesFramesWhenTheKernelHasVcan) {
  // Needs PF_CAN and a vcan0 interface (`ip link add vcan0 type vcan`).
  try {
    CanBus first = CanBus::OpenSocketCan("vcan0");
    CanBus second = CanBus::OpenSocketCan("vcan0");
    ASSERT_TRUE(first.Write(EncodeSync(5)));
    can_frame frame{};
    ASSERT_EQ(second.Read(&frame, 100), CanBus::ReadResult::kFrame);
    EXPECT_EQ(DecodeSyncFrame(frame), 5);
  } catch (const std::runtime_error& error) {
    GTEST_SKIP() << "this kernel lacks PF_CAN/vcan (no vcan0): " << error.what();
  }
}

}  // namespace
}  // namespace ves::haptics
