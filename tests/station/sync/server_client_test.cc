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
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/ca.pem"), std::string::npos);
  }
}

}  // namespace
}  // namespace ves::sync
