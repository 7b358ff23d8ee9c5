// Every role (and no / a wrong token) against every method, over real gRPC:
// the expected status of each cell is the access table of docs/server.md.
#include <gtest/gtest.h>

#include <functional>
#include <map>

#include "patient_db/case_format.h"
#include "tests/integration/test_server.h"

namespace ves::server::testing {
namespace {

using grpc::StatusCode;
using patient_db::StoreRole;
constexpr StatusCode OK = StatusCode::OK;
constexpr StatusCode PD = StatusCode::PERMISSION_DENIED;
constexpr StatusCode UA = StatusCode::UNAUTHENTICATED;
constexpr StatusCode NF = StatusCode::NOT_FOUND;
constexpr StatusCode FP = StatusCode::FAILED_PRECONDITION;

class RoleMatrix : public ::testing::Test {
 protected:
  void SetUp() override {
    server_.AddTrainee("t1", "north");
    server_.AddTrainee("t2", "south");
    const auto colon_case = SampleCase();
    bundle_ = patient_db::EncodeCaseBundle(colon_case);
    patient_db::CaseRow row;
    row.case_id = colon_case.id();
    row.version = colon_case.version();
    row.institution = "north";
    row.sha256_hex = Sha256Hex(bundle_);
    row.payload_sha256_hex = patient_db::CasePayloadSha256Hex(colon_case);
    ASSERT_TRUE(server_.store().PutCase(row, bundle_).ok());
    case_id_ = colon_case.id();
    tokens_["admin"] = server_.MakeToken(StoreRole::kAdmin, "north");
    tokens_["supervisor"] = server_.MakeToken(StoreRole::kSupervisor, "north");
    tokens_["station"] = server_.MakeToken(StoreRole::kStation, "north");
    tokens_["trainee"] = server_.MakeToken(StoreRole::kTrainee, "north", "t1");
    tokens_["supervisor_south"] = server_.MakeToken(StoreRole::kSupervisor, "south");
    tokens_["station_south"] = server_.MakeToken(StoreRole::kStation, "south");
    tokens_["trainee_south"] = server_.MakeToken(StoreRole::kTrainee, "south", "t2");
    tokens_["none"] = "";
    tokens_["wrong"] = std::string(64, 'f');
    ves::v1::UploadSessionResponse r;
    session_uuid_ = NewUuid(rng_);
    ASSERT_TRUE(UploadSession(server_.Client(tokens_["admin"]), MakeRecord(session_uuid_, "t1", 1),
                              &r)
                    .ok());
  }

  template <typename Stub>
  std::unique_ptr<Stub> NewStub(const ClientOptions& o) {
    return std::make_unique<Stub>(MakeClientChannel(o));
  }

  // Calls method `m` as `o`; returns the status code.
  StatusCode Call(const std::string& m, const ClientOptions& o) {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, o);
    auto cases = ves::v1::Cases::NewStub(MakeClientChannel(o));
    auto trainees = ves::v1::Trainees::NewStub(MakeClientChannel(o));
    auto admin = ves::v1::Admin::NewStub(MakeClientChannel(o));
    if (m == "ListCases") {
      ves::v1::ListCasesResponse r;
      return cases->ListCases(&ctx, {}, &r).error_code();
    }
    if (m == "DownloadCase") return DownloadCase(o, case_id_, 0, 0).status.error_code();
    if (m == "UploadCase") {
      ves::v1::UploadCaseResponse r;
      return UploadCase(o, bundle_, "matrix.vescase", &r).error_code();
    }
    if (m == "UploadSession") {
      ves::v1::UploadSessionResponse r;
      return UploadSession(o, MakeRecord(NewUuid(rng_), "t1", 2), &r).error_code();
    }
    if (m == "AddTrainee") {
      ves::v1::AddTraineeRequest q;
      q.mutable_trainee()->set_trainee_id("new-" + std::to_string(++counter_));
      ves::v1::AddTraineeResponse r;
      return trainees->AddTrainee(&ctx, q, &r).error_code();
    }
    if (m == "ListTrainees") {
      ves::v1::ListTraineesRequest q;
      q.set_institution("north");
      ves::v1::ListTraineesResponse r;
      return trainees->ListTrainees(&ctx, q, &r).error_code();
    }
    if (m == "ListSessions") {
      ves::v1::ListSessionsRequest q;
      q.set_trainee_id("t1");
      ves::v1::ListSessionsResponse r;
      return trainees->ListSessions(&ctx, q, &r).error_code();
    }
    if (m == "GetLearningCurve") {
      ves::v1::LearningCurveRequest q;
      q.set_trainee_id("t1");
      ves::v1::LearningCurveResponse r;
      return trainees->GetLearningCurve(&ctx, q, &r).error_code();
    }
    if (m == "GetSession") {
      ves::v1::GetSessionRequest q;
      q.set_uuid(session_uuid_);
      ves::v1::GetSessionResponse r;
      return trainees->GetSession(&ctx, q, &r).error_code();
    }
    if (m == "CreateToken") {
      ves::v1::CreateTokenRequest q;
      q.set_role(ves::v1::ROLE_STATION);
      q.set_institution("north");
      ves::v1::CreateTokenResponse r;
      return admin->CreateToken(&ctx, q, &r).error_code();
    }
    if (m == "ListAudit") {
      ves::v1::ListAuditResponse r;
      return admin->ListAudit(&ctx, {}, &r).error_code();
    }
    ADD_FAILURE() << "unknown method " << m;
    return StatusCode::UNKNOWN;
  }

  TestServer server_;
  std::string bundle_;
  std::string case_id_;
  std::string session_uuid_;
  std::map<std::string, std::string> tokens_;
  std::mt19937_64 rng_{42};
  int counter_ = 0;
};

TEST_F(RoleMatrix, EveryRoleGetsTheDocumentedStatusFromEveryMethod) {
  const std::vector<std::string> methods = {
      "ListCases",    "DownloadCase",     "UploadCase", "UploadSession",
      "AddTrainee",   "ListTrainees",     "ListSessions", "GetLearningCurve",
      "GetSession",   "CreateToken",      "ListAudit"};
  // Columns in the order of `methods`. The "north" trainee data (t1, the case)
  // belongs to institution north; *_south callers are of another institution:
  // north's case, trainee and session answer them as absent ones do (NF; FP
  // "no such trainee" for an upload), never PERMISSION_DENIED, which would
  // tell that they exist.
  const std::map<std::string, std::vector<StatusCode>> expected = {
      {"admin", {OK, OK, OK, OK, OK, OK, OK, OK, OK, OK, OK}},
      {"supervisor", {OK, OK, PD, PD, OK, OK, OK, OK, OK, PD, PD}},
      {"station", {OK, OK, PD, OK, PD, OK, PD, PD, PD, PD, PD}},
      {"trainee", {PD, PD, PD, PD, PD, PD, OK, OK, OK, PD, PD}},
      {"supervisor_south", {OK, NF, PD, PD, OK, PD, NF, NF, NF, PD, PD}},
      {"station_south", {OK, NF, PD, FP, PD, PD, PD, PD, PD, PD, PD}},
      {"trainee_south", {PD, PD, PD, PD, PD, PD, NF, NF, NF, PD, PD}},
      {"none", {UA, UA, UA, UA, UA, UA, UA, UA, UA, UA, UA}},
      {"wrong", {UA, UA, UA, UA, UA, UA, UA, UA, UA, UA, UA}},
  };
  for (const auto& [who, codes] : expected) {
    for (size_t i = 0; i < methods.size(); ++i) {
      EXPECT_EQ(Call(methods[i], server_.Client(tokens_[who])), codes[i])
          << who << " calling " << methods[i];
    }
  }
}

TEST_F(RoleMatrix, SouthStationSeesNorthCaseOnlyOnceShared) {
  const auto south = server_.Client(tokens_["station_south"]);
  EXPECT_EQ(DownloadCase(south, case_id_, 0, 0).status.error_code(), NF);
  // A second version shared with south: its stations may download that one.
  auto shared = BigCase(1000, 2);
  const std::string bundle = patient_db::EncodeCaseBundle(shared);
  auto stub = ves::v1::Cases::NewStub(MakeClientChannel(server_.Client(tokens_["admin"])));
  grpc::ClientContext ctx;
  PrepareContext(&ctx, server_.Client(tokens_["admin"]));
  ves::v1::UploadCaseResponse response;
  auto writer = stub->UploadCase(&ctx, &response);
  ves::v1::UploadCaseRequest part;
  part.mutable_header()->set_total_bytes(bundle.size());
  part.mutable_header()->set_sha256_hex(Sha256Hex(bundle));
  part.mutable_header()->add_share_with("south");
  ASSERT_TRUE(writer->Write(part));
  part.set_chunk(bundle);
  ASSERT_TRUE(writer->Write(part));
  writer->WritesDone();
  ASSERT_TRUE(writer->Finish().ok());
  EXPECT_EQ(DownloadCase(south, case_id_, 2, 0).status.error_code(), OK);
  EXPECT_EQ(DownloadCase(south, case_id_, 1, 0).status.error_code(), NF);
}

// What another institution learns about north's ids: exactly what it learns
// about ids that do not exist (issue #20: NOT_FOUND vs PERMISSION_DENIED told
// them apart, and a reused foreign uuid answered with its stored hash).
TEST_F(RoleMatrix, AnotherInstitutionsIdsAnswerExactlyAsMissingOnes) {
  const auto south = server_.Client(tokens_["supervisor_south"]);
  auto get_session = [&](const std::string& uuid) {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, south);
    ves::v1::GetSessionRequest q;
    q.set_uuid(uuid);
    ves::v1::GetSessionResponse r;
    return ves::v1::Trainees::NewStub(MakeClientChannel(south))->GetSession(&ctx, q, &r);
  };
  const grpc::Status foreign = get_session(session_uuid_);
  const std::string missing_uuid = NewUuid(rng_);
  const grpc::Status missing = get_session(missing_uuid);
  EXPECT_EQ(foreign.error_code(), missing.error_code());
  EXPECT_EQ(foreign.error_message(), "no session '" + session_uuid_ + "'");
  EXPECT_EQ(missing.error_message(), "no session '" + missing_uuid + "'");
  auto list_sessions = [&](const std::string& trainee) {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, south);
    ves::v1::ListSessionsRequest q;
    q.set_trainee_id(trainee);
    ves::v1::ListSessionsResponse r;
    return ves::v1::Trainees::NewStub(MakeClientChannel(south))->ListSessions(&ctx, q, &r);
  };
  EXPECT_EQ(list_sessions("t1").error_message(), "no trainee 't1'");
  EXPECT_EQ(list_sessions("nobody").error_message(), "no trainee 'nobody'");
  const grpc::Status foreign_case = DownloadCase(south, case_id_, 1, 0).status;
  const grpc::Status missing_case = DownloadCase(south, "no-such-case", 1, 0).status;
  EXPECT_EQ(foreign_case.error_code(), missing_case.error_code());
  EXPECT_EQ(foreign_case.error_message(), "no case '" + case_id_ + "' version 1");

  // South's station reuses north's session uuid for its own trainee's record.
  PutTestCase(server_.store(),
              patient_db::LoadCaseFile(std::string(VES_SOURCE_DIR) +
                                       "/patient_db/cases/paper-sigmoid.textproto"),
              "south");
  ves::v1::SessionRecord theirs = MakeRecord(session_uuid_, "t2", 5);
  theirs.set_case_id("paper-sigmoid");
  ves::v1::UploadSessionResponse ack;
  const grpc::Status reuse = UploadSession(server_.Client(tokens_["station_south"]), theirs, &ack);
  EXPECT_EQ(reuse.error_code(), StatusCode::ALREADY_EXISTS);
  auto stored = server_.store().GetSession(session_uuid_);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(reuse.error_message().find(stored.value.body_sha256_hex), std::string::npos)
      << reuse.error_message();
}

TEST_F(RoleMatrix, AuditLogRecordsWhoWhatAndResult) {
  Call("DownloadCase", server_.Client(tokens_["station"]));
  Call("GetSession", server_.Client(tokens_["trainee_south"]));
  // Reads are audited through the group commit: wait until they are visible.
  std::vector<patient_db::AuditRow> rows;
  for (int i = 0; i < 100; ++i) {
    rows = server_.store().ListAudit(0, 1000).value;
    if (rows.size() >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  bool saw_download = false, saw_denied_read = false;
  for (const auto& r : rows) {
    if (r.action == "case.download" && r.role == "station" && r.result == "OK") {
      saw_download = true;
    }
    if (r.action == "session.read" && r.institution == "south" &&
        r.result.rfind("NOT_FOUND", 0) == 0) {
      saw_denied_read = true;
    }
  }
  EXPECT_TRUE(saw_download);
  EXPECT_TRUE(saw_denied_read);
  grpc::ClientContext ctx;
  PrepareContext(&ctx, server_.Client(tokens_["admin"]));
  ves::v1::ListAuditResponse r;
  ASSERT_TRUE(ves::v1::Admin::NewStub(MakeClientChannel(server_.Client(tokens_["admin"])))
                  ->ListAudit(&ctx, {}, &r)
                  .ok());
  EXPECT_GE(r.entries_size(), 3);
}

}  // namespace
}  // namespace ves::server::testing
