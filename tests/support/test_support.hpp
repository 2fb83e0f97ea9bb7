#pragma once
// Test support shared by every suite: a guard that fails any test logging an unexpected warning
// or error through spdlog, and small helpers for seeded randomness.
#include <gtest/gtest.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cstdio>
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
