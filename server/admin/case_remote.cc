// `ves-admin case upload|list|download`: the case library on a server.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "patient_db/case_format.h"
#include "server/admin/remote.h"
#include "server/auth.h"
#include "ves/v1/services.grpc.pb.h"

namespace ves::admin {

namespace po = boost::program_options;
using ves::server::ClientOptions;

int RunCaseUpload(const CommandArgs& args) {
  std::string file, institution;
  std::vector<std::string> share_with;
  RemoteCommandLine line;
  line.Add()("file", po::value(&file)->required(), "case file (any readable format)")(
      "share-with", po::value(&share_with)->composing(), "institution allowed to download it")(
      "institution", po::value(&institution), "owner (default: the caller's)");
  line.Positional("file", 1);
  if (const int rc =
          line.Parse("case upload", "case upload FILE [--share-with I]... --server A", args);
      rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  std::string bundle;
  try {
    // Any format the case tools read; validated here first, again on the server.
    bundle = patient_db::EncodeCaseBundle(patient_db::LoadCaseFile(file));
  } catch (const patient_db::CaseError& e) {
    std::cerr << "ves-admin case upload: " << e.problems().front().ToString() << "\n";
    return kExitUsage;
  }
  auto stub = ves::v1::Cases::NewStub(ves::server::MakeClientChannel(client));
  grpc::ClientContext ctx;
  ves::server::PrepareContext(&ctx, client);
  ves::v1::UploadCaseResponse r;
  auto writer = stub->UploadCase(&ctx, &r);
  ves::v1::UploadCaseRequest part;
  auto* header = part.mutable_header();
  header->set_file_label(std::filesystem::path(file).filename().string());
  header->set_total_bytes(bundle.size());
  header->set_sha256_hex(ves::server::Sha256Hex(bundle));
  header->set_institution(institution);
  for (const auto& i : share_with) header->add_share_with(i);
  bool ok = writer->Write(part);
  constexpr size_t kChunk = 1 << 20;
  for (size_t off = 0; ok && off < bundle.size(); off += kChunk) {
    part.set_chunk(bundle.substr(off, kChunk));
    ok = writer->Write(part);
  }
  writer->WritesDone();
  auto status = writer->Finish();
  if (!status.ok()) {
    return ReportRpcError("case upload", status.error_code(), status.error_message());
  }
  // sha256= is the case's payload hash, the one `case validate`, the station
  // and lessons show; the bundle's own hash is the blob's content address.
  std::cout << (r.already_stored() ? "already stored " : "stored ") << r.summary().case_id()
            << " v" << r.summary().version() << " sha256=" << r.summary().payload_sha256_hex()
            << " (bundle " << r.summary().size_bytes() << " bytes, sha256 "
            << r.summary().sha256_hex().substr(0, 16) << "…)\n";
  // Shares are added on every upload, a repeat's too: say which hold now.
  if (r.summary().shared_with_size() > 0) {
    std::cout << "shared with";
    for (const auto& i : r.summary().shared_with()) std::cout << " " << Shown(i);
    std::cout << "\n";
  }
  return kExitOk;
}

int RunCaseList(const CommandArgs& args) {
  std::string institution;
  RemoteCommandLine line;
  line.Add()("institution", po::value(&institution), "only this owner")(
      "all-versions", "every version, not only the latest");
  if (const int rc = line.Parse("case list", "case list [--all-versions] --server A", args);
      rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  ves::v1::ListCasesRequest q;
  q.set_institution(institution);
  q.set_all_versions(line.Has("all-versions"));
  q.set_page_size(1000);
  auto stub = ves::v1::Cases::NewStub(ves::server::MakeClientChannel(client));
  return ListAllPages(
      "case list", client, *stub, &ves::v1::Cases::Stub::ListCases, q,
      [](const ves::v1::ListCasesResponse& r) {
        for (const auto& c : r.cases()) {
          // The payload hash, as `case validate` and the station print it.
          std::printf("%-24s v%-3u %-12s %-16s %10llu  %.12s  %s\n",
                      Shown(c.case_id()).c_str(), c.version(),
                      ves::v1::Difficulty_Name(c.difficulty()).c_str() + 11,
                      Shown(c.institution()).c_str(),
                      static_cast<unsigned long long>(c.size_bytes()),
                      Shown(c.payload_sha256_hex()).c_str(), Shown(c.title()).c_str());
        }
        return true;
      });
}

int RunCaseDownload(const CommandArgs& args) {
  std::string id, out;
  unsigned version = 0;
  RemoteCommandLine line;
  line.Add()("id", po::value(&id)->required(), "case id")("output,o", po::value(&out)->required(),
                                                          "where to write the .vescase")(
      "version", po::value(&version), "version (default: latest)");
  line.Positional("id", 1);
  if (const int rc =
          line.Parse("case download", "case download ID -o FILE.vescase --server A", args);
      rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  // Bytes land in FILE.part; an interrupted download resumes from there.
  const std::string partial = out + ".part";
  std::string bytes;
  if (std::filesystem::exists(partial)) bytes = patient_db::ReadFileBytes(partial);
  ves::v1::DownloadCaseRequest q;
  q.set_case_id(id);
  q.set_version(version);
  q.set_offset(bytes.size());
  grpc::ClientContext ctx;
  ves::server::PrepareContext(&ctx, client);
  auto reader =
      ves::v1::Cases::NewStub(ves::server::MakeClientChannel(client))->DownloadCase(&ctx, q);
  std::ofstream part(partial, std::ios::binary | std::ios::app);
  ves::v1::CaseChunk chunk;
  uint64_t total = 0;
  std::string sha;
  while (reader->Read(&chunk)) {
    if (!chunk.sha256_hex().empty()) {
      total = chunk.total_bytes();
      sha = chunk.sha256_hex();
    }
    part.write(chunk.data().data(), static_cast<std::streamsize>(chunk.data().size()));
    bytes += chunk.data();
  }
  part.close();
  auto status = reader->Finish();
  if (!status.ok()) {
    return ReportRpcError("case download", status.error_code(), status.error_message());
  }
  if (bytes.size() != total || ves::server::Sha256Hex(bytes) != sha) {
    std::filesystem::remove(partial);
    std::cerr << "ves-admin case download: " << id << ": received bytes do not match the "
              << "announced size " << total << " and sha256 " << sha << "; start again\n";
    return kExitFailed;
  }
  try {
    patient_db::DecodeCaseBundle(bytes, out);
  } catch (const patient_db::CaseError& e) {
    std::cerr << "ves-admin case download: " << e.problems().front().ToString() << "\n";
    return kExitFailed;
  }
  std::filesystem::rename(partial, out);
  std::cout << "wrote " << out << " (" << bytes.size() << " bytes, sha256 " << sha << ")\n";
  return kExitOk;
}

}  // namespace ves::admin
