// scripts/slurm-local's usage and its answers where no cluster runs (tests/cluster/slurm_walkthrough.sh
// starts and stops a real one as root): bad input exits 2 naming it, stop / env / status of a
// directory without a cluster say so, and no command creates the state directory but start.
#include <gtest/gtest.h>
#include <signal.h>

#include <cstdio>

#include <filesystem>
#include <string>

#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace {

ccfr::test::CliResult slurm_local(const fs::path& dir, const std::string& args) {
  return ccfr::test::run_shell("env CCFR_SLURM_DIR='" + dir.string() + "' '" + std::string(CCFR_SOURCE_DIR) +
                               "/scripts/slurm-local' " + args + " 2>&1");
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

// Each test has its own CCFR_SLURM_DIR: ctest -j runs them at once, and each removes its directory
// and checks whether one was created.
TEST(SlurmLocal, BadUsageExits2NamingIt) {
  const fs::path dir = ccfr::test::scratch_path("slurm_local_bad_usage");
  fs::remove_all(dir);
  auto r = slurm_local(dir, "frobnicate");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "unknown command 'frobnicate'")) << r.out;
  EXPECT_TRUE(has(r.out, "usage: scripts/slurm-local")) << r.out;
  r = slurm_local(dir, "");
  EXPECT_EQ(r.code, 2) << r.out;
  for (const char* cpus : {"0", "-1", "two", "1.5"}) {
    r = slurm_local(dir, std::string("start --cpus ") + cpus);
    EXPECT_EQ(r.code, 2) << cpus << ": " << r.out;
    EXPECT_TRUE(has(r.out, std::string("--cpus '") + cpus + "' is not a positive whole number")) << r.out;
  }
  r = slurm_local(dir, "start --nodes 2");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r.out, "unknown argument to start: '--nodes'")) << r.out;
  r = slurm_local(dir, "wait soon");
  EXPECT_EQ(r.code, 2) << r.out;
  r = slurm_local(dir, "--dir '' status");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_FALSE(fs::exists(dir));
}

TEST(SlurmLocal, WithoutAClusterStopIsANoOpAndTheOthersSaySo) {
  const fs::path dir = ccfr::test::scratch_path("slurm_local_no_cluster");
  fs::remove_all(dir);
  auto r = slurm_local(dir, "stop");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "nothing to stop: no cluster in " + dir.string())) << r.out;
  r = slurm_local(dir, "env");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "no cluster runs in " + dir.string())) << r.out;
  EXPECT_FALSE(has(r.out, "export SLURM_CONF")) << r.out;
  r = slurm_local(dir, "status");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "no cluster in " + dir.string())) << r.out;
  r = slurm_local(dir, "wait 1");
  EXPECT_EQ(r.code, 1) << r.out;
  // A directory whose daemons are gone (pid files of no live process): status says it is down.
  fs::create_directories(dir / "munge");
  ccfr::test::run_shell("echo 999999999 > '" + (dir / "slurmctld.pid").string() + "'");
  r = slurm_local(dir, "status");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "slurmctld: not running")) << r.out;
  EXPECT_TRUE(has(r.out, "is down")) << r.out;
  r = slurm_local(dir, "stop");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(fs::exists(dir));
  // A stale pid file whose pid now belongs to another program: not the daemon, never killed.
  FILE* other = popen("sleep 30 & echo $!", "r");
  ASSERT_NE(other, nullptr);
  long pid = 0;
  ASSERT_EQ(fscanf(other, "%ld", &pid), 1);
  pclose(other);
  fs::create_directories(dir / "munge");
  for (const char* f : {"slurmctld.pid", "slurmd.pid", "munge/pid"})
    ccfr::test::run_shell("echo " + std::to_string(pid) + " > '" + (dir / f).string() + "'");
  r = slurm_local(dir, "stop");
  EXPECT_EQ(r.code, 0) << r.out;
  // Alive, not a zombie (an orphan's parent here may not reap it).
  const std::string stat = ccfr::test::read_text("/proc/" + std::to_string(pid) + "/stat");
  const size_t paren = stat.rfind(')');
  ASSERT_NE(paren, std::string::npos) << "stop killed an unrelated process";
  EXPECT_NE(stat.substr(paren + 2, 1), "Z") << "stop killed an unrelated process";
  kill(static_cast<pid_t>(pid), SIGKILL);
}
