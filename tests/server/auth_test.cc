// Tokens, authentication and the access rules, without gRPC.
#include "server/auth.h"

#include "patient_db/net_address.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <unistd.h>

namespace ves::server {
namespace {

using patient_db::StoreRole;

TEST(Token, Is256RandomBitsInHex) {
  std::set<std::string> seen;
  for (int i = 0; i < 100; ++i) {
    const std::string t = NewToken();
    ASSERT_EQ(t.size(), 64u);
    EXPECT_EQ(t.find_first_not_of("0123456789abcdef"), std::string::npos);
    seen.insert(t);
  }
  EXPECT_EQ(seen.size(), 100u);
}

TEST(Token, HashIsSha256) {
  // SHA-256("abc"), FIPS 180-2 appendix B.1.
  EXPECT_EQ(Sha256Hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(TokenIdOf(Sha256Hex("abc")), "ba7816bf8f01");
}

class AuthenticatorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = std::filesystem::temp_directory_path() /
            ("ves_auth_" + std::to_string(::getpid()) + ".db");
    std::filesystem::remove(path_);
    store_ = patient_db::OpenStore("sqlite:" + path_.string());
    store_->AddInstitution("north", 1);
    token_ = NewToken();
    ASSERT_TRUE(
        store_->AddToken({Sha256Hex(token_), StoreRole::kSupervisor, "north", "", "dr", 1}).ok());
  }
  void TearDown() override {
    store_.reset();
    std::filesystem::remove(path_);
    std::filesystem::remove(path_.string() + "-wal");
    std::filesystem::remove(path_.string() + "-shm");
  }
  std::filesystem::path path_;
  std::unique_ptr<patient_db::Store> store_;
  std::string token_;
};

TEST_F(AuthenticatorTest, BearerTokenResolvesToItsPrincipal) {
  Authenticator auth(store_.get());
  Principal p;
  ASSERT_TRUE(auth.Authenticate("Bearer " + token_, &p).ok());
  EXPECT_EQ(p.role, StoreRole::kSupervisor);
  EXPECT_EQ(p.institution, "north");
  EXPECT_EQ(p.token_id, TokenIdOf(Sha256Hex(token_)));
  ASSERT_TRUE(auth.Authenticate("Bearer " + token_, &p).ok());  // from the cache
}

TEST_F(AuthenticatorTest, MissingMalformedOrUnknownTokenIsUnauthenticated) {
  Authenticator auth(store_.get());
  Principal p;
  EXPECT_EQ(auth.Authenticate("", &p).code, AuthCode::kUnauthenticated);
  EXPECT_EQ(auth.Authenticate(token_, &p).code, AuthCode::kUnauthenticated);  // no "Bearer "
  EXPECT_EQ(auth.Authenticate("Bearer " + NewToken(), &p).code, AuthCode::kUnauthenticated);
  // The stored hash itself is not a token.
  EXPECT_EQ(auth.Authenticate("Bearer " + Sha256Hex(token_), &p).code,
            AuthCode::kUnauthenticated);
}

TEST(AccessRules, RolesAndInstitutions) {
  const Principal admin{StoreRole::kAdmin, "north", "", "a", ""};
  const Principal sup{StoreRole::kSupervisor, "north", "", "s", ""};
  const Principal trainee{StoreRole::kTrainee, "north", "t1", "t", ""};
  const Principal station{StoreRole::kStation, "north", "", "x", ""};
  EXPECT_TRUE(RequireRole(admin, {StoreRole::kAdmin}, "x").ok());
  EXPECT_EQ(RequireRole(sup, {StoreRole::kAdmin}, "x").code, AuthCode::kPermissionDenied);
  EXPECT_TRUE(RequireInstitution(admin, "south", "x").ok());  // admins reach every institution
  EXPECT_EQ(RequireInstitution(sup, "south", "x").code, AuthCode::kPermissionDenied);
  const patient_db::TraineeRow t1{"t1", "north", "", 0}, t2{"t2", "north", "", 0},
      t3{"t3", "south", "", 0};
  EXPECT_TRUE(RequireTraineeReader(sup, t2, "x").ok());
  EXPECT_FALSE(RequireTraineeReader(sup, t3, "x").ok());
  EXPECT_TRUE(RequireTraineeReader(trainee, t1, "x").ok());
  EXPECT_FALSE(RequireTraineeReader(trainee, t2, "x").ok());
  EXPECT_FALSE(RequireTraineeReader(station, t1, "x").ok());
  EXPECT_TRUE(RequireTraineeReader(admin, t3, "x").ok());
}

TEST(Loopback, OnlyLoopbackAddressesQualify) {
  EXPECT_TRUE(patient_db::IsLoopbackAddress("127.0.0.1:50051"));
  EXPECT_TRUE(patient_db::IsLoopbackAddress("127.1.2.3:0"));
  EXPECT_TRUE(patient_db::IsLoopbackAddress("localhost:50051"));
  EXPECT_TRUE(patient_db::IsLoopbackAddress("[::1]:50051"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("0.0.0.0:50051"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("[::]:50051"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("10.0.0.1:50051"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("127.0.0.1.evil.com:50051"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("127.0.0.1"));  // no port
  EXPECT_TRUE(patient_db::IsLoopbackAddress("ipv4:127.0.0.1:50051"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("127.0.0.1:"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("127.0.0.1:80x"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("127.0.0.1111:80"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("127..0.1:80"));
  EXPECT_FALSE(patient_db::IsLoopbackAddress("ves.example.org:50051"));
}

}  // namespace
}  // namespace ves::server
