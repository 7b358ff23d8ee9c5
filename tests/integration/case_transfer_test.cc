// Case upload -> list -> download (with resume) over gRPC, and the upload's
// refusals: invalid case naming the field, hash mismatch, version clash.
#include <gtest/gtest.h>

#include "patient_db/case_format.h"
#include "tests/integration/test_server.h"

namespace ves::server::testing {
namespace {

using patient_db::StoreRole;

class CaseTransfer : public ::testing::Test {
 protected:
  void SetUp() override {
    admin_ = server_.Client(server_.MakeToken(StoreRole::kAdmin, "north"));
    station_ = server_.Client(server_.MakeToken(StoreRole::kStation, "north"));
  }
  grpc::Status List(const ves::v1::ListCasesRequest& q, ves::v1::ListCasesResponse* r) {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, station_);
    return ves::v1::Cases::NewStub(MakeClientChannel(station_))->ListCases(&ctx, q, r);
  }
  TestServer server_;
  ClientOptions admin_;
  ClientOptions station_;
};

TEST_F(CaseTransfer, UploadListDownloadWithResumeGivesIdenticalBytes) {
  const auto colon_case = BigCase(3'500'000);  // about 3.5 chunks of 1 MiB
  const std::string bundle = patient_db::EncodeCaseBundle(colon_case);
  ves::v1::UploadCaseResponse up;
  ASSERT_TRUE(UploadCase(admin_, bundle, "big.vescase", &up).ok());
  EXPECT_FALSE(up.already_stored());
  EXPECT_EQ(up.summary().sha256_hex(), Sha256Hex(bundle));
  EXPECT_EQ(up.summary().payload_sha256_hex(), patient_db::CasePayloadSha256Hex(colon_case));

  ves::v1::ListCasesRequest q;
  q.set_region(ves::v1::REGION_SIGMOID);
  ves::v1::ListCasesResponse listed;
  ASSERT_TRUE(List(q, &listed).ok());
  ASSERT_EQ(listed.cases_size(), 1);
  EXPECT_EQ(listed.cases(0).case_id(), colon_case.id());
  EXPECT_EQ(listed.cases(0).size_bytes(), bundle.size());
  q.set_region(ves::v1::REGION_UNSPECIFIED);
  q.set_difficulty(colon_case.difficulty() == ves::v1::DIFFICULTY_HARD
                       ? ves::v1::DIFFICULTY_EASY
                       : ves::v1::DIFFICULTY_HARD);
  ASSERT_TRUE(List(q, &listed).ok());
  EXPECT_EQ(listed.cases_size(), 0);  // the filter excludes it

  // Interrupted after two chunks, then resumed from the bytes held.
  Download first = DownloadCase(station_, colon_case.id(), 0, 0, 2);
  EXPECT_EQ(first.status.error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_EQ(first.bytes.size(), 2u << 20);
  EXPECT_EQ(first.total_bytes, bundle.size());
  EXPECT_EQ(first.sha256_hex, Sha256Hex(bundle));
  Download rest = DownloadCase(station_, colon_case.id(), 0, first.bytes.size());
  ASSERT_TRUE(rest.status.ok()) << rest.status.error_message();
  EXPECT_TRUE(rest.offsets_contiguous);
  EXPECT_LE(rest.largest_chunk, 1u << 20);
  const std::string joined = first.bytes + rest.bytes;
  EXPECT_EQ(joined, bundle);
  EXPECT_EQ(Sha256Hex(joined), rest.sha256_hex);
  EXPECT_EQ(patient_db::DecodeCaseBundle(joined, "downloaded").SerializeAsString(),
            colon_case.SerializeAsString());
}

TEST_F(CaseTransfer, OffsetBeyondTheEndIsOutOfRange) {
  const std::string bundle = patient_db::EncodeCaseBundle(SampleCase());
  ves::v1::UploadCaseResponse up;
  ASSERT_TRUE(UploadCase(admin_, bundle, "s.vescase", &up).ok());
  auto d = DownloadCase(station_, SampleCase().id(), 0, bundle.size() + 1);
  EXPECT_EQ(d.status.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  auto end = DownloadCase(station_, SampleCase().id(), 0, bundle.size());
  EXPECT_TRUE(end.status.ok());  // resuming at the very end: nothing left, still OK
  EXPECT_EQ(end.bytes.size(), 0u);
}

TEST_F(CaseTransfer, InvalidCaseIsRefusedNamingTheField) {
  auto bad = SampleCase();
  bad.mutable_regions(0)->mutable_tissue()->set_static_friction(-0.5);
  ves::v1::UploadCaseResponse up;
  auto status = UploadCase(admin_, patient_db::EncodeCaseBundle(bad), "bad.vescase", &up);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("static_friction"), std::string::npos)
      << status.error_message();
  EXPECT_NE(status.error_message().find("bad.vescase"), std::string::npos);
  ves::v1::ListCasesResponse listed;
  ASSERT_TRUE(List({}, &listed).ok());  // still serving, nothing stored
  EXPECT_EQ(listed.cases_size(), 0);
}

TEST_F(CaseTransfer, HashMismatchesAreRefused) {
  std::string bundle = patient_db::EncodeCaseBundle(SampleCase());
  ves::v1::UploadCaseResponse up;
  auto declared = UploadCase(admin_, bundle, "x.vescase", &up, std::string(64, '0'));
  EXPECT_EQ(declared.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(declared.error_message().find("sha256"), std::string::npos);
  // A payload byte flipped: the bundle's own SHA-256 no longer matches.
  bundle[patient_db::kCaseBundleHeaderSize + 5] ^= 0x01;
  auto inner = UploadCase(admin_, bundle, "flipped.vescase", &up);
  EXPECT_EQ(inner.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(inner.error_message().find("flipped.vescase"), std::string::npos)
      << inner.error_message();
  ves::v1::ListCasesResponse listed;
  EXPECT_TRUE(List({}, &listed).ok());
}

// 250 MiB announced, something else sent: the server answers after the first
// chunk (its magic) instead of buffering the whole upload first.
TEST_F(CaseTransfer, AnUploadThatIsNotABundleIsRefusedAtItsFirstBytes) {
  constexpr uint64_t kAnnounced = 250ull << 20;
  const std::string chunk(1 << 20, 'x');
  auto stub = ves::v1::Cases::NewStub(MakeClientChannel(admin_));
  grpc::ClientContext ctx;
  PrepareContext(&ctx, admin_);
  ves::v1::UploadCaseResponse up;
  auto writer = stub->UploadCase(&ctx, &up);
  ves::v1::UploadCaseRequest part;
  part.mutable_header()->set_file_label("junk.vescase");
  part.mutable_header()->set_total_bytes(kAnnounced);
  part.mutable_header()->set_sha256_hex(std::string(64, '0'));
  ASSERT_TRUE(writer->Write(part));
  int written = 0;
  part.set_chunk(chunk);
  while (written < static_cast<int>(kAnnounced / chunk.size()) && writer->Write(part)) ++written;
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("junk.vescase: bundle.magic"), std::string::npos)
      << status.error_message();
  // What flow control let through before the answer, far from all 250 chunks.
  EXPECT_LT(written, 64);
}

TEST_F(CaseTransfer, VersionsAreKeptAndAVersionCannotChangeContent) {
  auto v1 = SampleCase();
  v1.set_version(1);
  auto v2 = v1;
  v2.set_version(2);
  v2.set_title("second");
  ves::v1::UploadCaseResponse up;
  ASSERT_TRUE(UploadCase(admin_, patient_db::EncodeCaseBundle(v1), "v1", &up).ok());
  ASSERT_TRUE(UploadCase(admin_, patient_db::EncodeCaseBundle(v2), "v2", &up).ok());
  ASSERT_TRUE(UploadCase(admin_, patient_db::EncodeCaseBundle(v1), "v1", &up).ok());
  EXPECT_TRUE(up.already_stored());
  auto changed = v1;
  changed.set_title("changed without a new version");
  auto clash = UploadCase(admin_, patient_db::EncodeCaseBundle(changed), "v1b", &up);
  EXPECT_EQ(clash.error_code(), grpc::StatusCode::ALREADY_EXISTS);
  ves::v1::ListCasesRequest q;
  q.set_all_versions(true);
  ves::v1::ListCasesResponse listed;
  ASSERT_TRUE(List(q, &listed).ok());
  EXPECT_EQ(listed.cases_size(), 2);
  ASSERT_TRUE(List({}, &listed).ok());
  ASSERT_EQ(listed.cases_size(), 1);
  EXPECT_EQ(listed.cases(0).version(), 2u);
  EXPECT_EQ(DownloadCase(station_, v1.id(), 1, 0).bytes, patient_db::EncodeCaseBundle(v1));
}

}  // namespace
}  // namespace ves::server::testing
