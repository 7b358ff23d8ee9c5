#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>

// Client side of the server's services for ves-admin, tests and benchmarks:
// a channel (TLS or loopback plaintext) and per-call contexts that always
// carry a deadline and the bearer token.
namespace ves::server {

struct ClientOptions {
  std::string address;        // host:port
  std::string token;          // bearer token; empty: none sent
  std::string tls_ca_file;    // PEM of the server's CA; empty: plaintext (loopback only)
  std::string tls_cert_file;  // optional client certificate (PEM) ...
  std::string tls_key_file;   // ... and its key
  std::string tls_target_name;  // overrides the name checked in the server cert
  std::chrono::milliseconds deadline{std::chrono::seconds(30)};
};

// Refuses what would leak the token or cannot work, with one line naming the
// flag: plaintext to an address off loopback (the server's own rule,
// docs/server.md), an unreadable PEM file, a client key without its
// certificate or either without --tls-ca, a deadline outside (0, 1 h].
// Throws std::invalid_argument.
void CheckClientOptions(const ClientOptions& options);

// CheckClientOptions, then the channel. Throws std::invalid_argument.
std::shared_ptr<grpc::Channel> MakeClientChannel(const ClientOptions& options);

// Sets the deadline (now + options.deadline) and the authorization metadata.
void PrepareContext(grpc::ClientContext* context, const ClientOptions& options);

}  // namespace ves::server
