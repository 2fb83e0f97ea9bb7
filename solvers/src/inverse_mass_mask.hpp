#pragma once
// InverseMassMask: the vertices time.continuation: held_back fixes for one outer iteration.
#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

namespace ccfr {

/// For one outer iteration under time.continuation: held_back: sets the inverse mass of every
/// vertex not marked to 0 (kept in `saved`), and restores all of them when the pass ends, also by
/// an exception. Does nothing for empty marks.
class InverseMassMask {
 public:
  InverseMassMask(std::vector<double>& inv_mass, std::vector<double>& saved, std::span<const std::uint8_t> marks)
      : inv_mass_(marks.empty() ? nullptr : &inv_mass), saved_(saved) {
    if (!inv_mass_) return;
    saved_ = inv_mass;
    for (size_t i = 0; i < inv_mass.size(); ++i)
      if (!marks[i]) inv_mass[i] = 0.0;
  }
  ~InverseMassMask() {
    if (inv_mass_) std::copy(saved_.begin(), saved_.end(), inv_mass_->begin());
  }
  InverseMassMask(const InverseMassMask&) = delete;
  InverseMassMask& operator=(const InverseMassMask&) = delete;
  bool active() const { return inv_mass_ != nullptr; }

 private:
  std::vector<double>* inv_mass_;
  std::vector<double>& saved_;
};

}  // namespace ccfr
