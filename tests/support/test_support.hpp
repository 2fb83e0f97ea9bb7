#pragma once
// Test support shared by every suite: a guard that fails any test logging an unexpected warning
// or error through spdlog, and small helpers for seeded randomness.
#include <gtest/gtest.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

namespace ccfr::test {

/// A closed-form check's measured value, printed as one line `physics|test|quantity|expected|
/// measured|unit` for scripts/physics-table (docs/results.md, "Physics under contact"), and
/// recorded as a property of the test in its XML report.
inline void report_physics(const std::string& quantity, double expected, double measured, const std::string& unit) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string test = info ? std::string(info->test_suite_name()) + "." + info->name() : std::string("?");
  std::printf("physics|%s|%s|%.6g|%.6g|%s\n", test.c_str(), quantity.c_str(), expected, measured, unit.c_str());
  ::testing::Test::RecordProperty(quantity, std::to_string(measured));
}

/// The contact solvers a closed-form test of docs/results.md's "Physics under contact" runs: the
/// region solvers, whose closed forms it asserts, then those named in CCFR_PHYSICS_COMPARE (a comma
/// list; `scripts/physics-table --compare ogc,dat`), measured for the table and held to the
/// guarantee only (no violation left): the contact response belongs to the integrator, not to one
/// method. Unset, as in the suite, only the region solvers run.
inline const std::vector<const char*>& physics_solvers() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out{"ccfr", "exact_projection"};
    const char* env = std::getenv("CCFR_PHYSICS_COMPARE");
    std::string list = env ? env : "";
    for (size_t start = 0; start < list.size();) {
      const size_t end = std::min(list.find(',', start), list.size());
      if (end > start) out.push_back(list.substr(start, end - start));
      start = end + 1;
    }
    return out;
  }();
  static const std::vector<const char*> pointers = [] {
    std::vector<const char*> out;
    for (const std::string& n : names) out.push_back(n.c_str());
    return out;
  }();
  return pointers;
}

/// Whether a closed-form test asserts its closed form under `solver` (the region solvers), rather
/// than only measuring it for the table (physics_solvers).
inline bool asserts_closed_form(const std::string& solver) { return solver == "ccfr" || solver == "exact_projection"; }

/// Least-squares acceleration of s(t) = s0 + v0 t + a t²/2 over the samples from `skip` on.
inline double fitted_acceleration(const std::vector<double>& t, const std::vector<double>& s, size_t skip = 0) {
  const Eigen::Index rows = static_cast<Eigen::Index>(t.size() - skip);
  Eigen::MatrixXd a_mat(rows, 3);
  Eigen::VectorXd b_vec(rows);
  for (Eigen::Index j = 0; j < rows; ++j) {
    const double tj = t[static_cast<size_t>(j) + skip];
    a_mat.row(j) << 1.0, tj, 0.5 * tj * tj;
    b_vec[j] = s[static_cast<size_t>(j) + skip];
  }
  return a_mat.colPivHouseholderQr().solve(b_vec)[2];
}

/// Counts warnings and errors logged through the default logger.
class CountingSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  std::atomic<int> warnings{0};
  std::string last;

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    if (msg.level >= spdlog::level::warn) {
      ++warnings;
      last.assign(msg.payload.data(), msg.payload.size());
    }
  }
  void flush_() override {}
};

inline std::shared_ptr<CountingSink>& counting_sink() {
  static std::shared_ptr<CountingSink> sink = std::make_shared<CountingSink>();
  return sink;
}

/// While alive, warnings are expected and do not fail the test.
class ExpectWarnings {
 public:
  ExpectWarnings() { depth()++; }
  ~ExpectWarnings() {
    counting_sink()->warnings = 0;
    depth()--;
  }
  static int& depth() {
    static int d = 0;
    return d;
  }
};

class WarningListener final : public ::testing::EmptyTestEventListener {
  void OnTestStart(const ::testing::TestInfo&) override { counting_sink()->warnings = 0; }
  void OnTestEnd(const ::testing::TestInfo&) override {
    if (ExpectWarnings::depth() == 0 && counting_sink()->warnings > 0)
      ADD_FAILURE() << "unexpected warning logged: " << counting_sink()->last;
  }
};

class WarningGuardEnvironment final : public ::testing::Environment {
 public:
  void SetUp() override {
    spdlog::default_logger()->sinks().push_back(counting_sink());
    ::testing::UnitTest::GetInstance()->listeners().Append(new WarningListener);
  }
};

/// A seeded generator for reproducible random tests.
inline std::mt19937_64 rng(std::uint64_t seed) { return std::mt19937_64(seed); }

}  // namespace ccfr::test
