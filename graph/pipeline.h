/// @file pipeline.h
/// @brief A validated pipeline (config resolved against the node registry) and its execution as a
/// `tbb::flow::graph`.
///
/// Building checks everything before anything runs: unknown node types (listing the registered ones),
/// params (unknown keys, types, ranges), inputs (unknown ports, unknown ids, missing required ports),
/// artefact types of every edge, and cycles. Running builds one `continue_node` per node, wired along the
/// inputs, so independent nodes run concurrently; with a cache folder, nodes whose key is cached are
/// loaded instead of run (graph/cache.h). An exception in a node cancels the graph and comes
/// back as a NodeError naming the node id and type, except in a node of a branch (config `branches`):
/// that branch is dropped, reported as `branch_error`, and the others go on.
#pragma once

#include "graph/config.h"
#include "graph/node.h"

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace polyhex {

struct ResolvedNode {
  std::string id;
  const NodeSpec* spec = nullptr;
  json params;                   ///< canonical params (every key, defaults filled)
  std::vector<int> input_nodes;  ///< per port of spec->inputs, index of the producing node or -1
  int branch = 0;                ///< NodeConfig::branch: a copy of the config's `branches`, or 0
};

/// What happened to one node in a run.
struct NodeRecord {
  std::string id, type;
  double seconds = 0;
  /// The process's resident memory when the node ended (runtime/memory.h), MiB: now and its high-water mark
  /// so far. Nodes run side by side share the process, so a node's own share is the rise it shows over the
  /// nodes that ended before it; 0 when not known (not Linux, or the node did not end).
  double rss_mb = 0, peak_rss_mb = 0;
  bool cache_hit = false;  ///< the output, metrics and warnings were loaded from the artefact cache
  bool ran = false;        ///< the node completed (computed, or loaded from the cache)
  bool skipped = false;    ///< not run: a required input came from a node that produced nothing (NodeSpec::may_skip)
  /// A node of a branch (config `branches`) that threw: its branch is dropped (its dependants are
  /// skipped) and the run goes on with the other branches; the message is here and in the report.
  std::string branch_error;
  std::string cache_key;  ///< the key its output was looked up and stored under ("" when not cached)
  json metrics = json::object();
  std::vector<std::string> warnings;
};

struct RunOptions {
  std::filesystem::path out_dir = "polyhex-out";
  bool save_all = false;  ///< also write every mesh artefact as OUT/<id>.<ext>
  int threads = 0;        ///< 0 = all cores
  /// Artefact cache folder (graph/cache.h); empty = no cache (every node runs). A node whose key is in
  /// the cache is skipped: its output, metrics and warnings are loaded. Sinks always run, and so does
  /// every node under save_all or with a true `save_*` param (they write files). A bad entry is ignored
  /// with a warning on the node, recomputed and overwritten; a failed store is a warning too.
  std::filesystem::path cache_dir;
  /// Called on node start ("start"), end ("done"), cache hit ("cached", value = seconds to load; no
  /// "start"/"done" then), skip ("skipped": a required input produced nothing) and progress ("progress");
  /// may be empty.
  std::function<void(const std::string& event, const std::string& id, const std::string& type, double value,
                     const std::string& what)>
      on_event;
};

struct RunResult {
  std::vector<NodeRecord> nodes;  ///< in config order
  double seconds = 0;
  double peak_rss_mb = 0;    ///< the process's resident high-water mark at the run's end, MiB (runtime/memory.h)
  std::string error;         ///< empty when the run succeeded
  bool interrupted = false;  ///< stopped by SIGINT/SIGTERM (error says where)
  json retry;                ///< the config's retry attempts (tools/cli_run.h); null when it has none
  /// "ok", "interrupted" or "error"
  std::string status() const { return error.empty() ? "ok" : interrupted ? "interrupted" : "error"; }
  /// report.json: {polyhex_version, status, error?, seconds, peak_rss_mb, nodes: {id: {type, ran, skipped?, seconds,
  /// rss_mb, peak_rss_mb, cache_hit, metrics, warnings}}, retry?}
  json report() const;
};

class Pipeline {
 public:
  /// \throw ConfigError naming the node and listing valid choices
  static Pipeline build(const PipelineConfig& cfg);
  const std::vector<ResolvedNode>& nodes() const { return nodes_; }
  /// Graphviz DOT of the pipeline: nodes with their type and params, edges labelled with artefact types.
  std::string dot() const;
  /// Cache key of every node (graph/cache.h, node_key) from its inputs' keys, in config order; "" for a
  /// node that cannot be cached because a file it reads cannot be read or an input cannot be cached. A run
  /// keys a node by its inputs' contents where the cache has them (NodeRecord::cache_key, graph/cache.h):
  /// the two agree for the nodes without inputs.
  std::vector<std::string> cache_keys() const;
  /// Runs the graph. Never throws for node failures: they are in RunResult::error (and the report).
  /// \throw IOError when the output folder cannot be created
  RunResult run(const RunOptions& opt) const;

 private:
  std::vector<ResolvedNode> nodes_;
  std::string source_;
};

/// Writes `report.json` into `dir` atomically.
void write_report(const RunResult& r, const std::filesystem::path& dir);

/// The nodes of a run of `p` that report inverted hexes (an `inverted` metric above 0) in the mesh the run
/// kept: its `optimize` and `quality` nodes, except those of a branch (config `branches`) other than the one
/// whose mesh the `select_hexes` node chose (its `chosen` port's producer; every branch when there is no
/// such node). polyhex run exits with 3 when there is one: a mesh a solver would reject is not a success,
/// and a branch that was not kept wrote no mesh.
std::vector<const NodeRecord*> inverted_mesh_reports(const Pipeline& p, const RunResult& r);

}  // namespace polyhex
