// The narrow phase's wave-wise concatenation (collision/src/contact_waves.hpp) against a serial
// concatenation of the same chunks.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "ccfr/core/parallel.hpp"
#include "contact_waves.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {
/// Chunk c's contacts for pass `pass`: a count in [0, most] (many chunks empty), each record
/// naming its chunk, its position and the pass, so that any misplaced record shows.
std::vector<ContactPair> chunk_contacts(int pass, Index c, Index most) {
  auto rng = ccfr::test::rng(static_cast<std::uint64_t>(1000 * pass + c));
  std::uniform_int_distribution<Index> count(-most / 2, most);
  std::vector<ContactPair> out(static_cast<size_t>(std::max<Index>(0, count(rng))));
  for (size_t i = 0; i < out.size(); ++i) {
    out[i].v = {c, static_cast<Index>(i), pass, -1};
    out[i].distance = 0.001 * static_cast<double>(i + 1);
  }
  return out;
}
}  // namespace

TEST(ContactWaves, ConcatenateChunksInOrderForAnyThreadCountAndAcrossGrowingAndShrinkingPasses) {
  // Passes of 0 to 1,000 chunks of up to 300 contacts each, the list growing past its capacity and
  // shrinking again between passes: each pass's list is exactly the serial concatenation, at 1
  // and 2 threads (waves of 32 and 64 chunks).
  detail::ContactWaves waves;
  std::vector<ContactPair> contacts;
  const Index chunk_counts[] = {5, 1000, 0, 37, 1000, 64, 65, 1};
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    int pass = 0;
    for (Index chunks : chunk_counts) {
      ++pass;
      const Index most = pass % 2 ? 300 : 40;
      std::vector<ContactPair> expect;
      for (Index c = 0; c < chunks; ++c) {
        const auto part = chunk_contacts(pass, c, most);
        expect.insert(expect.end(), part.begin(), part.end());
      }
      waves.collect(
          chunks,
          [&](Index c, std::vector<ContactPair>& out) {
            ASSERT_TRUE(out.empty()) << "chunk " << c << " was handed a used buffer";
            const auto part = chunk_contacts(pass, c, most);
            out.insert(out.end(), part.begin(), part.end());
          },
          contacts);
      ASSERT_EQ(contacts.size(), expect.size()) << "pass " << pass << ", " << threads << " threads";
      for (size_t i = 0; i < expect.size(); ++i) {
        ASSERT_EQ(contacts[i].v, expect[i].v) << "contact " << i << ", pass " << pass;
        ASSERT_EQ(contacts[i].distance, expect[i].distance) << "contact " << i << ", pass " << pass;
      }
    }
  }
  set_thread_count(0);
}

TEST(ContactWaves, SizeAListGrownFromEmptyOnceFromTheFirstWaveAndStayExactWhenTheEstimateIsWrong) {
  // Uniform chunks: the first wave's density extrapolates to the exact pass, so the empty list is
  // allocated once, to the pass plus an eighth (growth wave by wave would end at a quarter over
  // the last wave's need). Skewed passes (first wave empty, or the only full one) still come out
  // exact.
  set_thread_count(1);
  const Index chunks = 1000, per_chunk = 50;
  detail::ContactWaves waves;
  std::vector<ContactPair> contacts;
  const auto fill_uniform = [&](Index c, std::vector<ContactPair>& out) {
    out.resize(static_cast<size_t>(per_chunk));
    for (Index i = 0; i < per_chunk; ++i) out[static_cast<size_t>(i)].v = {c, i, 0, -1};
  };
  waves.collect(chunks, fill_uniform, contacts);
  const size_t n = static_cast<size_t>(chunks * per_chunk);
  ASSERT_EQ(contacts.size(), n);
  EXPECT_EQ(contacts.capacity(), n + n / 8);
  EXPECT_EQ(contacts.back().v[0], chunks - 1);

  const Index wave = detail::ContactWaves::kChunksPerThread;
  for (const bool first_wave_only : {false, true}) {
    std::vector<ContactPair> skewed;
    const auto full = [&](Index c) { return first_wave_only ? c < wave : c >= wave; };
    waves.collect(
        chunks,
        [&](Index c, std::vector<ContactPair>& out) {
          if (full(c)) fill_uniform(c, out);
        },
        skewed);
    const Index full_chunks = first_wave_only ? wave : chunks - wave;
    ASSERT_EQ(skewed.size(), static_cast<size_t>(full_chunks * per_chunk));
    const Index first = first_wave_only ? 0 : wave;
    for (size_t i = 0; i < skewed.size(); ++i) {
      const Index k = static_cast<Index>(i);
      ASSERT_EQ(skewed[i].v[0], first + k / per_chunk) << "contact " << i;
      ASSERT_EQ(skewed[i].v[1], k % per_chunk) << "contact " << i;
    }
  }
  set_thread_count(0);
}

TEST(ContactWaves, GrowAListAtTheFirstWaveWhereNothingIsKeptAndRarelyForASlowlyGrowingCount) {
  // A pass that outgrows the list is sized when its first wave is in, where the old list holds
  // nothing that must be kept: freed first, it is never resident beside the new one. Growing after
  // that wave (when the list is full) would copy the kept contacts with both lists resident. A
  // count that grows 2 % a pass reallocates only when it passes a quarter over the last size.
  set_thread_count(1);
  const Index chunks = 1000, wave = detail::ContactWaves::kChunksPerThread;
  detail::ContactWaves waves;
  std::vector<ContactPair> contacts;
  Index per_chunk = 50;
  size_t capacity_in_second_wave = 0;
  const auto fill = [&](Index c, std::vector<ContactPair>& out) {
    if (c == wave) capacity_in_second_wave = contacts.capacity();
    out.resize(static_cast<size_t>(per_chunk));
    for (Index i = 0; i < per_chunk; ++i) out[static_cast<size_t>(i)].v = {c, i, per_chunk, -1};
  };
  const auto check_exact = [&] {
    ASSERT_EQ(contacts.size(), static_cast<size_t>(chunks * per_chunk));
    for (size_t i = 0; i < contacts.size(); ++i) {
      const Index k = static_cast<Index>(i);
      ASSERT_EQ(contacts[i].v, (std::array<Index, 4>{k / per_chunk, k % per_chunk, per_chunk, -1})) << "contact " << i;
    }
  };
  waves.collect(chunks, fill, contacts);
  check_exact();
  ASSERT_EQ(contacts.capacity(), 56250u);  // 50,000 and an eighth

  per_chunk = 100;  // twice the list: sized at the first wave to 100,000 and an eighth
  waves.collect(chunks, fill, contacts);
  check_exact();
  EXPECT_EQ(contacts.capacity(), 112500u);
  EXPECT_EQ(capacity_in_second_wave, 112500u) << "the list grew after its first wave";

  int reallocations = 0;
  for (per_chunk = 102; per_chunk <= 140; per_chunk += 2) {
    const size_t before = contacts.capacity();
    waves.collect(chunks, fill, contacts);
    check_exact();
    EXPECT_EQ(capacity_in_second_wave, contacts.capacity()) << per_chunk << " a chunk: grown after the first wave";
    reallocations += contacts.capacity() != before;
  }
  // 112,500 -> 140,625 at 102 a chunk (a quarter more) -> 175,781 at 126: 2 of 20 passes.
  EXPECT_EQ(reallocations, 2);
  set_thread_count(0);
}

TEST(ContactWaves, KeepALargeListWholeThroughSmallPassesAndWriteTheNextLargePassIntoIt) {
  // A substep's first pass finds every contact, its held-back passes a few: a small pass puts the
  // large list aside whole and hands out a copy, so the next large pass reuses the same buffer
  // and records (no reallocation, no value-initialisation of the list again). Results stay exact;
  // a pass at least an eighth of the list shrinks it in place as before.
  set_thread_count(2);
  const Index chunks = 1000;
  detail::ContactWaves waves;
  std::vector<ContactPair> contacts;
  Index per_chunk = 0;
  const auto fill = [&](Index c, std::vector<ContactPair>& out) {
    out.resize(static_cast<size_t>(per_chunk));
    for (Index i = 0; i < per_chunk; ++i) out[static_cast<size_t>(i)].v = {c, i, per_chunk, -1};
  };
  const auto collect_exact = [&](Index n) {
    per_chunk = n;
    waves.collect(chunks, fill, contacts);
    ASSERT_EQ(contacts.size(), static_cast<size_t>(chunks * per_chunk));
    for (size_t i = 0; i < contacts.size(); ++i) {
      const Index k = static_cast<Index>(i);
      ASSERT_EQ(contacts[i].v, (std::array<Index, 4>{k / per_chunk, k % per_chunk, per_chunk, -1})) << "contact " << i;
    }
  };
  collect_exact(40);  // 40,000
  const ContactPair* large = contacts.data();
  EXPECT_EQ(waves.spare_size(), 0u);
  collect_exact(4);  // 4,000 < 40,000 / 8: the list is put aside whole
  EXPECT_EQ(waves.spare_size(), 40000u);
  EXPECT_NE(contacts.data(), large);
  collect_exact(1);
  EXPECT_EQ(waves.spare_size(), 40000u);
  collect_exact(36);  // the large list comes back
  EXPECT_EQ(contacts.data(), large);
  EXPECT_EQ(waves.spare_size(), 0u);
  collect_exact(5);  // 5,000 = 36,000 / 7.2: shrunk in place
  EXPECT_EQ(contacts.data(), large);
  EXPECT_EQ(waves.spare_size(), 0u);
  collect_exact(0);  // empty: the 5,000 records put aside (the shrink in place gave up the rest)
  EXPECT_EQ(waves.spare_size(), 5000u);
  collect_exact(60);  // outgrows the kept list's capacity: a new list, exact
  EXPECT_EQ(waves.spare_size(), 0u);
  set_thread_count(0);
}
