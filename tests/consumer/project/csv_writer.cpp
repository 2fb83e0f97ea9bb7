// A downstream output format: csv/frame_N.csv, one line "x,y,z" per vertex with `digits`
// significant digits (docs/extending.md, "An output format"). Registered here, selected by
// scene.yaml's output.formats, its parameter in output.csv.
#include <ccfr/core/registry.hpp>
#include <ccfr/io/formats.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "csv_writer.hpp"

namespace {

class CsvWriter final : public ccfr::io::FrameSink {
 public:
  explicit CsvWriter(int digits) : digits_(digits) {}
  void write(const std::filesystem::path& dir, int frame, double, const ccfr::Positions& x,
             const ccfr::io::VertexFields&) override {
    std::filesystem::create_directories(dir / "csv");
    std::ofstream out(dir / "csv" / ("frame_" + std::to_string(frame) + ".csv"));
    for (const ccfr::Vec3& p : x) out << csv_line(p, digits_);
  }

 private:
  int digits_;
};

const ccfr::Registration<ccfr::io::FrameWriterRegistry> kCsv(
    ccfr::io::frame_writers(), {"csv",
                                "csv/frame_N.csv: one line x,y,z per vertex",
                                {ccfr::ParamSpec::integer("digits", 17, "significant digits", 1, 17)},
                                [](const ccfr::ParamValues& p, const ccfr::io::FrameSinkContext&) {
                                  return std::make_unique<CsvWriter>(static_cast<int>(p.integer("digits")));
                                }});

}  // namespace

std::string csv_line(const ccfr::Vec3& p, int digits) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%.*g,%.*g,%.*g\n", digits, p.x(), digits, p.y(), digits, p.z());
  return buf;
}
