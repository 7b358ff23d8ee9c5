#include "station/haptics/can_bus.h"

#include <fcntl.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace ves::haptics {
namespace {

[[noreturn]] void ThrowSystem(const std::string& what, int error) {
  throw std::runtime_error(what + ": " + std::strerror(error));
}

void SetNonBlocking(int fd) {
  const int flags = fcntl(fd, F_GETFL, 0);
  if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0) {
    ThrowSystem("fcntl(O_NONBLOCK)", errno);
  }
}

}  // namespace

CanBus CanBus::OpenSocketCan(const std::string& interface_name) {
  const std::string context = "CAN interface '" + interface_name + "'";
  if (interface_name.empty() || interface_name.size() >= IFNAMSIZ) {
    throw std::runtime_error(context + ": interface name must be 1.." +
                             std::to_string(IFNAMSIZ - 1) + " characters");
  }
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int error = errno;
    std::string hint = error == EAFNOSUPPORT ? " (this kernel has no SocketCAN/PF_CAN)" : "";
    throw std::runtime_error(context + ": socket(PF_CAN): " + std::strerror(error) + hint);
  }
  CanBus bus(fd, interface_name);
  ifreq request{};
  std::strncpy(request.ifr_name, interface_name.c_str(), IFNAMSIZ - 1);
  if (ioctl(fd, SIOCGIFINDEX, &request) < 0) ThrowSystem(context + ": SIOCGIFINDEX", errno);
  // Every error class: bus-off and error-passive take the loop to its safe state.
  const can_err_mask_t error_mask = CAN_ERR_MASK;
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &error_mask, sizeof(error_mask)) < 0) {
    ThrowSystem(context + ": CAN_RAW_ERR_FILTER", errno);
  }
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = request.ifr_ifindex;
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) < 0) {
    ThrowSystem(context + ": bind", errno);
  }
  SetNonBlocking(fd);
  return bus;
}

std::pair<CanBus, CanBus> CanBus::CreateSocketPair() {
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) < 0) {
    ThrowSystem("socketpair(AF_UNIX, SOCK_SEQPACKET)", errno);
  }
  CanBus host(fds[0], "sim0");
  CanBus device(fds[1], "sim0");
  // Room for a few hundred frames either way, so a stalled reader loses
  // frames only after a long stall (counted as lost by the driver).
  const int buffer_bytes = 1 << 20;
  for (int fd : fds) {
    setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &buffer_bytes, sizeof(buffer_bytes));
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &buffer_bytes, sizeof(buffer_bytes));
    SetNonBlocking(fd);
  }
  return {std::move(host), std::move(device)};
}

CanBus::CanBus(int fd, std::string name) : fd_(fd), name_(std::move(name)) {}

CanBus::CanBus(CanBus&& other) noexcept
    : fd_(other.fd_), name_(std::move(other.name_)), last_errno_(other.last_errno_) {
  other.fd_ = -1;
}

CanBus& CanBus::operator=(CanBus&& other) noexcept {
  if (this != &other) {
    Close();
    fd_ = other.fd_;
    name_ = std::move(other.name_);
    last_errno_ = other.last_errno_;
    other.fd_ = -1;
  }
  return *this;
}

CanBus::~CanBus() { Close(); }

void CanBus::Close() {
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
}

CanBus::ReadResult CanBus::Read(can_frame* frame, int timeout_ms) {
  // Larger than a frame so a record of the wrong size is seen, not truncated.
  alignas(can_frame) unsigned char buffer[sizeof(can_frame) * 4];
  for (;;) {
    const ssize_t n = recv(fd_, buffer, sizeof(buffer), MSG_DONTWAIT);
    if (n == static_cast<ssize_t>(sizeof(can_frame))) {
      std::memcpy(frame, buffer, sizeof(can_frame));
      return ReadResult::kFrame;
    }
    if (n == 0) return ReadResult::kClosed;
    if (n > 0) return ReadResult::kMalformed;
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) {
      last_errno_ = errno;
      return ReadResult::kError;
    }
    if (timeout_ms <= 0) return ReadResult::kTimeout;
    pollfd waiter{fd_, POLLIN, 0};
    const int ready = poll(&waiter, 1, timeout_ms);
    if (ready == 0) return ReadResult::kTimeout;
    if (ready < 0 && errno != EINTR) {
      last_errno_ = errno;
      return ReadResult::kError;
    }
    if (waiter.revents & (POLLHUP | POLLERR) && !(waiter.revents & POLLIN)) {
      return ReadResult::kClosed;
    }
    timeout_ms = 0;  // one wait, then one more non-blocking read
  }
}

bool CanBus::Write(const can_frame& frame) {
  for (;;) {
    const ssize_t n = send(fd_, &frame, sizeof(frame), MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n == static_cast<ssize_t>(sizeof(frame))) return true;
    if (n < 0 && errno == EINTR) continue;
    last_errno_ = n < 0 ? errno : EIO;
    return false;
  }
}

}  // namespace ves::haptics
