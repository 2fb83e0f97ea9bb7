#pragma once
// Aggregates of per-frame statistics (mean, median, max) for `ccfr ablate` and `ccfr bench`.
#include <algorithm>
#include <functional>
#include <vector>

#include "ccfr/solvers/simulation.hpp"

namespace ccfr::app {

struct Aggregate {
  double mean = 0, median = 0, max = 0, sum = 0;
};

inline Aggregate aggregate(const std::vector<FrameStats>& frames, const std::function<double(const FrameStats&)>& get) {
  Aggregate a;
  if (frames.empty()) return a;
  std::vector<double> v;
  v.reserve(frames.size());
  for (const auto& f : frames) v.push_back(get(f));
  for (double x : v) a.sum += x;
  a.mean = a.sum / static_cast<double>(v.size());
  a.max = *std::max_element(v.begin(), v.end());
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  a.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  return a;
}

}  // namespace ccfr::app
