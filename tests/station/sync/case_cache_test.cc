#include "station/sync/case_cache.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <set>

#include "patient_db/case_bundle.h"
#include "patient_db/case_format.h"
#include "patient_db/case_problem.h"
#include "station/sync/shipped_cases.h"

namespace ves::sync {
namespace {

std::filesystem::path FreshDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ves_case_cache_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

ves::v1::ColonCase ShippedCase(const std::string& id) {
  return patient_db::LoadCaseFile(std::filesystem::path(VES_SOURCE_DIR) / "patient_db" / "cases" /
                                  (id + ".textproto"));
}

std::string ReadBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void WriteBytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST(CaseCache, PutThenLoadGivesTheSameCaseByContentAddress) {
  CaseCache cache(FreshDir("put") / "cache");
  const auto colon_case = ShippedCase("paper-sigmoid");
  const CachedCase entry = cache.Put(colon_case);
  EXPECT_EQ(entry.sha256_hex, patient_db::CasePayloadSha256Hex(colon_case));
  EXPECT_EQ(cache.Load(entry.sha256_hex).SerializeAsString(), colon_case.SerializeAsString());
  ASSERT_TRUE(cache.FindLatest("paper-sigmoid").has_value());
  EXPECT_EQ(cache.List().size(), 1u);
  cache.Put(colon_case);  // same content: still one file
  EXPECT_EQ(cache.List().size(), 1u);
}

TEST(CaseCache, FindLatestPicksTheHighestVersion) {
  CaseCache cache(FreshDir("versions") / "cache");
  auto colon_case = ShippedCase("paper-sigmoid");
  cache.Put(colon_case);
  colon_case.set_version(colon_case.version() + 1);
  colon_case.set_title("revised");
  cache.Put(colon_case);
  EXPECT_EQ(cache.FindLatest("paper-sigmoid")->title, "revised");
  EXPECT_FALSE(cache.FindLatest("no-such-case").has_value());
}

TEST(CaseCache, ImportExportRoundTripOfABundleFile) {
  const auto dir = FreshDir("import");
  const auto colon_case = ShippedCase("standard-adult");
  WriteBytes(dir / "disc.vescase", patient_db::EncodeCaseBundle(colon_case));
  CaseCache cache(dir / "cache");
  const CachedCase entry = cache.ImportBundleFile(dir / "disc.vescase");
  EXPECT_EQ(entry.id, "standard-adult");
  cache.ExportBundleFile("standard-adult", dir / "out.vescase");
  EXPECT_EQ(ReadBytes(dir / "out.vescase"), ReadBytes(dir / "disc.vescase"));
}

TEST(CaseCache, DamagedBundleIsRefusedAtImportAndNothingIsStored) {
  const auto dir = FreshDir("damaged");
  std::string bytes = patient_db::EncodeCaseBundle(ShippedCase("paper-sigmoid"));
  bytes[bytes.size() / 2] ^= 0x5a;
  WriteBytes(dir / "damaged.vescase", bytes);
  CaseCache cache(dir / "cache");
  EXPECT_THROW(cache.ImportBundleFile(dir / "damaged.vescase"), patient_db::CaseError);
  EXPECT_TRUE(cache.List().empty());
}

TEST(CaseCache, ForeignFileIsRefusedAtImport) {
  const auto dir = FreshDir("foreign");
  WriteBytes(dir / "holiday.vescase", "\x89PNG\r\n\x1a\n not a case bundle at all");
  CaseCache cache(dir / "cache");
  try {
    cache.ImportBundleFile(dir / "holiday.vescase");
    FAIL() << "a foreign file was imported";
  } catch (const patient_db::CaseError& error) {
    EXPECT_NE(std::string(error.what()).find("holiday.vescase"), std::string::npos) << error.what();
  }
}

TEST(CaseCache, CachedFileDamagedOnDiskIsRefusedBeforeUse) {
  CaseCache cache(FreshDir("rot") / "cache");
  const CachedCase entry = cache.Put(ShippedCase("paper-sigmoid"));
  std::string bytes = ReadBytes(entry.path);
  bytes[30] ^= 0x01;
  WriteBytes(entry.path, bytes);
  EXPECT_THROW(cache.Load(entry.sha256_hex), patient_db::CaseError);
  std::vector<std::string> damaged;
  EXPECT_TRUE(cache.List(&damaged).empty());
  EXPECT_EQ(damaged.size(), 1u);
}

TEST(CaseCache, ValidBundleUnderAnotherCasesNameIsRefused) {
  CaseCache cache(FreshDir("swap") / "cache");
  const CachedCase a = cache.Put(ShippedCase("paper-sigmoid"));
  const CachedCase b = cache.Put(ShippedCase("standard-adult"));
  std::filesystem::copy_file(b.path, a.path, std::filesystem::copy_options::overwrite_existing);
  EXPECT_THROW(cache.Load(a.sha256_hex), patient_db::CaseError);
}

TEST(CaseCache, ExportOfUnknownCaseNamesIt) {
  CaseCache cache(FreshDir("unknown") / "cache");
  try {
    cache.ExportBundleFile("no-such-case", FreshDir("unknown_out") / "x.vescase");
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("no-such-case"), std::string::npos);
  }
}

// A fresh station has the shipped cases without an import step: seeding puts
// every file of patient_db/cases into an empty cache, each as it parses from
// the source tree, and a second seeding puts none.
TEST(ShippedCases, AFreshCacheGetsEveryShippedCaseOnceAsInTheSourceTree) {
  CaseCache cache(FreshDir("seed") / "cache");
  std::set<std::string> shipped_ids;
  for (const auto& file : std::filesystem::directory_iterator(std::filesystem::path(VES_SOURCE_DIR) /
                                                              "patient_db" / "cases")) {
    if (file.path().extension() == ".textproto") {
      shipped_ids.insert(patient_db::LoadCaseFile(file.path()).id());
    }
  }
  ASSERT_GE(shipped_ids.size(), 5u);
  ASSERT_EQ(ShippedCaseTexts().size(), shipped_ids.size());
  const std::vector<CachedCase> seeded = SeedShippedCases(cache);
  std::set<std::string> seeded_ids;
  for (const CachedCase& entry : seeded) seeded_ids.insert(entry.id);
  EXPECT_EQ(seeded_ids, shipped_ids);
  const auto standard = cache.FindLatest("standard-adult");
  ASSERT_TRUE(standard.has_value());
  EXPECT_EQ(cache.Load(standard->sha256_hex).SerializeAsString(),
            ShippedCase("standard-adult").SerializeAsString());
  EXPECT_TRUE(SeedShippedCases(cache).empty());
  EXPECT_EQ(cache.List().size(), shipped_ids.size());
}

// The station's own library wins: a case id already cached (here a newer
// version, as the server would send) is not joined by the shipped one.
TEST(ShippedCases, ACaseIdAlreadyCachedIsLeftAsItIs) {
  CaseCache cache(FreshDir("seed_kept") / "cache");
  ves::v1::ColonCase newer = ShippedCase("standard-adult");
  newer.set_version(7);
  newer.set_title("Standard adult colon, the hospital's revision");
  const CachedCase put = cache.Put(newer);
  const std::vector<CachedCase> seeded = SeedShippedCases(cache);
  for (const CachedCase& entry : seeded) EXPECT_NE(entry.id, "standard-adult");
  int standard_versions = 0;
  for (const CachedCase& entry : cache.List()) standard_versions += entry.id == "standard-adult";
  EXPECT_EQ(standard_versions, 1);
  EXPECT_EQ(cache.FindLatest("standard-adult")->sha256_hex, put.sha256_hex);
}

}  // namespace
}  // namespace ves::sync
