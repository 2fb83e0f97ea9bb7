// ccfr::format and ccfr::log (core/log.hpp): the library's own logging interface, with spdlog and
// fmt private to core. Expected strings are written out by hand (printf's %g rules, C++ literals).
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

TEST(Format, NumbersStringsAndSpecsAsPrintfWouldWriteThem) {
  EXPECT_EQ(format("{} of {}", 3, 7), "3 of 7");
  EXPECT_EQ(format("{:.4g}", 3.14159265), "3.142");          // printf("%.4g")
  EXPECT_EQ(format("{:.17g}", 0.1), "0.10000000000000001");  // printf("%.17g")
  EXPECT_EQ(format("{:g}", 1e-7), "1e-07");                  // printf("%g")
  EXPECT_EQ(format("{:.1f} MB", 39.19236862), "39.2 MB");
  EXPECT_EQ(format("{:.6f}", 0.5), "0.500000");
  EXPECT_EQ(format("{}", 0.25), "0.25");  // shortest round trip
  // A float keeps its own shortest form (as a double it would print 0.10000000149011612).
  EXPECT_EQ(format("{}", 0.1f), "0.1");
  EXPECT_EQ(format("{:>5}|{:<4}|", 42, "ab"), "   42|ab  |");
  EXPECT_EQ(format("'{}' ({}{})", std::string("cloth"), "shell", std::string_view(", scripted")),
            "'cloth' (shell, scripted)");
  EXPECT_EQ(format("{} {} {}", true, 'x', static_cast<unsigned char>(200)), "true x 200");
  EXPECT_EQ(format("{}", std::numeric_limits<std::int64_t>::min()), "-9223372036854775808");
  EXPECT_EQ(format("{}", std::numeric_limits<std::uint64_t>::max()), "18446744073709551615");
  EXPECT_EQ(format("{1}-{0}", "a", "b"), "b-a");
  EXPECT_EQ(format("{{}} literal"), "{} literal");
  EXPECT_EQ(format("no fields"), "no fields");
  EXPECT_EQ(format("{}", ""), "");
}

TEST(Format, FieldCountIsCheckedAtCompileTime) {
  // The consteval count behind FormatString: a mismatch does not compile (not testable at run
  // time), so the count itself is checked here on the cases it must get right.
  static_assert(detail::format_arguments_needed("") == 0);
  static_assert(detail::format_arguments_needed("{{}}") == 0);
  static_assert(detail::format_arguments_needed("{} {:.3g} {:>8}") == 3);
  static_assert(detail::format_arguments_needed("{1} {0}") == 2);
  static_assert(detail::format_arguments_needed("{2}") == 3);
  static_assert(detail::format_arguments_needed("}} {} {{") == 1);
  SUCCEED();
}

TEST(Format, AFieldThatDoesNotFitItsArgumentIsAnErrorNamingTheString) {
  try {
    (void)format("{:d}", "text");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("{:d}"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)format("{:.3q}", 1.0), Error);
  EXPECT_THROW((void)format("{:", 1), Error);
}

TEST(Log, WritesThroughTheDefaultLoggerAtItsLevel) {
  test::ExpectWarnings expect;
  auto& sink = *test::counting_sink();
  init_logging("warn");
  EXPECT_FALSE(log::enabled(log::Level::info));
  EXPECT_TRUE(log::enabled(log::Level::warn));
  EXPECT_FALSE(log::enabled(log::Level::off));

  sink.warnings = 0;
  log::info("not written: {}", 1);
  log::debug("not written either");
  EXPECT_EQ(sink.warnings, 0);
  log::warn("object '{}': {} degenerate rest tets", "slab", 3);
  EXPECT_EQ(sink.warnings, 1);
  EXPECT_EQ(sink.last, "object 'slab': 3 degenerate rest tets");
  log::error("frame {}: {:.3g} m", 12, 0.0123456);
  EXPECT_EQ(sink.warnings, 2);
  EXPECT_EQ(sink.last, "frame 12: 0.0123 m");
  log::write(log::Level::warn, "{} taken as it is");  // no formatting of a finished message
  EXPECT_EQ(sink.last, "{} taken as it is");

  // A field that does not fit its argument must not stop a run from a log line: the format string
  // is written with a note instead of throwing.
  EXPECT_NO_THROW(log::warn("{:d} vertices", "many"));
  EXPECT_EQ(sink.warnings, 4);
  EXPECT_EQ(sink.last.rfind("{:d} vertices [not formatted: ", 0), 0u) << sink.last;

  init_logging("off");
  log::error("not written at off");
  EXPECT_EQ(sink.warnings, 4);
  init_logging("info");  // spdlog's own default, which the other tests of this binary run with
}

}  // namespace
}  // namespace ccfr
