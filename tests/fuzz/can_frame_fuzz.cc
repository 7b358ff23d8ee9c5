// The CAN side (station/haptics/protocol.h, candump_log.h): every 16 bytes
// are one struct can_frame as a read() delivers it, fed to the classifier
// and every decoder; a decoded message encodes to a frame that decodes to the
// same message. Bytes after a '\n' are also read as candump log lines.
#include <cstring>
#include <string>
#include <string_view>

#include "station/haptics/candump_log.h"
#include "station/haptics/protocol.h"
#include "tests/fuzz/fuzz_targets.h"

namespace ves::fuzz {
namespace {

using namespace ves::haptics;  // NOLINT: the protocol's many names

template <typename Message, typename Decode, typename Encode>
void RoundTrip(const can_frame& frame, Decode decode, Encode encode, const char* what) {
  const std::optional<Message> decoded = decode(frame);
  if (!decoded) return;
  const std::optional<Message> again = decode(encode(*decoded));
  Require(again.has_value() && *again == *decoded, what);
}

bool SameFrame(const can_frame& a, const can_frame& b) {
  return a.can_id == b.can_id && a.can_dlc == b.can_dlc &&
         std::memcmp(a.data, b.data, std::min<std::size_t>(a.can_dlc, CAN_MAX_DLEN)) == 0;
}

}  // namespace

int FuzzCanFrame(const std::uint8_t* data, std::size_t size) {
  for (std::size_t at = 0; at + sizeof(can_frame) <= size; at += sizeof(can_frame)) {
    can_frame frame;
    std::memcpy(&frame, data + at, sizeof frame);
    (void)ClassifyFrame(frame);
    RoundTrip<NmtCommand>(frame, DecodeNmtFrame, EncodeNmt, "NMT round trip");
    RoundTrip<Emcy>(frame, DecodeEmcyFrame, EncodeEmcy, "EMCY round trip");
    RoundTrip<MotorVoltages>(frame, DecodeMotorFrame, EncodeMotorPdo, "motor PDO round trip");
    RoundTrip<EncoderCounts>(frame, DecodeEncoderFrame, EncodeEncoderPdo,
                             "encoder PDO round trip");
    RoundTrip<SensorSample>(frame, DecodeSensorFrame, EncodeSensorPdo, "sensor PDO round trip");
    RoundTrip<Heartbeat>(frame, DecodeHeartbeatFrame, EncodeHeartbeat, "heartbeat round trip");
    RoundTrip<BusError>(frame, DecodeErrorFrame, EncodeBusError, "error frame round trip");
    if (const auto counter = DecodeSyncFrame(frame)) {
      Require(DecodeSyncFrame(EncodeSync(*counter)) == counter, "SYNC round trip");
    }
  }
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::size_t newline = text.find('\n');
  if (newline == std::string_view::npos) return 0;
  std::size_t start = newline + 1;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string line(text.substr(start, end - start));
    if (const auto record = ParseCandumpLine(line)) {
      const auto again = ParseCandumpLine(
          FormatCandumpLine(record->timestamp_s, record->interface_name, record->frame));
      Require(again.has_value() && again->interface_name == record->interface_name &&
                  SameFrame(again->frame, record->frame),
              "a candump line survives a format round trip");
    }
    start = end + 1;
  }
  return 0;
}

}  // namespace ves::fuzz
