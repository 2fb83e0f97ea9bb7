// Output formats are the frame writers of one registry (docs/extending.md, "An output format"): one
// file per built-in under io/formats/src/frame_writers/, named by its key. (A writer registered
// from outside: tests/apps/test_frame_writers.cpp, a suite of its own since the registration
// stays for the rest of the process.)
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ccfr/io/formats.hpp"
#include "component_files.hpp"

using namespace ccfr;

TEST(FrameWriterFiles, EveryFileUnderFrameWritersIsTheRegisteredWriterOfItsName) {
  const auto files = test::component_files("io/formats/src/frame_writers");
  ASSERT_FALSE(files.empty());
  for (const auto& f : files) {
    EXPECT_NE(f.text.find("void register_frame_writer_" + f.key + "("), std::string::npos) << f.path;
    EXPECT_NE(f.text.find("\"" + f.key + "\""), std::string::npos) << f.path;
  }
  EXPECT_EQ(io::frame_writer_names(), test::keys_of(files));
  const Topology empty;
  for (const auto& f : files) EXPECT_NE(io::make_frame_sink(f.key, io::FrameSinkContext{empty}), nullptr) << f.key;
}
