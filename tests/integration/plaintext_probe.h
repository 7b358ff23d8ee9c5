#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <optional>
#include <string>

// A TCP listener on a non-loopback IPv4 address of this machine, for the
// tests that a client refuses to send its token there in plaintext: it never
// answers, and Connections() counts who connected (it accepts without blocking).
namespace ves::testing {

class NonLoopbackListener {
 public:
  NonLoopbackListener() {
    std::optional<in_addr> found;
    ifaddrs* list = nullptr;
    if (::getifaddrs(&list) != 0) return;
    for (ifaddrs* a = list; a != nullptr; a = a->ifa_next) {
      if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
      const in_addr ip = reinterpret_cast<sockaddr_in*>(a->ifa_addr)->sin_addr;
      if ((ntohl(ip.s_addr) >> 24) == 127) continue;
      found = ip;
      break;
    }
    ::freeifaddrs(list);
    if (!found) return;
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    sockaddr_in bind_to{};
    bind_to.sin_family = AF_INET;
    bind_to.sin_addr = *found;
    socklen_t size = sizeof bind_to;
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&bind_to), size) != 0 ||
        ::listen(fd_, 16) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&bind_to), &size) != 0) {
      Close();
      return;
    }
    char text[INET_ADDRSTRLEN] = {};
    ::inet_ntop(AF_INET, &bind_to.sin_addr, text, sizeof text);
    address_ = std::string(text) + ":" + std::to_string(ntohs(bind_to.sin_port));
  }
  ~NonLoopbackListener() { Close(); }
  NonLoopbackListener(const NonLoopbackListener&) = delete;
  NonLoopbackListener& operator=(const NonLoopbackListener&) = delete;

  // "ip:port", or empty when this machine has no non-loopback IPv4 address.
  const std::string& address() const { return address_; }
  // Connections made so far (each accepted and closed).
  int Connections() {
    while (fd_ >= 0) {
      const int c = ::accept(fd_, nullptr, nullptr);
      if (c < 0) break;
      ::close(c);
      ++connections_;
    }
    return connections_;
  }

 private:
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int fd_ = -1;
  int connections_ = 0;
  std::string address_;
};

}  // namespace ves::testing
