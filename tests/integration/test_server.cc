#include "tests/integration/test_server.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <stdexcept>

#include "patient_db/case_format.h"
#include "station/training/input_log.h"

namespace ves::server::testing {

std::filesystem::path MakeTempDir(const std::string& tag) {
  static std::atomic<int> counter{0};
  auto dir = std::filesystem::temp_directory_path() /
             ("ves_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TestServer::TestServer(ServerOptions options, bool log_calls) : dir_(MakeTempDir("server")) {
  options.listen = "127.0.0.1:0";
  if (options.tls_cert_file.empty()) options.insecure_loopback = true;
  options.log_calls = log_calls;
  server_ = std::make_unique<VesServer>(
      options, patient_db::OpenStore("sqlite:" + (dir_ / "ves.db").string()));
  server_->Start();
}

TestServer::~TestServer() {
  server_.reset();
  std::filesystem::remove_all(dir_);
}

std::string TestServer::MakeToken(patient_db::StoreRole role, const std::string& institution,
                                  const std::string& trainee_id) {
  const std::string token = NewToken();
  store().AddInstitution(institution, 1);
  patient_db::TokenRow row{Sha256Hex(token), role, institution, trainee_id,
                           std::string(patient_db::RoleName(role)) + "@" + institution, 1};
  auto st = store().AddToken(row);
  if (!st.ok()) throw std::runtime_error(st.message);
  return token;
}

void TestServer::AddTrainee(const std::string& trainee_id, const std::string& institution) {
  store().AddInstitution(institution, 1);
  auto st = store().AddTrainee({trainee_id, institution, "Trainee " + trainee_id, 1});
  if (!st.ok()) throw std::runtime_error(st.message);
}

ClientOptions TestServer::Client(const std::string& token) const {
  ClientOptions o;
  o.address = address();
  o.token = token;
  // A failsafe, not a measurement: generous enough for sanitizer builds
  // (a 250 MiB refused upload took 17 s under ThreadSanitizer).
  o.deadline = std::chrono::seconds(60);
  return o;
}

std::string NewUuid(std::mt19937_64& rng) {
  static const char kHex[] = "0123456789abcdef";
  std::string s(36, '-');
  for (size_t i = 0; i < s.size(); ++i) {
    if (i == 8 || i == 13 || i == 18 || i == 23) continue;
    s[i] = kHex[rng() & 0xf];
  }
  s[14] = '4';
  s[19] = kHex[8 + (rng() & 3)];
  return s;
}

ves::v1::SessionRecord MakeRecord(const std::string& uuid, const std::string& trainee_id,
                                  int seed) {
  ves::v1::SessionRecord r;
  r.set_uuid(uuid);
  r.set_trainee_id(trainee_id);
  r.set_case_id("standard-adult");
  r.set_case_version(1);
  r.set_station_id("station-1");
  r.set_start_unix_ms(1'700'000'000'000 + seed * 60'000);
  r.set_end_unix_ms(r.start_unix_ms() + 300'000);
  r.set_outcome(ves::v1::OUTCOME_CECUM_REACHED);
  auto* m = r.mutable_metrics();
  m->set_duration_s(300);
  m->set_completed(true);
  m->set_time_to_cecum_s(200 + seed % 50);
  m->set_pain_s(5 + seed % 7);
  m->set_peak_insertion_force_n(8.5);
  r.set_score(50 + seed % 50);
  for (int i = 0; i < 4; ++i) {
    auto* e = r.add_events();
    e->set_t_s(10.0 * i);
    e->set_kind(ves::v1::EVENT_KIND_LOOP);
    e->set_value(seed + i);
  }
  // A well-formed log (its header is checked at upload) of 1000 idle steps.
  std::vector<training::InputSample> samples(1000);
  for (size_t i = 0; i < samples.size(); ++i) {
    samples[i].tick = i;
    samples[i].push_force_N = 0.001 * (seed % 100);
  }
  *r.mutable_input_log() = training::MakeInputLog(samples, 0.001);
  r.set_operator_kind("human");
  return r;
}

void PutSampleCase(patient_db::Store& store, const std::string& owner,
                   const std::vector<std::string>& share_with) {
  PutTestCase(store, SampleCase(), owner, share_with);
}

void PutTestCase(patient_db::Store& store, const ves::v1::ColonCase& colon_case,
                 const std::string& owner, const std::vector<std::string>& share_with) {
  const std::string bundle = patient_db::EncodeCaseBundle(colon_case);
  patient_db::CaseRow row;
  row.case_id = colon_case.id();
  row.version = colon_case.version();
  row.title = colon_case.title();
  row.institution = owner;
  row.sha256_hex = Sha256Hex(bundle);
  row.payload_sha256_hex = patient_db::CasePayloadSha256Hex(colon_case);
  row.shared_with = share_with;
  std::sort(row.shared_with.begin(), row.shared_with.end());
  store.AddInstitution(owner, 1);
  for (const auto& i : share_with) store.AddInstitution(i, 1);
  auto put = store.PutCase(row, bundle);
  if (!put.ok()) throw std::runtime_error("PutTestCase: " + put.status.message);
}

ves::v1::ColonCase SampleCase() {
  return patient_db::LoadCaseFile(std::filesystem::path(VES_SOURCE_DIR) /
                                  "patient_db/cases/standard-adult.textproto");
}

ves::v1::ColonCase BigCase(size_t texture_bytes, uint32_t version) {
  ves::v1::ColonCase c = SampleCase();
  c.set_version(version);
  std::string image = "\x89PNG\r\n\x1a\n";
  std::mt19937_64 rng(1234 + version);
  while (image.size() < texture_bytes) {
    const uint64_t v = rng();
    image.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  c.mutable_mucosa_texture()->set_media_type("image/png");
  c.mutable_mucosa_texture()->set_image(image);
  return c;
}

Download DownloadCase(const ClientOptions& client, const std::string& case_id, uint32_t version,
                      uint64_t offset, int stop_after_chunks) {
  auto stub = ves::v1::Cases::NewStub(MakeClientChannel(client));
  grpc::ClientContext ctx;
  PrepareContext(&ctx, client);
  ves::v1::DownloadCaseRequest request;
  request.set_case_id(case_id);
  request.set_version(version);
  request.set_offset(offset);
  auto reader = stub->DownloadCase(&ctx, request);
  Download d;
  ves::v1::CaseChunk chunk;
  while (reader->Read(&chunk)) {
    if (d.chunks == 0) {
      d.total_bytes = chunk.total_bytes();
      d.sha256_hex = chunk.sha256_hex();
    }
    if (chunk.offset() != offset + d.bytes.size()) d.offsets_contiguous = false;
    d.largest_chunk = std::max(d.largest_chunk, chunk.data().size());
    d.bytes += chunk.data();
    if (++d.chunks == stop_after_chunks) {
      ctx.TryCancel();
      break;
    }
  }
  d.status = reader->Finish();
  return d;
}

grpc::Status UploadCase(const ClientOptions& client, const std::string& bundle,
                        const std::string& label, ves::v1::UploadCaseResponse* response,
                        const std::string& declared_sha, size_t chunk_bytes) {
  auto stub = ves::v1::Cases::NewStub(MakeClientChannel(client));
  grpc::ClientContext ctx;
  PrepareContext(&ctx, client);
  auto writer = stub->UploadCase(&ctx, response);
  ves::v1::UploadCaseRequest part;
  auto* header = part.mutable_header();
  header->set_file_label(label);
  header->set_total_bytes(bundle.size());
  header->set_sha256_hex(declared_sha.empty() ? Sha256Hex(bundle) : declared_sha);
  bool ok = writer->Write(part);
  for (size_t off = 0; ok && off < bundle.size(); off += chunk_bytes) {
    part.set_chunk(bundle.substr(off, chunk_bytes));
    ok = writer->Write(part);
  }
  writer->WritesDone();
  return writer->Finish();
}

grpc::Status UploadSession(const ClientOptions& client, const ves::v1::SessionRecord& record,
                           ves::v1::UploadSessionResponse* response) {
  auto stub = ves::v1::Sessions::NewStub(MakeClientChannel(client));
  grpc::ClientContext ctx;
  PrepareContext(&ctx, client);
  ves::v1::UploadSessionRequest request;
  *request.mutable_record() = record;
  return stub->UploadSession(&ctx, request, response);
}

}  // namespace ves::server::testing
