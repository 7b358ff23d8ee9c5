// The storage contract suite (store_contract_test.cc, the same tests, not a
// copy) instantiated for PostgreSQL. The fixture lives in an anonymous
// namespace there, so this file compiles that source once more with its SQLite
// instantiation and SQLite-only tests switched off (they run in
// store_contract_test) and adds the PostgreSQL parameter. Once the suite's own
// INSTANTIATE_TEST_SUITE_P lists Backend{"postgres", OpenPostgresTestStore},
// this file can go.
// Skipped with kNoPostgresMessage unless VES_TEST_POSTGRES_URL is set
// (deploy/with-postgres.sh sets it).
#include <gtest/gtest.h>

#include "tests/patient_db/pg_test_util.h"

#pragma push_macro("INSTANTIATE_TEST_SUITE_P")
#pragma push_macro("TEST")
#undef INSTANTIATE_TEST_SUITE_P
#undef TEST
#define INSTANTIATE_TEST_SUITE_P(...) static_assert(true, "the SQLite instantiation")
#define TEST(suite, name) [[maybe_unused]] static void suite##_##name##_RunsInStoreContractTest()
#include "tests/patient_db/store_contract_test.cc"
#pragma pop_macro("TEST")
#pragma pop_macro("INSTANTIATE_TEST_SUITE_P")

namespace ves::patient_db {
namespace {

INSTANTIATE_TEST_SUITE_P(
    Postgres, StoreContract,
    ::testing::Values(Backend{"postgres", &pg_testing::OpenPostgresTestStore}),
    [](const ::testing::TestParamInfo<Backend>& info) { return info.param.name; });

}  // namespace
}  // namespace ves::patient_db
