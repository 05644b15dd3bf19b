/// @file cli_run.h
/// @brief Shared plumbing of the `polyhex run` and `polyhex bench` commands: load a config with
/// `${input}` and `--set` overrides, build the pipeline, run it with terminal progress; and the config's
/// `retry` block, which `polyhex run` follows.
///
/// ## The `retry` key of a config
///
///     "retry": {"node": "quality", "max_inverted": 0, "min_sj": 0.3,
///               "variants": [{"polycube.level_placement": "push_up"}]}
///
/// A run is accepted when node `node` reports `inverted` <= max_inverted and `sj_min` >= min_sj. When
/// the first run is not, or failed because every orientation branch failed (a node of a branch threw; a
/// run that fails before the branches, on a bad input, is reported as it is), the variants run one after
/// the other (each: the config with its `"<id>.<param>": value` pairs set, into OUT/.retry-<k>, sharing the artefact
/// cache so that only the nodes downstream of a changed param run again; with --no-cache a temporary cache
/// OUT/.retry-cache serves the attempts and is removed), until one is accepted. The best attempt is kept: fewest
/// inverted hexes, then the highest minimum scaled Jacobian (the first attempt wins a tie); its files are moved into
/// OUT and report.json is its report with `retry`: {node, max_inverted, min_sj, chosen (0 = the config as given),
/// attempts:
/// [{set, status, inverted, sj_min, seconds, accepted}]}; `seconds` is the time of all attempts.
/// Why: the hex stage's outcome (the optimizer's minimum, whether a fold can be untangled) is sensitive to
/// small changes of the map, so two equally sound variants of a stage each fail on some models where the
/// other succeeds; trying the second only where the first falls short costs nothing where it does not.
/// `on_failure` (optional): more variants, tried after `variants` only while no attempt has made a mesh
/// (every one failed in all its orientation branches): the default configs run more frames there
/// (`orient.within`), which would otherwise trade a frame's average for another's minimum.
/// Every variant is checked (ids, params, ranges) before anything runs. `polyhex sweep` follows the block
/// in every case (the variants set on top of the case's values); `polyhex bench` ignores it (it times one
/// pipeline).
#pragma once

#include "graph/pipeline.h"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace polyhex {

struct RunRequest {
  std::filesystem::path config;
  std::string input;              ///< value of ${input}; empty = the config's default
  std::vector<std::string> sets;  ///< id.param=value overrides
  /// --hex-edge: the config var `hex_edge` (the hex edge as a fraction of the reference length, which
  /// the default configs' other sizes follow), set before `sets`; 0 = the config's own
  double hex_edge = 0;
  std::filesystem::path out_dir = "polyhex-out";
  int threads = 0;
  bool save_all = false;
  std::filesystem::path cache_dir;  ///< artefact cache; empty = default_cache_dir(out_dir) (.polyhex-cache beside it)
  bool no_cache = false;            ///< --no-cache: run every node, read and write no cache (benchmarks)
  int verbosity = 0;                ///< 0 = progress on a terminal only, 1 = -v, 2 = -vv
};

/// The parsed `retry` block of a config, with every variant's pipeline built.
struct RetryPlan {
  std::string node;            ///< the node whose metrics judge a run
  double max_inverted = 0;     ///< accepted when inverted <= this ...
  double min_sj = 0;           ///< ... and sj_min >= this
  std::vector<json> variants;  ///< per variant its {"<id>.<param>": value} object: `variants`, then `on_failure`
  size_t regular = 0;          ///< how many of them are `variants` (the rest run only while no attempt made a mesh)
  std::vector<Pipeline> pipelines;  ///< per variant the pipeline it runs
};

/// The `retry` block of `config` (none when it has none), checked against `pipeline` (built from the
/// same config): keys, the judging node's id, ranges, and every variant's pipeline.
/// \throw ConfigError naming `source` and the key (`retry.variants[k]: node ...`)
std::optional<RetryPlan> retry_plan(const json& config, const Pipeline& pipeline, const std::string& source);

/// Loads, substitutes, overrides and validates. With `retry`, also the config's retry block (--set
/// applies to the variants too; a variant's own values win). \throw ConfigError
Pipeline load_pipeline(const RunRequest& req, std::optional<RetryPlan>* retry = nullptr);

/// Runs the pipeline, shows its progress on stderr (runtime/progress.h: a bar on a terminal, lines with -v),
/// writes report.json into the output folder. Uses the artefact cache unless req.no_cache.
RunResult run_pipeline(const Pipeline& p, const RunRequest& req);

/// run_pipeline, then the retry block's variants while the best attempt is not accepted (above).
/// \throw ConfigError when the judging node does not report `inverted` and `sj_min`
/// \throw IOError when an attempt's files cannot be moved into the output folder
RunResult run_with_retry(const Pipeline& p, const std::optional<RetryPlan>& retry, const RunRequest& req);

}  // namespace polyhex
