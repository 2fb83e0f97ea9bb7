#pragma once
// A sweep directory and its DIR/sweep.json (the cells and how they run), written by `ccfr sweep`
// and `ccfr ablate` and read back by every sweep subcommand. docs/cluster.md.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ccfr/io/sweep_spec.hpp"

namespace ccfr::app {

/// Sweeps (`ccfr sweep`, `ccfr ablate`): cells of scene × solver × parameter values, each one run
/// directory DIR/<cell id>. What the cells are (the SPEC.yaml parser and the expansion) is
/// ccfr/io/sweep_spec.hpp.
struct SweepLayout {
  std::filesystem::path dir;
  std::vector<io::SweepCell> cells;
  std::vector<std::string> parameter_keys;
  int audit_stride = 1;
  io::SweepResources resources;
  std::filesystem::path spec;      ///< empty for ablate
  double cell_time_limit_s = 0.0;  ///< spec cell_time_limit; 0: none
};

/// Writes DIR/sweep.json (the cells and how to run them) and creates DIR/logs.
void write_sweep(const SweepLayout& s);
/// Reads DIR/sweep.json back; throws ccfr::Error if DIR is not a sweep.
SweepLayout read_sweep(const std::filesystem::path& dir);
/// The JSON document in `p`; null when the file is missing or is not JSON.
nlohmann::ordered_json read_json(const std::filesystem::path& p);

}  // namespace ccfr::app
