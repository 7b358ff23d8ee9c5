#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>

#include "station/sync/case_cache.h"
#include "station/sync/uploader.h"
#include "ves/v1/services.grpc.pb.h"

namespace ves::sync {

// Where the station's server is and how to talk to it.
struct ServerEndpoint {
  std::string address;            // host:port
  std::string token;              // bearer token (station role)
  std::string tls_ca_file;        // PEM of the server's CA; empty: plaintext (loopback only)
  std::chrono::milliseconds deadline{std::chrono::seconds(10)};  // per call
};

// Refuses an endpoint that would send the token in plaintext off loopback
// (the server's own rule, docs/server.md) or whose CA file cannot be read:
// throws std::invalid_argument with one line naming the flag.
void CheckEndpoint(const ServerEndpoint& endpoint);

// CheckEndpoint, then a channel: TLS when a CA file is given, else plaintext.
std::shared_ptr<grpc::Channel> MakeChannel(const ServerEndpoint& endpoint);

// What an upload status means for the outbox: transient failures (server
// down, deadline, overload, auth that an admin may fix) are retried; a
// record the server calls invalid or conflicting is kept but not retried.
UploadVerdict ClassifyUploadStatus(grpc::StatusCode code);

// Sessions.UploadSession over gRPC with the endpoint's deadline and token.
class GrpcSessionUploader : public SessionUploader {
 public:
  explicit GrpcSessionUploader(ServerEndpoint endpoint);
  UploadResult Upload(const ves::v1::SessionRecord& record) override;

 private:
  ServerEndpoint endpoint_;
  std::unique_ptr<ves::v1::Sessions::Stub> stub_;
};

// Downloads the latest version of `case_id` into the cache. The bytes go to
// `<cache>/partial/<case_id>.part` first; a download cut off by the network
// resumes from there on the next call. The whole bundle is checked against
// the size and SHA-256 the server announced, then decoded (hash and
// validation) before it enters the cache. Throws std::runtime_error naming
// the case and what went wrong.
CachedCase DownloadCaseToCache(const ServerEndpoint& endpoint, const std::string& case_id,
                               CaseCache& cache);

}  // namespace ves::sync
