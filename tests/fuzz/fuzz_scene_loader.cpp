// libFuzzer target: YAML scene text -> ccfr::io::load_scene_text (the parser behind `ccfr run`).
// Leading "#set key.path=value" lines (YAML comments) are also passed as --set overrides.
// Relative mesh paths resolve from configs/ (configs/stress/ when the text says "../meshes/"),
// so the seed scenes load their meshes.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "ccfr/io/scene_loader.hpp"
#include "fuzz_support.hpp"

namespace fs = std::filesystem;

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  ccfr::fuzz::quiet();
  // In-range scenes may legitimately need gigabytes; the loader's memory check must refuse them
  // under the fuzzer's 2 GB RSS limit (ASan roughly doubles the footprint), not the machine's.
  ::setenv("CCFR_MEMORY_LIMIT_MB", "128", 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> overrides;
  for (size_t pos = 0; text.compare(pos, 5, "#set ") == 0;) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) nl = text.size();
    overrides.push_back(text.substr(pos + 5, nl - pos - 5));
    pos = nl < text.size() ? nl + 1 : nl;
  }
  const fs::path configs = fs::path(CCFR_SOURCE_DIR) / "configs";
  const fs::path base = text.find("../meshes/") != std::string::npos ? configs / "stress" : configs;
  ccfr::fuzz::expect_ccfr_error("load_scene_text",
                                [&] { (void)ccfr::io::load_scene_text(text, "fuzz.yaml", base, overrides); });
  return 0;
}
