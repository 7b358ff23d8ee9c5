#pragma once

#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "server/client.h"
#include "server/server.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/services.grpc.pb.h"

// An in-process ves-server on 127.0.0.1:<free port> over a fresh SQLite file,
// with helpers to mint tokens and build records, for tests over real gRPC.
namespace ves::server::testing {

// A new empty directory under the system temp dir, removed by the caller.
std::filesystem::path MakeTempDir(const std::string& tag);

class TestServer {
 public:
  // Plaintext on loopback unless `options` asks for TLS; listen is forced to
  // 127.0.0.1:0. The per-call log is off unless `log_calls` (tests that read
  // the log).
  explicit TestServer(ServerOptions options = {}, bool log_calls = false);
  ~TestServer();

  std::string address() const { return "127.0.0.1:" + std::to_string(server_->port()); }
  VesServer& server() { return *server_; }
  patient_db::Store& store() { return server_->store(); }
  const std::filesystem::path& dir() const { return dir_; }

  // A token straight into the store (institution created when new).
  std::string MakeToken(patient_db::StoreRole role, const std::string& institution,
                        const std::string& trainee_id = "");
  void AddTrainee(const std::string& trainee_id, const std::string& institution);
  // Plaintext client options with `token` and a 10 s deadline.
  ClientOptions Client(const std::string& token) const;

 private:
  std::filesystem::path dir_;
  std::unique_ptr<VesServer> server_;
};

// A random lower-case RFC 4122 version-4 UUID.
std::string NewUuid(std::mt19937_64& rng);

// A plausible record for `trainee_id`; `seed` varies its content.
ves::v1::SessionRecord MakeRecord(const std::string& uuid, const std::string& trainee_id,
                                  int seed);

// The repository's sample case standard-adult (valid), loaded from its textproto.
ves::v1::ColonCase SampleCase();
// Stores SampleCase() (version 1) owned by `owner` and shared with `share_with`:
// records from MakeRecord name it, and the server refuses sessions of a case
// the trainee's institution cannot see.
void PutSampleCase(patient_db::Store& store, const std::string& owner,
                   const std::vector<std::string>& share_with = {});
// The same for any case.
void PutTestCase(patient_db::Store& store, const ves::v1::ColonCase& colon_case,
                 const std::string& owner, const std::vector<std::string>& share_with = {});
// SampleCase() with a PNG-tagged mucosa texture of `texture_bytes` seeded
// pseudo-random bytes, to make a bundle of about that size.
ves::v1::ColonCase BigCase(size_t texture_bytes, uint32_t version = 1);

struct Download {
  grpc::Status status;
  std::string bytes;       // data received, starting at the requested offset
  uint64_t total_bytes = 0;
  std::string sha256_hex;  // announced in the first chunk
  int chunks = 0;
  size_t largest_chunk = 0;
  bool offsets_contiguous = true;
};
// Cases.DownloadCase; with `stop_after_chunks` the client cancels the stream
// after that many chunks (an interrupted download).
Download DownloadCase(const ClientOptions& client, const std::string& case_id, uint32_t version,
                      uint64_t offset, int stop_after_chunks = -1);

// Cases.UploadCase in chunks of `chunk_bytes`; `declared_sha` overrides the
// header's hash (empty: the true one).
grpc::Status UploadCase(const ClientOptions& client, const std::string& bundle,
                        const std::string& label, ves::v1::UploadCaseResponse* response,
                        const std::string& declared_sha = "", size_t chunk_bytes = 256 << 10);

grpc::Status UploadSession(const ClientOptions& client, const ves::v1::SessionRecord& record,
                           ves::v1::UploadSessionResponse* response);

}  // namespace ves::server::testing
