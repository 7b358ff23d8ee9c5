// The Cases service: list, streamed download with resume, streamed upload.
#include <algorithm>

#include "patient_db/case_bundle.h"
#include "patient_db/case_problem.h"
#include "server/pipeline.h"
#include "server/services.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreRole;

std::shared_ptr<const std::string> BlobCache::Get(const std::string& sha256_hex) {
  std::lock_guard lock(mutex_);
  auto it = blobs_.find(sha256_hex);
  return it == blobs_.end() ? nullptr : it->second;
}

void BlobCache::Put(const std::string& sha256_hex, std::shared_ptr<const std::string> bytes) {
  std::lock_guard lock(mutex_);
  if (bytes->size() > budget_bytes_ || blobs_.count(sha256_hex)) return;
  // Crude but bounded: forget everything when the budget would be exceeded.
  if (bytes_ + bytes->size() > budget_bytes_) {
    blobs_.clear();
    bytes_ = 0;
  }
  bytes_ += bytes->size();
  blobs_[sha256_hex] = std::move(bytes);
}

namespace {

void ToSummary(const patient_db::CaseRow& row, ves::v1::CaseSummary* s) {
  s->set_case_id(row.case_id);
  s->set_version(row.version);
  s->set_title(row.title);
  s->set_difficulty(static_cast<ves::v1::Difficulty>(row.difficulty));
  s->set_institution(row.institution);
  for (int r = 1; r < 64; ++r) {
    if (row.region_mask & (uint64_t{1} << r)) s->add_regions(static_cast<ves::v1::Region>(r));
  }
  s->set_sha256_hex(row.sha256_hex);
  s->set_payload_sha256_hex(row.payload_sha256_hex);
  s->set_size_bytes(row.size_bytes);
  s->set_stored_unix_ms(row.stored_unix_ms);
  for (const auto& i : row.shared_with) s->add_shared_with(i);
}

bool VisibleTo(const patient_db::CaseRow& row, const Principal& who) {
  if (who.role == StoreRole::kAdmin || row.institution == who.institution) return true;
  return std::find(row.shared_with.begin(), row.shared_with.end(), who.institution) !=
         row.shared_with.end();
}

std::string CaseTarget(const std::string& id, uint32_t version) {
  return id + "@" + (version == 0 ? std::string("latest") : std::to_string(version));
}

// Streams bytes [offset, end) in chunks of at most kCaseChunkBytes; the first
// chunk carries the summary, total size and hash even when no data is left.
class DownloadReactor final : public grpc::ServerWriteReactor<ves::v1::CaseChunk> {
 public:
  DownloadReactor(std::shared_ptr<const std::string> bytes, ves::v1::CaseSummary summary,
                  uint64_t offset)
      : bytes_(std::move(bytes)), summary_(std::move(summary)), offset_(offset) {
    WriteNext();
  }
  void OnWriteDone(bool ok) override {
    if (!ok) {
      Finish(Status(StatusCode::CANCELLED, "client went away"));
      return;
    }
    WriteNext();
  }
  void OnDone() override { delete this; }

 private:
  void WriteNext() {
    if (!first_ && offset_ >= bytes_->size()) {
      Finish(Status::OK);
      return;
    }
    chunk_.Clear();
    if (first_) {
      *chunk_.mutable_summary() = summary_;
      chunk_.set_total_bytes(bytes_->size());
      chunk_.set_sha256_hex(summary_.sha256_hex());
      first_ = false;
    }
    const size_t n = std::min<uint64_t>(kCaseChunkBytes, bytes_->size() - offset_);
    chunk_.set_offset(offset_);
    chunk_.set_data(bytes_->data() + offset_, n);
    offset_ += n;
    StartWrite(&chunk_);
  }

  std::shared_ptr<const std::string> bytes_;
  ves::v1::CaseSummary summary_;
  uint64_t offset_;
  bool first_ = true;
  ves::v1::CaseChunk chunk_;
};

template <typename Base>
class ErrorReactor final : public Base {
 public:
  explicit ErrorReactor(const Status& status) { this->Finish(status); }
  void OnDone() override { delete this; }
};

// Collects the header and the chunks, then checks size, hash and the case
// itself (the case validator names the field) before storing. Each message
// passes the pipeline's bounds stage; the call's audit row names the case
// once decoded and is written when the stream ends.
class UploadReactor final : public grpc::ServerReadReactor<ves::v1::UploadCaseRequest> {
 public:
  UploadReactor(ServiceDeps deps, std::shared_ptr<AsyncCall> call,
                ves::v1::UploadCaseResponse* response)
      : deps_(deps), call_(std::move(call)), who_(call_->who()), response_(response) {
    call_->set_finisher([this](const Status& status) { Finish(status); });
    StartRead(&request_);
  }
  void OnReadDone(bool ok) override {
    if (!ok) {
      Done(Complete());
      return;
    }
    Status s = Take();
    if (!s.ok()) {
      Done(s);
      return;
    }
    StartRead(&request_);
  }
  void OnDone() override { delete this; }

 private:
  Status Take() {
    const Status limits = call_->AdmitMessage(request_);
    if (!limits.ok()) return limits;
    if (request_.has_header()) {
      if (has_header_) return Status(StatusCode::INVALID_ARGUMENT, "a second header");
      header_ = request_.header();
      has_header_ = true;
      if (header_.total_bytes() > kMaxCaseUploadBytes) {
        return Status(StatusCode::RESOURCE_EXHAUSTED,
                      "header.total_bytes = " + std::to_string(header_.total_bytes()) +
                          ": larger than the limit " + std::to_string(kMaxCaseUploadBytes));
      }
      return Status::OK;
    }
    if (!has_header_) return Status(StatusCode::INVALID_ARGUMENT, "chunk before the header");
    if (bytes_.size() + request_.chunk().size() > header_.total_bytes()) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "more bytes than header.total_bytes = " +
                        std::to_string(header_.total_bytes()));
    }
    bytes_ += request_.chunk();
    if (!head_checked_) {
      // The bundle's magic and length are checked with its first bytes, not
      // after 256 MiB of something else have been buffered.
      try {
        patient_db::CheckCaseBundleHead(bytes_, header_.total_bytes(), Label());
      } catch (const patient_db::CaseError& e) {
        return Status(StatusCode::INVALID_ARGUMENT, patient_db::JoinProblems(e.problems()));
      }
      head_checked_ = bytes_.size() >= patient_db::kCaseBundleHeaderSize;
      if (head_checked_) bytes_.reserve(header_.total_bytes());
    }
    return Status::OK;
  }

  std::string Label() const {
    return header_.file_label().empty() ? std::string("upload") : header_.file_label();
  }

  Status Complete() {
    if (!has_header_) return Status(StatusCode::INVALID_ARGUMENT, "no header was sent");
    const std::string label = Label();
    if (bytes_.size() != header_.total_bytes()) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    label + ": received " + std::to_string(bytes_.size()) +
                        " bytes, header.total_bytes = " + std::to_string(header_.total_bytes()));
    }
    const std::string sha = Sha256Hex(bytes_);
    if (sha != header_.sha256_hex()) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    label + ": header.sha256_hex = " + header_.sha256_hex() +
                        " does not match the bytes received (sha256 " + sha + ")");
    }
    ves::v1::ColonCase colon_case;
    try {
      colon_case = patient_db::DecodeCaseBundle(bytes_, label);
    } catch (const patient_db::CaseError& e) {
      return Status(StatusCode::INVALID_ARGUMENT, patient_db::JoinProblems(e.problems()));
    }
    call_->set_target(CaseTarget(colon_case.id(), colon_case.version()));
    // Stored canonical: the same case always has the same bytes and address.
    const std::string canonical = patient_db::EncodeCaseBundle(colon_case);
    patient_db::CaseRow row;
    row.case_id = colon_case.id();
    row.version = colon_case.version();
    row.title = colon_case.title();
    row.difficulty = colon_case.difficulty();
    for (const auto& span : colon_case.regions()) {
      if (span.region() > 0 && span.region() < 64) row.region_mask |= uint64_t{1} << span.region();
    }
    row.institution = header_.institution().empty() ? who_.institution : header_.institution();
    row.sha256_hex = Sha256Hex(canonical);
    row.payload_sha256_hex = patient_db::CasePayloadSha256Hex(colon_case);
    row.uploaded_by = who_.token_id;
    row.stored_unix_ms = NowUnixMs();
    row.shared_with.assign(header_.share_with().begin(), header_.share_with().end());
    auto st = deps_.store->AddInstitution(row.institution, row.stored_unix_ms);
    if (!st.ok()) return ToGrpcStatus(st);
    auto put = deps_.store->PutCase(row, canonical);
    if (!put.ok()) return ToGrpcStatus(put.status);
    ToSummary(put.value.row, response_->mutable_summary());
    response_->set_already_stored(put.value.already_stored);
    return Status::OK;
  }

  void Done(const Status& status) { call_->Finish(status); }

  ServiceDeps deps_;
  std::shared_ptr<AsyncCall> call_;
  const Principal& who_;
  ves::v1::UploadCaseResponse* response_;
  ves::v1::UploadCaseRequest request_;
  ves::v1::UploadCaseHeader header_;
  bool has_header_ = false;
  bool head_checked_ = false;
  std::string bytes_;
};

}  // namespace

Status ListCasesCall(const ServiceDeps& deps, const Principal& who,
                     const ves::v1::ListCasesRequest& request, ves::v1::ListCasesResponse* response) {
  static const CallSpec spec{
      "case.list", {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation}, "list cases"};
  return RunCall(deps, who, spec, request.institution(), [&]() -> Status {
    patient_db::CaseFilter filter;
    filter.region = request.region();
    filter.difficulty = request.difficulty();
    filter.institution = request.institution();
    filter.all_versions = request.all_versions();
    if (who.role != StoreRole::kAdmin) filter.visible_to = who.institution;
    const Status token = ReadPageToken(request.page_token(), "cases", &filter.page);
    if (!token.ok()) return token;
    const int size = PageSizeOf(request.page_size());
    filter.page.limit = size + 1;  // one more tells whether a next page exists
    auto rows = deps.store->ListCases(filter);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    size_t bytes = 0;
    for (int i = 0; i < static_cast<int>(rows.value.size()) && i < size; ++i) {
      ToSummary(rows.value[i], response->add_cases());
      bytes += response->cases(i).ByteSizeLong() + 8;
      const bool more = i + 1 < static_cast<int>(rows.value.size());
      if (more && (i + 1 == size || bytes > kPageReplyBudgetBytes)) {
        const auto& last = rows.value[i];
        response->set_next_page_token(MakePageToken("cases", last.version, last.case_id));
        break;
      }
    }
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* CasesService::ListCases(grpc::CallbackServerContext* ctx,
                                                  const ves::v1::ListCasesRequest* request,
                                                  ves::v1::ListCasesResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListCasesCall);
}

grpc::ServerWriteReactor<ves::v1::CaseChunk>* CasesService::DownloadCase(
    grpc::CallbackServerContext* ctx, const ves::v1::DownloadCaseRequest* request) {
  using Error = ErrorReactor<grpc::ServerWriteReactor<ves::v1::CaseChunk>>;
  Principal who;
  const Status admitted = AdmitRequest(deps_, AuthorizationOf(ctx), *request, &who);
  if (!admitted.ok()) return new Error(admitted);
  // The audit row names the stored version once the body has found it.
  std::string target = CaseTarget(request->case_id(), request->version());
  std::shared_ptr<const std::string> bytes;
  ves::v1::CaseSummary summary;
  static const CallSpec spec{
      "case.download", {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation},
      "download cases"};
  const Status status = RunCall(deps_, who, spec, target, [&]() -> Status {
    auto row = deps_.store->GetCase(request->case_id(), request->version());
    if (!row.ok()) return ToGrpcStatus(row.status);
    target = CaseTarget(row.value.case_id, row.value.version);
    if (!VisibleTo(row.value, who)) {
      // As for a case that does not exist: its existence is not told.
      const uint32_t version = request->version();
      return Status(StatusCode::NOT_FOUND,
                    "no case '" + request->case_id() + "'" +
                        (version == 0 ? std::string() : " version " + std::to_string(version)));
    }
    if (request->offset() > row.value.size_bytes) {
      return Status(StatusCode::OUT_OF_RANGE,
                    "offset = " + std::to_string(request->offset()) + ": the case has only " +
                        std::to_string(row.value.size_bytes) + " bytes");
    }
    bytes = blobs_.Get(row.value.sha256_hex);
    if (!bytes) {
      auto blob = deps_.store->GetBlob(row.value.sha256_hex);
      if (!blob.ok()) return ToGrpcStatus(blob.status);
      bytes = std::make_shared<const std::string>(std::move(blob.value));
      blobs_.Put(row.value.sha256_hex, bytes);
    }
    ToSummary(row.value, &summary);
    return Status::OK;
  });
  if (!status.ok()) return new Error(status);
  return new DownloadReactor(std::move(bytes), std::move(summary), request->offset());
}

grpc::ServerReadReactor<ves::v1::UploadCaseRequest>* CasesService::UploadCase(
    grpc::CallbackServerContext* ctx, ves::v1::UploadCaseResponse* response) {
  using Reactor = grpc::ServerReadReactor<ves::v1::UploadCaseRequest>;
  static const CallSpec spec{"case.upload", {StoreRole::kAdmin}, "upload cases"};
  return ServeAsync<Reactor>(
      ctx, deps_, spec, "?",
      [&](std::shared_ptr<AsyncCall> call) {
        return new UploadReactor(deps_, std::move(call), response);
      },
      [](const Status& status) { return new ErrorReactor<Reactor>(status); });
}

}  // namespace ves::server
