/// @file cli_run.h
/// @brief Shared plumbing of the `polyhex run` and `polyhex bench` commands: load a config with
/// `${input}` and `--set` overrides, build the pipeline, run it with terminal progress.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "graph/pipeline.h"

namespace polyhex {

struct RunRequest {
  std::filesystem::path config;
  std::string input;                 ///< value of ${input}; empty = the config's default
  std::vector<std::string> sets;     ///< id.param=value overrides
  std::filesystem::path out_dir = "polyhex-out";
  int threads = 0;
  bool save_all = false;
  std::filesystem::path cache_dir;   ///< artefact cache; empty = default_cache_dir(out_dir) (.polyhex-cache beside it)
  bool no_cache = false;             ///< --no-cache: run every node, read and write no cache (benchmarks)
  int verbosity = 0;                 ///< 0 = progress on a terminal only, 1 = -v, 2 = -vv
};

/// Loads, substitutes, overrides and validates. \throw ConfigError
Pipeline load_pipeline(const RunRequest& req);

/// Runs the pipeline, prints progress to stderr when stderr is a terminal (or verbosity > 0),
/// writes report.json into the output folder. Uses the artefact cache unless req.no_cache.
RunResult run_pipeline(const Pipeline& p, const RunRequest& req);

}  // namespace polyhex
