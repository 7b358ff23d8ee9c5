// TLS: certificates are made by openssl at run time in a temp dir. Refused:
// no client certificate, a certificate from another CA, plaintext to a TLS
// port; accepted: a client certificate from the configured CA.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "tests/integration/test_server.h"

namespace ves::server::testing {
namespace {

using patient_db::StoreRole;

class Tls : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::filesystem::path(MakeTempDir("tls"));
    std::ofstream(*dir_ / "san.ext") << "subjectAltName=DNS:localhost,IP:127.0.0.1\n";
    const std::string d = dir_->string();
    // EC keys: quick to generate. Two CAs; the server and one client signed by
    // "ca", a rogue client signed by "other".
    const std::string script =
        "set -e; cd '" + d + "'; exec >openssl.log 2>&1\n"
        "for ca in ca other; do\n"
        "  openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes "
        "-keyout $ca.key -out $ca.pem -days 2 -subj /CN=$ca-test-ca\n"
        "done\n"
        "sign() { openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes "
        "-keyout $1.key -out $1.csr -subj /CN=$3\n"
        "  openssl x509 -req -in $1.csr -CA $2.pem -CAkey $2.key -CAcreateserial -out $1.pem "
        "-days 2 -extfile san.ext; }\n"
        "sign server ca localhost\nsign client ca station\nsign rogue other rogue\n";
    ASSERT_EQ(std::system(("bash -c \"$(cat <<'EOS'\n" + script + "EOS\n)\"").c_str()), 0)
        << "openssl failed, see " << d << "/openssl.log";
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(*dir_);
    delete dir_;
  }
  static std::string File(const std::string& name) { return (*dir_ / name).string(); }

  void SetUp() override {
    ServerOptions o;
    o.tls_cert_file = File("server.pem");
    o.tls_key_file = File("server.key");
    o.tls_client_ca_file = File("ca.pem");
    server_ = std::make_unique<TestServer>(o);
    token_ = server_->MakeToken(StoreRole::kStation, "north");
  }
  grpc::StatusCode ListCases(const ClientOptions& o) {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, o);
    ves::v1::ListCasesResponse r;
    return ves::v1::Cases::NewStub(MakeClientChannel(o))->ListCases(&ctx, {}, &r).error_code();
  }
  ClientOptions Client(const std::string& cert) {
    ClientOptions o = server_->Client(token_);
    o.deadline = std::chrono::seconds(5);
    o.tls_ca_file = File("ca.pem");
    if (!cert.empty()) {
      o.tls_cert_file = File(cert + ".pem");
      o.tls_key_file = File(cert + ".key");
    }
    return o;
  }

  static std::filesystem::path* dir_;
  std::unique_ptr<TestServer> server_;
  std::string token_;
};
std::filesystem::path* Tls::dir_ = nullptr;

TEST_F(Tls, ClientCertificateFromTheConfiguredCaIsAccepted) {
  EXPECT_EQ(ListCases(Client("client")), grpc::StatusCode::OK);
}

TEST_F(Tls, MissingClientCertificateIsRefused) {
  EXPECT_EQ(ListCases(Client("")), grpc::StatusCode::UNAVAILABLE);
}

TEST_F(Tls, ClientCertificateFromAnotherCaIsRefused) {
  EXPECT_EQ(ListCases(Client("rogue")), grpc::StatusCode::UNAVAILABLE);
}

TEST_F(Tls, PlaintextClientWithValidTokenIsRefused) {
  ClientOptions plain = server_->Client(token_);
  plain.deadline = std::chrono::seconds(5);
  EXPECT_EQ(ListCases(plain), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(ListCases(Client("client")), grpc::StatusCode::OK);  // still serving
}

TEST(ServerCredentials, PlaintextIsRefusedUnlessAskedForOnLoopback) {
  ServerOptions o;
  o.listen = "127.0.0.1:50051";
  EXPECT_THROW(MakeServerCredentials(o), std::invalid_argument);  // no TLS, no flag
  o.insecure_loopback = true;
  EXPECT_NO_THROW(MakeServerCredentials(o));
  o.listen = "0.0.0.0:50051";
  EXPECT_THROW(MakeServerCredentials(o), std::invalid_argument);
  o.listen = "10.1.2.3:50051";
  EXPECT_THROW(MakeServerCredentials(o), std::invalid_argument);
  o.listen = "[::1]:50051";
  EXPECT_NO_THROW(MakeServerCredentials(o));
}

TEST(ServerCredentials, CertificateWithoutKeyIsRefused) {
  ServerOptions o;
  o.tls_cert_file = "/nonexistent/server.pem";
  EXPECT_THROW(MakeServerCredentials(o), std::invalid_argument);
  o.tls_key_file = "/nonexistent/server.key";
  EXPECT_THROW(MakeServerCredentials(o), std::invalid_argument);  // unreadable
}

// A key that is not the certificate's: one line saying so, not "address in
// use" when gRPC later fails to listen (issue #20).
TEST_F(Tls, AKeyThatIsNotTheCertificatesIsNamed) {
  ServerOptions o;
  o.tls_cert_file = File("server.pem");
  o.tls_key_file = File("client.key");
  try {
    MakeServerCredentials(o);
    ADD_FAILURE() << "accepted a mismatched key";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "--tls-key " + File("client.key") +
                                         " is not the key of --tls-cert " + File("server.pem"));
  }
  o.tls_key_file = File("san.ext");  // not a key at all
  EXPECT_THROW(MakeServerCredentials(o), std::invalid_argument);
}

}  // namespace
}  // namespace ves::server::testing
