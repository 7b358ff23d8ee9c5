#pragma once

// CanBus: `struct can_frame` in and out through one file descriptor.
// The real bus is a PF_CAN raw socket bound to an interface by name, with
// error frames enabled (CAN_RAW_ERR_FILTER); tests and the simulated device
// use one end of socketpair(AF_UNIX, SOCK_SEQPACKET), where one read is one
// 16-byte frame. Both are non-blocking; Read() waits with poll().
#include <linux/can.h>

#include <string>
#include <utility>

namespace ves::haptics {

class CanBus {
 public:
  enum class ReadResult {
    kFrame,      // *frame holds one frame
    kTimeout,    // nothing arrived within the timeout
    kMalformed,  // a record that is not one can_frame (wrong size); dropped
    kClosed,     // the peer went away
    kError,      // any other read error (errno kept in last_errno())
  };

  // Opens a raw CAN socket on `interface_name` (e.g. "can0"). Throws
  // std::runtime_error with one line naming the interface and the cause, e.g.
  // when the kernel has no PF_CAN ("Address family not supported").
  static CanBus OpenSocketCan(const std::string& interface_name);
  // A connected pair standing in for a bus with two nodes.
  static std::pair<CanBus, CanBus> CreateSocketPair();

  CanBus(int fd, std::string name);  // takes ownership of fd
  CanBus(CanBus&& other) noexcept;
  CanBus& operator=(CanBus&& other) noexcept;
  CanBus(const CanBus&) = delete;
  CanBus& operator=(const CanBus&) = delete;
  ~CanBus();

  // timeout_ms 0 = do not wait. Never blocks longer than the timeout.
  ReadResult Read(can_frame* frame, int timeout_ms);
  // False when the frame could not be queued (buffer full, bus down).
  bool Write(const can_frame& frame);

  int fd() const { return fd_; }
  const std::string& name() const { return name_; }
  int last_errno() const { return last_errno_; }

 private:
  void Close();

  int fd_{-1};
  std::string name_;
  int last_errno_{0};
};

}  // namespace ves::haptics
