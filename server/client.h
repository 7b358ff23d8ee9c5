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
  std::string tls_ca_file;    // PEM of the server's CA; empty: plaintext
  std::string tls_cert_file;  // optional client certificate (PEM) ...
  std::string tls_key_file;   // ... and its key
  std::string tls_target_name;  // overrides the name checked in the server cert
  std::chrono::milliseconds deadline{std::chrono::seconds(30)};
};

// Throws std::invalid_argument naming an unreadable PEM file.
std::shared_ptr<grpc::Channel> MakeClientChannel(const ClientOptions& options);

// Sets the deadline (now + options.deadline) and the authorization metadata.
void PrepareContext(grpc::ClientContext* context, const ClientOptions& options);

}  // namespace ves::server
