// Shared main for every test executable: fails a test that logs an unexpected warning
// (MuJoCo-style), unless the test opts in with ccfr::test::ExpectWarnings.
#include <gtest/gtest.h>

#include "test_support.hpp"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::AddGlobalTestEnvironment(new ccfr::test::WarningGuardEnvironment);
  return RUN_ALL_TESTS();
}
