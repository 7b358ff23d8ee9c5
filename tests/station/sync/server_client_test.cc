#include "station/sync/server_client.h"

#include <gtest/gtest.h>

namespace ves::sync {
namespace {

TEST(ClassifyUploadStatus, OnlyOkIsAnAcknowledgement) {
  EXPECT_EQ(ClassifyUploadStatus(grpc::StatusCode::OK), UploadVerdict::kAcknowledged);
}

TEST(ClassifyUploadStatus, TransientFailuresAreRetried) {
  for (const auto code : {grpc::StatusCode::UNAVAILABLE, grpc::StatusCode::DEADLINE_EXCEEDED,
                          grpc::StatusCode::RESOURCE_EXHAUSTED, grpc::StatusCode::INTERNAL,
                          grpc::StatusCode::UNAUTHENTICATED, grpc::StatusCode::PERMISSION_DENIED,
                          grpc::StatusCode::ABORTED, grpc::StatusCode::CANCELLED}) {
    EXPECT_EQ(ClassifyUploadStatus(code), UploadVerdict::kRetryLater) << static_cast<int>(code);
  }
}

TEST(ClassifyUploadStatus, InvalidOrConflictingRecordsAreNotRetried) {
  for (const auto code : {grpc::StatusCode::INVALID_ARGUMENT, grpc::StatusCode::ALREADY_EXISTS,
                          grpc::StatusCode::FAILED_PRECONDITION}) {
    EXPECT_EQ(ClassifyUploadStatus(code), UploadVerdict::kRejected) << static_cast<int>(code);
  }
}

// A dead network: nothing listens on the port. The upload is a retry-later
// with a message, never an exception, and within the deadline.
TEST(GrpcSessionUploader, DeadServerMeansRetryLater) {
  ServerEndpoint endpoint{"127.0.0.1:1", "token", "", std::chrono::milliseconds(300)};
  GrpcSessionUploader uploader(endpoint);
  ves::v1::SessionRecord record;
  record.set_uuid("00000000-0000-4000-8000-000000000001");
  const UploadResult result = uploader.Upload(record);
  EXPECT_EQ(result.verdict, UploadVerdict::kRetryLater);
  EXPECT_FALSE(result.message.empty());
}

TEST(MakeChannel, MissingCaFileIsAClearError) {
  ServerEndpoint endpoint{"127.0.0.1:1", "token", "/nonexistent/ca.pem", {}};
  try {
    MakeChannel(endpoint);
    FAIL();
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()),
              "--tls-ca /nonexistent/ca.pem: cannot read the file (or it is empty)");
  }
}

// The server's own rule for plaintext, on the station's side (issue #20).
TEST(MakeChannel, PlaintextOffLoopbackIsRefusedBeforeAnyConnection) {
  for (const char* address : {"ves.example.org:50051", "10.0.0.7:50051", "0.0.0.0:50051"}) {
    ServerEndpoint endpoint{address, "token", "", {}};
    EXPECT_THROW(CheckEndpoint(endpoint), std::invalid_argument) << address;
    EXPECT_THROW(MakeChannel(endpoint), std::invalid_argument) << address;
  }
  for (const char* address : {"127.0.0.1:50051", "localhost:1", "[::1]:50051"}) {
    EXPECT_NO_THROW(CheckEndpoint(ServerEndpoint{address, "token", "", {}})) << address;
  }
}

}  // namespace
}  // namespace ves::sync
