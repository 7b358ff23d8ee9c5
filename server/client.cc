#include "server/client.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include "patient_db/net_address.h"

namespace ves::server {
namespace {

std::string ReadFile(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(what + " " + path + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  if (!in || text.str().empty()) {
    throw std::invalid_argument(what + " " + path + ": cannot read the file (or it is empty)");
  }
  return text.str();
}

}  // namespace

void CheckClientOptions(const ClientOptions& o) {
  if (o.tls_ca_file.empty()) {
    if (!o.tls_cert_file.empty() || !o.tls_key_file.empty()) {
      throw std::invalid_argument("--tls-cert and --tls-key need --tls-ca");
    }
    if (!patient_db::IsLoopbackAddress(o.address)) {
      throw std::invalid_argument("refusing to send the token in plaintext to '" + o.address +
                                  "': give --tls-ca (plaintext only to a loopback address "
                                  "such as 127.0.0.1:50051)");
    }
  }
  if (o.tls_cert_file.empty() != o.tls_key_file.empty()) {
    throw std::invalid_argument("--tls-cert and --tls-key go together");
  }
  if (!o.tls_ca_file.empty()) ReadFile(o.tls_ca_file, "--tls-ca");
  if (!o.tls_cert_file.empty()) ReadFile(o.tls_cert_file, "--tls-cert");
  if (!o.tls_key_file.empty()) ReadFile(o.tls_key_file, "--tls-key");
  if (o.deadline <= std::chrono::milliseconds(0) || o.deadline > std::chrono::hours(1)) {
    throw std::invalid_argument("deadline " + std::to_string(o.deadline.count()) +
                                " ms: must be in (0, 3600 s]");
  }
}

std::shared_ptr<grpc::Channel> MakeClientChannel(const ClientOptions& o) {
  CheckClientOptions(o);
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  args.SetMaxSendMessageSize(64 << 20);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 60000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  if (!o.tls_target_name.empty()) {
    args.SetSslTargetNameOverride(o.tls_target_name);
  }
  std::shared_ptr<grpc::ChannelCredentials> credentials;
  if (o.tls_ca_file.empty()) {
    credentials = grpc::InsecureChannelCredentials();
  } else {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = ReadFile(o.tls_ca_file, "--tls-ca");
    if (!o.tls_cert_file.empty()) ssl.pem_cert_chain = ReadFile(o.tls_cert_file, "--tls-cert");
    if (!o.tls_key_file.empty()) ssl.pem_private_key = ReadFile(o.tls_key_file, "--tls-key");
    credentials = grpc::SslCredentials(ssl);
  }
  return grpc::CreateCustomChannel(o.address, credentials, args);
}

void PrepareContext(grpc::ClientContext* context, const ClientOptions& o) {
  context->set_deadline(std::chrono::system_clock::now() + o.deadline);
  if (!o.token.empty()) context->AddMetadata("authorization", "Bearer " + o.token);
}

}  // namespace ves::server
