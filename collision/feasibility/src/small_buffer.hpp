#pragma once
// A fixed-capacity inline array that spills to the heap for large sizes: per-vertex scratch
// without an allocation in the common case. Its elements start uninitialised (every user writes
// before it reads): zero-filling them was measured at a tenth of Plesník's cost on the soft-wire
// pile, whose projected vertices hold ~150 planes each.
#include <cstddef>
#include <memory>
#include <type_traits>

namespace ccfr {

template <class T, std::size_t N = 256>
class SmallBuffer {
  static_assert(std::is_trivial_v<T>, "SmallBuffer leaves its elements uninitialised");

 public:
  explicit SmallBuffer(std::size_t n) : size_(n) {
    if (n > N) heap_ = std::make_unique_for_overwrite<T[]>(n);
  }
  SmallBuffer(const SmallBuffer&) = delete;
  SmallBuffer& operator=(const SmallBuffer&) = delete;
  T* begin() { return heap_ ? heap_.get() : inline_; }
  T* end() { return begin() + size_; }
  const T* begin() const { return heap_ ? heap_.get() : inline_; }
  const T* end() const { return begin() + size_; }
  T& operator[](std::size_t i) { return begin()[i]; }
  const T& operator[](std::size_t i) const { return begin()[i]; }
  std::size_t size() const { return size_; }

 private:
  std::size_t size_;
  std::unique_ptr<T[]> heap_;
  T inline_[N];
};

}  // namespace ccfr
