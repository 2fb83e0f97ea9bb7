#pragma once
// A fixed-capacity inline array that spills to the heap for large sizes: per-vertex scratch
// without an allocation in the common case (a vertex rarely has more than a few dozen planes).
#include <array>
#include <cstddef>
#include <vector>

namespace ccfr {

template <class T, std::size_t N = 64>
class SmallBuffer {
 public:
  explicit SmallBuffer(std::size_t n) : size_(n) {
    if (n > N) heap_.resize(n);
  }
  T* begin() { return size_ > N ? heap_.data() : inline_.data(); }
  T* end() { return begin() + size_; }
  const T* begin() const { return size_ > N ? heap_.data() : inline_.data(); }
  const T* end() const { return begin() + size_; }
  T& operator[](std::size_t i) { return begin()[i]; }
  const T& operator[](std::size_t i) const { return begin()[i]; }
  std::size_t size() const { return size_; }

 private:
  std::size_t size_;
  std::array<T, N> inline_{};
  std::vector<T> heap_;
};

}  // namespace ccfr
