// One file per built-in contact solver, named by its key (docs/extending.md, "A contact solver
// inside ccfr: one file"): the registry holds exactly the files of solvers/src/contact/, in the
// order of their names, each registering the key it is named by.
#include <gtest/gtest.h>

#include <string>

#include "ccfr/solvers/contact_solver.hpp"
#include "component_files.hpp"

TEST(SolverFiles, EveryFileUnderContactIsTheRegisteredSolverOfItsName) {
  const auto files = ccfr::test::component_files("solvers/src/contact");
  ASSERT_FALSE(files.empty());
  for (const auto& f : files) {
    // The file defines its registration function and registers its own key (directly or through
    // region_projection_entry).
    EXPECT_NE(f.text.find("void register_contact_solver_" + f.key + "("), std::string::npos) << f.path;
    EXPECT_NE(f.text.find("\"" + f.key + "\""), std::string::npos) << f.path;
  }
  EXPECT_EQ(ccfr::registered_contact_solvers(), ccfr::test::keys_of(files));
  for (const auto& f : files) EXPECT_NE(ccfr::make_contact_solver(f.key, {}), nullptr) << f.key;
}
