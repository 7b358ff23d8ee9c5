#pragma once

#include <string_view>

// The one rule for plaintext gRPC (docs/server.md): ves-server's --listen,
// ves-admin's and ves-station's --server. It lives in patient_db because the
// server, ves-admin and the station's client all link it.
namespace ves::patient_db {

// True for a "host:port" on this machine's loopback: 127.0.0.0/8 (dotted
// quad), [::1] or localhost, optionally behind gRPC's "ipv4:" / "ipv6:" scheme.
bool IsLoopbackAddress(std::string_view address);

}  // namespace ves::patient_db
