// The shipped curriculum (patient_db/curricula/x-ray-free.textproto) is well
// formed and pins the shipped cases by their current payload hashes, so an
// edit of a case cannot silently change what a lesson runs.
#include <google/protobuf/text_format.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "patient_db/case_format.h"
#include "server/lesson_rules.h"

namespace ves::server {
namespace {

ves::v1::Curriculum ReadShippedCurriculum() {
  std::ifstream in(VES_SOURCE_DIR "/patient_db/curricula/x-ray-free.textproto");
  std::stringstream text;
  text << in.rdbuf();
  ves::v1::Curriculum c;
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text.str(), &c));
  return c;
}

TEST(ShippedCurriculum, IsWellFormed) {
  const ves::v1::Curriculum c = ReadShippedCurriculum();
  EXPECT_EQ(CheckCurriculum(c), "");
  ASSERT_GE(c.lessons_size(), 2);
  // From paper-sigmoid with both aids to redundant-sigmoid with neither.
  const auto& first = c.lessons(0);
  EXPECT_EQ(first.case_ref().case_id(), "paper-sigmoid");
  EXPECT_TRUE(first.aids().fluoroscopy_allowed());
  EXPECT_TRUE(first.aids().wireframe_allowed());
  const auto& last = c.lessons(c.lessons_size() - 1);
  EXPECT_EQ(last.case_ref().case_id(), "redundant-sigmoid");
  EXPECT_FALSE(last.aids().fluoroscopy_allowed());
  EXPECT_FALSE(last.aids().wireframe_allowed());
}

TEST(ShippedCurriculum, PinsTheShippedCasesByTheirPayloadHash) {
  const ves::v1::Curriculum curriculum = ReadShippedCurriculum();
  for (const auto& lesson : curriculum.lessons()) {
    const std::string file =
        VES_SOURCE_DIR "/patient_db/cases/" + lesson.case_ref().case_id() + ".textproto";
    // The hash the server stores for an upload of that file (CasePayloadSha256Hex).
    const std::string sha = patient_db::CasePayloadSha256Hex(patient_db::LoadCaseFile(file));
    EXPECT_EQ(lesson.case_ref().payload_sha256_hex(), sha)
        << lesson.lesson_id() << ": " << file << " changed; update the curriculum's hash";
  }
}

}  // namespace
}  // namespace ves::server
