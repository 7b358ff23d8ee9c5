#include "patient_db/net_address.h"

#include <string>

namespace ves::patient_db {

bool IsLoopbackAddress(std::string_view address) {
  const size_t colon = address.rfind(':');
  if (colon == std::string_view::npos) return false;
  const std::string_view port = address.substr(colon + 1);
  if (port.empty()) return false;
  for (char c : port) {
    if (c < '0' || c > '9') return false;
  }
  std::string_view host = address.substr(0, colon);
  for (std::string_view scheme : {"ipv4:", "ipv6:"}) {
    if (host.substr(0, scheme.size()) == scheme) host.remove_prefix(scheme.size());
  }
  if (host == "localhost" || host == "[::1]") return true;
  // 127.0.0.0/8: four dotted decimal parts of 1-3 digits, the first 127.
  if (host.substr(0, 4) != "127.") return false;
  int parts = 1;
  int digits = 0;
  for (char c : host) {
    if (c == '.') {
      if (digits == 0) return false;
      ++parts;
      digits = 0;
    } else if (c >= '0' && c <= '9' && digits < 3) {
      ++digits;
    } else {
      return false;
    }
  }
  return parts == 4 && digits > 0;
}

}  // namespace ves::patient_db
