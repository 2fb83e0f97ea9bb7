// One file per built-in broad phase, named by its key (docs/extending.md, "A broad phase: one
// file"): the registry holds exactly the files of collision/src/broad_phase/, in the order of their
// names, each registering the key it is named by, and each builds a broad phase of that name.
#include <gtest/gtest.h>

#include <string>

#include "ccfr/collision/broad_phase.hpp"
#include "component_files.hpp"

TEST(BroadPhaseFiles, EveryFileUnderBroadPhaseIsTheRegisteredBroadPhaseOfItsName) {
  const auto files = ccfr::test::component_files("collision/src/broad_phase");
  ASSERT_FALSE(files.empty());
  for (const auto& f : files) {
    EXPECT_NE(f.text.find("void register_broad_phase_" + f.key + "("), std::string::npos) << f.path;
    EXPECT_NE(f.text.find("{\"" + f.key + "\""), std::string::npos) << f.path;
  }
  EXPECT_EQ(ccfr::broad_phase_names(), ccfr::test::keys_of(files));
  for (const auto& f : files) {
    const auto bp = ccfr::make_broad_phase(f.key, {});
    ASSERT_NE(bp, nullptr) << f.key;
    EXPECT_EQ(bp->name(), f.key);
  }
}
