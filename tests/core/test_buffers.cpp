// resize_for_overwrite and fill_parallel: sizes, values and capacity against what std::vector
// alone would give, at growths within and past the capacity, and at zero.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "ccfr/core/buffers.hpp"

namespace ccfr {
namespace {

TEST(Buffers, ResizeForOverwriteGivesExactlyNElementsAndHeadroomOnGrowth) {
  std::vector<int> v;
  resize_for_overwrite(v, 1000);
  ASSERT_EQ(v.size(), 1000u);
  EXPECT_GE(v.capacity(), 1250u);  // a quarter of headroom: the next slow growth stays in place
  for (int i = 0; i < 1000; ++i) v[static_cast<size_t>(i)] = i;
  const int* data = v.data();
  resize_for_overwrite(v, 1200);  // within the capacity: no reallocation, the prefix untouched
  EXPECT_EQ(v.size(), 1200u);
  EXPECT_EQ(v.data(), data);
  EXPECT_EQ(v[999], 999);
  resize_for_overwrite(v, 10);
  EXPECT_EQ(v.size(), 10u);
  resize_for_overwrite(v, 0);
  EXPECT_TRUE(v.empty());
  resize_for_overwrite(v, 5000);  // past the capacity
  EXPECT_EQ(v.size(), 5000u);
  EXPECT_GE(v.capacity(), 6250u);
}

TEST(Buffers, ResizeWithASpareKeepsALargeBufferConstructedThroughSmallRequests) {
  // A first pass of 100,000, held-back passes of 10 and 0, the next first pass of 90,000: the
  // large buffer comes back unreallocated with its old elements in place, where a shrink and a
  // regrowth would value-initialise them (zeros). A request of at least an eighth shrinks in place.
  std::vector<int> v, spare;
  resize_for_overwrite(v, 100000, spare);
  for (size_t i = 0; i < v.size(); ++i) v[i] = static_cast<int>(i) + 1;
  const int* large = v.data();
  resize_for_overwrite(v, 10, spare);
  EXPECT_EQ(v.size(), 10u);
  EXPECT_NE(v.data(), large);
  EXPECT_EQ(spare.size(), 100000u);
  resize_for_overwrite(v, 0, spare);
  EXPECT_TRUE(v.empty());
  EXPECT_EQ(spare.data(), large);
  resize_for_overwrite(v, 90000, spare);
  ASSERT_EQ(v.size(), 90000u);
  EXPECT_EQ(v.data(), large);
  EXPECT_EQ(v[89999], 90000) << "the kept elements were initialised again";
  EXPECT_LE(spare.size(), 10u);
  resize_for_overwrite(v, 20000, spare);  // 20,000 >= 90,000 / 8: in place
  EXPECT_EQ(v.data(), large);
  EXPECT_EQ(v.size(), 20000u);
  resize_for_overwrite(v, 200000, spare);  // past the capacity: a new buffer of the asked size
  EXPECT_EQ(v.size(), 200000u);
  EXPECT_LE(spare.size(), 10u);
}

TEST(Buffers, FillParallelWritesEveryElementAtEverySize) {
  std::vector<double> v;
  for (const Index n : {Index{0}, Index{1}, Index{7}, Index{100000}, Index{33}, Index{300000}}) {
    fill_parallel(v, n, 1.5);
    ASSERT_EQ(v.size(), static_cast<size_t>(n));
    Index wrong = 0;
    for (const double x : v) wrong += x != 1.5;
    EXPECT_EQ(wrong, 0) << n;
    for (double& x : v) x = -2.0;  // the next fill must overwrite these
  }
  std::vector<std::uint8_t> flags(10, 7);
  fill_parallel(flags, 70000, std::uint8_t{0});
  EXPECT_EQ(flags, std::vector<std::uint8_t>(70000, 0));
}

}  // namespace
}  // namespace ccfr
