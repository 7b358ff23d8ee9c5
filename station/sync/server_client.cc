#include "station/sync/server_client.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include "patient_db/case_bundle.h"
#include "patient_db/net_address.h"

namespace ves::sync {
namespace {

std::unique_ptr<grpc::ClientContext> MakeContext(const ServerEndpoint& endpoint) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + endpoint.deadline);
  context->AddMetadata("authorization", "Bearer " + endpoint.token);
  return context;
}

std::string DescribeStatus(const grpc::Status& status) {
  return "status " + std::to_string(static_cast<int>(status.error_code())) + ": " +
         status.error_message();
}

std::string ReadFileOrEmpty(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

}  // namespace

void CheckEndpoint(const ServerEndpoint& endpoint) {
  if (endpoint.tls_ca_file.empty()) {
    if (!patient_db::IsLoopbackAddress(endpoint.address)) {
      throw std::invalid_argument("refusing to send the token in plaintext to '" +
                                  endpoint.address +
                                  "': give --tls-ca (plaintext only to a loopback address such "
                                  "as 127.0.0.1:50051)");
    }
    return;
  }
  if (ReadFileOrEmpty(endpoint.tls_ca_file).empty()) {
    throw std::invalid_argument("--tls-ca " + endpoint.tls_ca_file +
                                ": cannot read the file (or it is empty)");
  }
}

std::shared_ptr<grpc::Channel> MakeChannel(const ServerEndpoint& endpoint) {
  CheckEndpoint(endpoint);
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(8 << 20);
  if (endpoint.tls_ca_file.empty()) {
    return grpc::CreateCustomChannel(endpoint.address, grpc::InsecureChannelCredentials(),
                                     arguments);
  }
  grpc::SslCredentialsOptions options;
  options.pem_root_certs = ReadFileOrEmpty(endpoint.tls_ca_file);
  return grpc::CreateCustomChannel(endpoint.address, grpc::SslCredentials(options), arguments);
}

UploadVerdict ClassifyUploadStatus(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK:
      return UploadVerdict::kAcknowledged;
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::OUT_OF_RANGE:
    case grpc::StatusCode::UNIMPLEMENTED:
      return UploadVerdict::kRejected;
    default:  // UNAVAILABLE, DEADLINE_EXCEEDED, RESOURCE_EXHAUSTED, auth, INTERNAL, ...
      return UploadVerdict::kRetryLater;
  }
}

GrpcSessionUploader::GrpcSessionUploader(ServerEndpoint endpoint)
    : endpoint_(std::move(endpoint)),
      stub_(ves::v1::Sessions::NewStub(MakeChannel(endpoint_))) {}

UploadResult GrpcSessionUploader::Upload(const ves::v1::SessionRecord& record) {
  ves::v1::UploadSessionRequest request;
  *request.mutable_record() = record;
  ves::v1::UploadSessionResponse response;
  const auto context = MakeContext(endpoint_);
  const grpc::Status status = stub_->UploadSession(context.get(), request, &response);
  if (status.ok() && response.uuid() != record.uuid()) {
    return {UploadVerdict::kRetryLater, "server acknowledged another uuid: " + response.uuid()};
  }
  return {ClassifyUploadStatus(status.error_code()), status.ok() ? "" : DescribeStatus(status)};
}

CachedCase DownloadCaseToCache(const ServerEndpoint& endpoint, const std::string& case_id,
                               CaseCache& cache) {
  const auto partial_dir = cache.dir() / "partial";
  std::filesystem::create_directories(partial_dir);
  const auto partial = partial_dir / (case_id + ".part");
  const auto expected_sha_file = partial_dir / (case_id + ".sha256");

  std::string bytes = ReadFileOrEmpty(partial);
  const std::string previous_sha = ReadFileOrEmpty(expected_sha_file);

  auto stub = ves::v1::Cases::NewStub(MakeChannel(endpoint));
  ves::v1::DownloadCaseRequest request;
  request.set_case_id(case_id);
  request.set_offset(bytes.size());
  const auto context = MakeContext(endpoint);
  auto reader = stub->DownloadCase(context.get(), request);

  std::ofstream out(partial, std::ios::binary | std::ios::app);
  ves::v1::CaseChunk chunk;
  uint64_t total_bytes = 0;
  std::string announced_sha;
  bool first = true;
  while (reader->Read(&chunk)) {
    if (first) {
      total_bytes = chunk.total_bytes();
      announced_sha = chunk.sha256_hex();
      if (!previous_sha.empty() && previous_sha != announced_sha) {
        // The case changed on the server since the partial download: start over.
        reader->Finish().ok();
        std::filesystem::remove(partial);
        std::filesystem::remove(expected_sha_file);
        return DownloadCaseToCache(endpoint, case_id, cache);
      }
      std::ofstream(expected_sha_file, std::ios::binary | std::ios::trunc) << announced_sha;
      first = false;
    }
    if (chunk.offset() != bytes.size()) {
      throw std::runtime_error("download of case " + case_id + ": chunk at offset " +
                               std::to_string(chunk.offset()) + ", expected " +
                               std::to_string(bytes.size()));
    }
    out.write(chunk.data().data(), static_cast<std::streamsize>(chunk.data().size()));
    out.flush();
    bytes += chunk.data();
  }
  const grpc::Status status = reader->Finish();
  out.close();
  if (!status.ok()) {
    throw std::runtime_error("download of case " + case_id + " stopped at byte " +
                             std::to_string(bytes.size()) + " (resumable): " +
                             DescribeStatus(status));
  }
  if (bytes.size() != total_bytes) {
    throw std::runtime_error("download of case " + case_id + ": got " +
                             std::to_string(bytes.size()) + " bytes, server announced " +
                             std::to_string(total_bytes));
  }
  const std::string actual_sha = patient_db::Sha256Hex(bytes);
  std::filesystem::remove(partial);
  std::filesystem::remove(expected_sha_file);
  if (actual_sha != announced_sha) {
    throw std::runtime_error("download of case " + case_id + ": SHA-256 " + actual_sha +
                             " differs from the announced " + announced_sha +
                             "; the partial file was discarded");
  }
  return cache.Put(patient_db::DecodeCaseBundle(bytes, "download of case " + case_id));
}

}  // namespace ves::sync
