// The built-in component files of a registry folder (docs/extending.md: a contact solver or a broad
// phase is one file named by its key), read for the tests that check the registry against them.
#pragma once

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace ccfr::test {

struct ComponentFile {
  std::string key;             ///< the file's stem: the component's YAML key
  std::filesystem::path path;  ///< the file
  std::string text;            ///< its contents
};

/// Every `.cpp` of `CCFR_SOURCE_DIR/relative_folder`, sorted by key (the registries' order).
inline std::vector<ComponentFile> component_files(const std::filesystem::path& relative_folder) {
  std::vector<ComponentFile> files;
  for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(CCFR_SOURCE_DIR) / relative_folder)) {
    if (e.path().extension() != ".cpp") continue;
    std::ifstream in(e.path());
    std::stringstream text;
    text << in.rdbuf();
    files.push_back({e.path().stem().string(), e.path(), text.str()});
  }
  std::sort(files.begin(), files.end(), [](const ComponentFile& a, const ComponentFile& b) { return a.key < b.key; });
  return files;
}

/// The keys of `files`, in their order.
inline std::vector<std::string> keys_of(const std::vector<ComponentFile>& files) {
  std::vector<std::string> keys;
  for (const ComponentFile& f : files) keys.push_back(f.key);
  return keys;
}

}  // namespace ccfr::test
