// The case bundle (*.vescase): layout, round trip, and rejection of damaged files.
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include "patient_db/case_format.h"
#include "tests/patient_db/case_test_util.h"

namespace ves::patient_db {
namespace {

using google::protobuf::util::MessageDifferencer;
using testing::MakeValidCase;

const std::string kCasesDir = VES_SOURCE_DIR "/patient_db/cases/";

// Field of the single problem a damaged bundle must raise.
std::string RejectionField(const std::string& bytes) {
  try {
    DecodeCaseBundle(bytes, "damaged.vescase");
  } catch (const CaseError& e) {
    EXPECT_FALSE(e.problems().empty());
    EXPECT_EQ(e.problems()[0].file, "damaged.vescase");
    return e.problems()[0].field;
  }
  return "(accepted)";
}

TEST(CaseBundle, Sha256MatchesTheStandardTestVector) {
  // FIPS 180-2 example: SHA-256("abc").
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(CaseBundle, LayoutIsMagicVersionLengthPayloadHash) {
  const auto c = MakeValidCase();
  const std::string bundle = EncodeCaseBundle(c);
  const std::string payload = SerializeCaseDeterministic(c);
  ASSERT_EQ(bundle.size(), 20 + payload.size() + 32);
  EXPECT_EQ(bundle.substr(0, 8), std::string("VESCASE\0", 8));
  EXPECT_EQ(bundle.substr(8, 4), std::string("\x01\x00\x00\x00", 4));  // version 1, LE
  uint64_t length = 0;
  for (int i = 0; i < 8; ++i) {
    length |= static_cast<uint64_t>(static_cast<unsigned char>(bundle[12 + i])) << (8 * i);
  }
  EXPECT_EQ(length, payload.size());
  EXPECT_EQ(bundle.substr(20, payload.size()), payload);
  std::string hex;
  for (unsigned char byte : bundle.substr(20 + payload.size())) {
    static constexpr char kDigits[] = "0123456789abcdef";
    hex += kDigits[byte >> 4];
    hex += kDigits[byte & 0xf];
  }
  EXPECT_EQ(hex, CasePayloadSha256Hex(c));
}

TEST(CaseBundle, EncodingIsDeterministic) {
  const auto c = LoadCaseFile(kCasesDir + "standard-adult.textproto");
  EXPECT_EQ(EncodeCaseBundle(c), EncodeCaseBundle(LoadCaseFile(kCasesDir + "standard-adult.textproto")));
}

TEST(CaseBundle, TextprotoToBundleToTextprotoKeepsTheMeaning) {
  for (const char* name : {"paper-sigmoid", "standard-adult", "redundant-sigmoid", "fixed-tube"}) {
    const auto original = LoadCaseFile(kCasesDir + name + ".textproto");
    const auto decoded = DecodeCaseBundle(EncodeCaseBundle(original), name);
    const auto reparsed = ParseCaseTextproto(FormatCaseTextproto(decoded), name);
    std::string diff;
    MessageDifferencer differencer;
    differencer.ReportDifferencesToString(&diff);
    EXPECT_TRUE(differencer.Compare(original, reparsed)) << name << ": " << diff;
    EXPECT_EQ(CasePayloadSha256Hex(reparsed), CasePayloadSha256Hex(original)) << name;
  }
}

TEST(CaseBundle, EveryFlippedByteIsRejected) {
  const std::string bundle = EncodeCaseBundle(MakeValidCase());
  const size_t payload_end = bundle.size() - 32;
  for (size_t i = 0; i < bundle.size(); ++i) {
    std::string damaged = bundle;
    damaged[i] = static_cast<char>(damaged[i] ^ 0x01);
    const std::string field = RejectionField(damaged);
    if (i < 8) {
      EXPECT_EQ(field, "bundle.magic") << "byte " << i;
    } else if (i < 12) {
      EXPECT_EQ(field, "bundle.format_version") << "byte " << i;
    } else if (i < 20) {
      // A changed length: truncated, trailing bytes or over the size limit.
      EXPECT_TRUE(field == "bundle" || field == "bundle.payload_length") << "byte " << i << field;
    } else {
      EXPECT_EQ(field, "bundle.sha256") << "byte " << i << (i < payload_end ? " (payload)" : "");
    }
  }
}

TEST(CaseBundle, FlippedPayloadByteOfAShippedCaseIsRejected) {
  std::string bundle = EncodeCaseBundle(LoadCaseFile(kCasesDir + "redundant-sigmoid.textproto"));
  bundle[bundle.size() / 2] = static_cast<char>(bundle[bundle.size() / 2] ^ 0x80);
  EXPECT_EQ(RejectionField(bundle), "bundle.sha256");
}

TEST(CaseBundle, EveryTruncationIsRejected) {
  const std::string bundle = EncodeCaseBundle(MakeValidCase());
  for (size_t size = 0; size < bundle.size(); ++size) {
    const std::string field = RejectionField(bundle.substr(0, size));
    EXPECT_EQ(field, "bundle") << "truncated to " << size << " bytes";
  }
}

TEST(CaseBundle, TrailingBytesRejected) {
  EXPECT_EQ(RejectionField(EncodeCaseBundle(MakeValidCase()) + "x"), "bundle");
}

TEST(CaseBundle, UnsupportedVersionNamed) {
  std::string bundle = EncodeCaseBundle(MakeValidCase());
  bundle[8] = 2;
  try {
    DecodeCaseBundle(bundle, "v2.vescase");
    FAIL() << "version 2 accepted";
  } catch (const CaseError& e) {
    EXPECT_EQ(e.problems()[0].field, "bundle.format_version");
    EXPECT_EQ(e.problems()[0].value, "2");
  }
}

TEST(CaseBundle, IntactBundleOfAnInvalidCaseIsRejected) {
  auto c = MakeValidCase();
  c.set_version(0);
  EXPECT_EQ(RejectionField(EncodeCaseBundle(c)), "version");
}

TEST(CaseBundle, PayloadThatIsNotAColonCaseIsRejected) {
  // A correctly hashed payload of garbage: an unterminated length-delimited field.
  const std::string payload = "\x0a\x7f";
  std::string bundle(kCaseBundleMagic);
  bundle += std::string("\x01\x00\x00\x00", 4);
  bundle += std::string("\x02\x00\x00\x00\x00\x00\x00\x00", 8);
  bundle += payload;
  const std::string hex = Sha256Hex(payload);
  for (size_t i = 0; i < hex.size(); i += 2) {
    bundle += static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16));
  }
  EXPECT_EQ(RejectionField(bundle), "bundle.payload");
}

}  // namespace
}  // namespace ves::patient_db
