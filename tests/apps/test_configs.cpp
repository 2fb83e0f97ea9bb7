// Every scene under configs/ runs a few frames under its own solver and is certified clean by
// the audit: the paper's experiments in short form (long runs belong to `ccfr bench`).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>
#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace {
int run(const std::string& args, std::string& out) {
  const ccfr::test::CliResult r = ccfr::test::run_ccfr(args);
  out += r.out;
  return r.code;
}

std::vector<fs::path> configs() {
  std::vector<fs::path> v;
  for (const auto& e : fs::directory_iterator(fs::path(CCFR_SOURCE_DIR) / "configs"))
    if (e.path().extension() == ".yaml") v.push_back(e.path());
  std::sort(v.begin(), v.end());
  return v;
}
}  // namespace

class ConfigRun : public ::testing::TestWithParam<fs::path> {};

TEST_P(ConfigRun, ShortRunIsAuditClean) {
  const fs::path cfg = GetParam();
  const fs::path out = ccfr::test::scratch_path("config_" + cfg.stem().string());
  std::string log;
  ASSERT_EQ(run("run " + cfg.string() + " --frames 2 --out " + out.string() + " --log-level warn", log), 0) << log;
  std::string audit;
  EXPECT_EQ(run("audit " + out.string(), audit), 0) << audit;
  fs::remove_all(out);
}

INSTANTIATE_TEST_SUITE_P(Configs, ConfigRun, ::testing::ValuesIn(configs()),
                         [](const ::testing::TestParamInfo<fs::path>& info) {
                           std::string n = info.param.stem().string();
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

namespace {
std::vector<fs::path> benchmarks() {
  std::vector<fs::path> v;
  for (const auto& e : fs::directory_iterator(fs::path(CCFR_SOURCE_DIR) / "configs" / "benchmarks"))
    if (e.path().extension() == ".yaml") v.push_back(e.path());
  std::sort(v.begin(), v.end());
  return v;
}
}  // namespace

// The benchmark scenes are too long for the suite; each must still load, pass the initial checks
// and write its frame 0 (the memory limit raised: the 50 layers are estimated at 19 GB).
class BenchmarkLoad : public ::testing::TestWithParam<fs::path> {};

TEST_P(BenchmarkLoad, LoadsAndWritesFrameZero) {
  const fs::path cfg = GetParam();
  const fs::path out = ccfr::test::scratch_path("benchmark_" + cfg.stem().string());
  std::string log;
  ASSERT_EQ(run("run " + cfg.string() + " --frames 0 --max-memory 64 --out " + out.string() + " --log-level warn", log),
            0)
      << log;
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_00000.obj"));
  fs::remove_all(out);
}

INSTANTIATE_TEST_SUITE_P(Benchmarks, BenchmarkLoad, ::testing::ValuesIn(benchmarks()),
                         [](const ::testing::TestParamInfo<fs::path>& info) {
                           std::string n = info.param.stem().string();
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });
