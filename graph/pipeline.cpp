#include "graph/pipeline.h"

#include "graph/cache.h"
#include "runtime/atomic_file.h"
#include "runtime/memory.h"
#include "runtime/stopwatch.h"

#include <oneapi/tbb/flow_graph.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <sstream>

namespace polyhex {

namespace {

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

std::string port_list(const NodeSpec& spec) {
  std::vector<std::string> names;
  for (auto& p : spec.inputs) names.push_back(p.name + " (" + p.artefact_type + (p.optional ? ", optional)" : ")"));
  return names.empty() ? "(none)" : join(names);
}

// A node whose params ask it to write files into the output folder (`save_*` flags) must run to
// write them; so must every node under --save-all.
bool writes_side_files(const ResolvedNode& n, bool save_all) {
  if (save_all) return true;
  for (auto it = n.params.begin(); it != n.params.end(); ++it)
    if (it.key().rfind("save_", 0) == 0 && it.value().is_boolean() && it.value().get<bool>()) return true;
  return false;
}

/// Where --save-all writes node `id`'s artefact: OUT/<id><ext>, or OUT/<id>.node<ext> when a node of the
/// graph names that file in its `path` param (a writer's output, e.g. node `hex` and `write` -> hex.vtk,
/// or a reader's input), so a saved artefact never replaces a file the config asks for.
std::filesystem::path save_all_path(const std::vector<ResolvedNode>& nodes, const std::string& id,
                                    const std::string& ext, const std::filesystem::path& out_dir) {
  namespace fs = std::filesystem;
  const fs::path plain = (out_dir / (id + ext)).lexically_normal();
  for (const auto& n : nodes) {
    const auto it = n.params.find("path");
    if (it == n.params.end() || !it->is_string()) continue;
    const fs::path p = it->get<std::string>();
    if ((out_dir / p).lexically_normal() == plain || p.lexically_normal() == plain)
      return out_dir / (id + ".node" + ext);
  }
  return out_dir / (id + ext);
}

}  // namespace

std::vector<std::string> Pipeline::cache_keys() const {
  std::vector<std::string> keys(nodes_.size());
  std::vector<int> state(nodes_.size(), 0);  // 0 = todo, 1 = done (the graph is acyclic)
  std::function<void(size_t)> visit = [&](size_t i) {
    if (state[i]) return;
    state[i] = 1;
    const ResolvedNode& n = nodes_[i];
    std::vector<std::string> in;
    bool uncacheable_input = false;
    for (int u : n.input_nodes) {
      if (u >= 0) {
        visit(size_t(u));
        uncacheable_input = uncacheable_input || keys[u].empty();
      }
      in.push_back(u >= 0 ? keys[u] : std::string());
    }
    if (uncacheable_input) return;
    try {
      keys[i] = node_key(*n.spec, n.params, in);
    } catch (const std::exception&) {
      // an unreadable input file: the node runs (and reports the error itself), nothing below is cached
    }
  };
  for (size_t i = 0; i < nodes_.size(); ++i) visit(i);
  return keys;
}

Pipeline Pipeline::build(const PipelineConfig& cfg) {
  Pipeline p;
  p.source_ = cfg.source;
  const Registry& reg = Registry::instance();
  std::map<std::string, int> index;
  for (size_t i = 0; i < cfg.nodes.size(); ++i) index[cfg.nodes[i].id] = int(i);

  for (const NodeConfig& nc : cfg.nodes) {
    const std::string where = cfg.source + ": node `" + nc.id + "` (`" + nc.type + "`)";
    const NodeSpec* spec = reg.find(nc.type);
    if (!spec)
      throw ConfigError(where + ": unknown node type `" + nc.type + "`; registered types: " + join(reg.types()));
    ResolvedNode rn;
    rn.id = nc.id;
    rn.branch = nc.branch;
    rn.spec = spec;
    rn.params = spec->check_params(nc.params, cfg.source + ": node `" + nc.id + "` (`" + spec->type + "`)");
    rn.input_nodes.assign(spec->inputs.size(), -1);
    auto bind = [&](size_t port, const std::string& from) {
      auto it = index.find(from);
      if (it == index.end())
        throw ConfigError(where + ": input `" + spec->inputs[port].name + "` names unknown node `" + from + "`");
      rn.input_nodes[port] = it->second;
    };
    if (nc.inputs.is_array()) {
      if (nc.inputs.size() > spec->inputs.size())
        throw ConfigError(where + ": " + std::to_string(nc.inputs.size()) +
                          " inputs given, ports: " + port_list(*spec));
      for (size_t k = 0; k < nc.inputs.size(); ++k) bind(k, nc.inputs[k].get<std::string>());
    } else {
      for (auto it = nc.inputs.begin(); it != nc.inputs.end(); ++it) {
        size_t port = spec->inputs.size();
        for (size_t k = 0; k < spec->inputs.size(); ++k)
          if (spec->inputs[k].name == it.key()) port = k;
        if (port == spec->inputs.size())
          throw ConfigError(where + ": unknown input port `" + it.key() + "`; ports: " + port_list(*spec));
        bind(port, it.value().get<std::string>());
      }
    }
    for (size_t k = 0; k < spec->inputs.size(); ++k) {
      const PortSpec& port = spec->inputs[k];
      if (rn.input_nodes[k] < 0) {
        if (!port.optional)
          throw ConfigError(where + ": required input `" + port.name + "` (" + port.artefact_type +
                            ") is not connected");
        continue;
      }
      const NodeConfig& from = cfg.nodes[rn.input_nodes[k]];
      const NodeSpec* fs = reg.find(from.type);
      if (!fs) continue;  // reported when that node is resolved
      if (fs->output != port.artefact_type)
        throw ConfigError(where + ": input `" + port.name + "` expects " + port.artefact_type + " but node `" +
                          from.id + "` (`" + fs->type + "`) produces " +
                          (fs->output.empty() ? std::string("nothing") : fs->output));
    }
    p.nodes_.push_back(std::move(rn));
  }
  // Cycle check: depth-first search with colours.
  std::vector<int> colour(p.nodes_.size(), 0);
  std::vector<int> stack;
  std::function<void(int)> visit = [&](int v) {
    colour[v] = 1;
    stack.push_back(v);
    for (int u : p.nodes_[v].input_nodes) {
      if (u < 0) continue;
      if (colour[u] == 1) {
        std::string cyc;
        auto it = std::find(stack.begin(), stack.end(), u);
        for (; it != stack.end(); ++it) cyc += "`" + p.nodes_[*it].id + "` <- ";
        throw ConfigError(cfg.source + ": node `" + p.nodes_[u].id + "`: the inputs form a cycle: " + cyc + "`" +
                          p.nodes_[u].id + "`");
      }
      if (colour[u] == 0) visit(u);
    }
    stack.pop_back();
    colour[v] = 2;
  };
  for (size_t v = 0; v < p.nodes_.size(); ++v)
    if (colour[v] == 0) visit(int(v));
  return p;
}

std::string Pipeline::dot() const {
  std::ostringstream s;
  s << "digraph polyhex {\n  rankdir=LR;\n  node [shape=box, fontname=\"Helvetica\"];\n";
  for (const ResolvedNode& n : nodes_) {
    std::string label = n.id + "\\n" + n.spec->type;
    for (auto it = n.params.begin(); it != n.params.end(); ++it) {
      std::string v = it.value().dump();
      for (auto& c : v)
        if (c == '"') c = '\'';
      label += "\\n" + it.key() + "=" + v;
    }
    s << "  \"" << n.id << "\" [label=\"" << label << "\"];\n";
  }
  for (const ResolvedNode& n : nodes_)
    for (size_t k = 0; k < n.input_nodes.size(); ++k)
      if (n.input_nodes[k] >= 0)
        s << "  \"" << nodes_[n.input_nodes[k]].id << "\" -> \"" << n.id << "\" [label=\"" << n.spec->inputs[k].name
          << ": " << n.spec->inputs[k].artefact_type << "\"];\n";
  s << "}\n";
  return s.str();
}

namespace {

using Clock = std::chrono::steady_clock;

/// One run's state and the steps that run one node: its inputs, its cache key, a cache hit, the
/// computation (with --save-all's files) and its record. Nodes run concurrently: node i writes only its
/// own slots (outputs_[i], identity_[i], frame_[i], result.nodes[i]) and reads those of its inputs,
/// which the flow graph completed before it started.
class NodeRunner {
 public:
  NodeRunner(const std::vector<ResolvedNode>& nodes, const RunOptions& opt, RunResult& result)
      : nodes_(nodes),
        opt_(opt),
        result_(result),
        outputs_(nodes.size()),
        identity_(nodes.size()),
        keys_(nodes.size()),
        frame_(nodes.size()) {}

  /// Sets up the artefact cache (opt.cache_dir) and the nodes' keys. \throw what ArtefactCache throws
  void open_cache(std::vector<std::string> keys) {
    cache_ = std::make_unique<ArtefactCache>(opt_.cache_dir);
    keys_ = std::move(keys);
  }

  /// Runs node i, or loads it from the cache, or skips it; records what happened.
  /// \throw NodeError naming the node when it fails (a node of a branch drops its branch instead)
  void run(size_t i) {
    const ResolvedNode& n = nodes_[i];
    NodeRecord& rec = result_.nodes[i];
    Inputs in;
    for (int u : n.input_nodes) in.items.push_back(u >= 0 ? outputs_[size_t(u)] : Artefact{});
    if (lacks_required_input(n, in)) {
      rec.skipped = true;
      event("skipped", n, 0, "");
      return;
    }
    const Clock::time_point t0 = Clock::now();
    const std::string key = key_of(i);
    rec.cache_key = key;
    if (!key.empty()) identity_[i] = "k:" + key;  // replaced by the content digest below when there is one
    // The cache: sinks always run; outputs without a codec are not cached.
    const bool cacheable =
        cache_ && !key.empty() && !n.spec->output.empty() && Registry::instance().codec(n.spec->output) != nullptr;
    std::vector<std::string> cache_warnings;
    if (cacheable && !writes_side_files(n, opt_.save_all) && load_cached(i, key, t0, cache_warnings)) return;
    NodeContext ctx = context_of(i);
    if (!compute(i, in, ctx, t0)) return;
    rec.seconds = seconds_since(t0);
    if (cacheable) {
      try {
        identity_[i] = "d:" + cache_->store(n.spec->type, key, outputs_[i], ctx.metrics, ctx.warnings);
      } catch (const std::exception& e) {
        cache_warnings.push_back(std::string("cache: could not store the result: ") + e.what());
      }
    }
    rec.ran = true;
    record_memory(rec);
    rec.metrics = std::move(ctx.metrics);
    rec.warnings = std::move(ctx.warnings);
    rec.warnings.insert(rec.warnings.end(), cache_warnings.begin(), cache_warnings.end());
    event("done", n, rec.seconds, "");
  }

 private:
  void event(const std::string& e, const ResolvedNode& n, double v, const std::string& what) {
    if (!opt_.on_event) return;
    std::lock_guard<std::mutex> lock(event_mutex_);
    opt_.on_event(e, n.id, n.spec->type, v, what);
  }

  /// A required input from a node that produced nothing (a may_skip node's empty result, or a node
  /// skipped for that reason): the node is skipped too.
  static bool lacks_required_input(const ResolvedNode& n, const Inputs& in) {
    for (size_t k = 0; k < n.input_nodes.size(); ++k)
      if (n.input_nodes[k] >= 0 && !in.items[k] && !n.spec->inputs[k].optional) return true;
    return false;
  }

  /// The key: each input by its content where known, else by its own key (graph/cache.h); none when an
  /// input has neither (it cannot be cached) or a file the node reads cannot be read (keys_[i] empty).
  std::string key_of(size_t i) const {
    const ResolvedNode& n = nodes_[i];
    if (!cache_ || keys_[i].empty()) return {};
    std::vector<std::string> in_ids;
    for (int u : n.input_nodes) {
      if (u >= 0 && identity_[size_t(u)].empty()) return {};
      in_ids.push_back(u >= 0 ? identity_[size_t(u)] : std::string());
    }
    return n.input_nodes.empty() ? keys_[i] : node_key(*n.spec, n.params, in_ids);
  }

  /// The process's memory as node `rec` ends (NodeRecord::rss_mb).
  static void record_memory(NodeRecord& rec) {
    const ProcessMemory mem = process_memory();
    rec.rss_mb = mem.rss_mb;
    rec.peak_rss_mb = mem.peak_rss_mb;
  }

  /// Loads node i from the cache; false when it is not there (an invalid entry adds a warning).
  bool load_cached(size_t i, const std::string& key, Clock::time_point t0, std::vector<std::string>& warnings) {
    const ResolvedNode& n = nodes_[i];
    CacheLookup hit = cache_->load(n.spec->type, key, n.spec->output);
    if (hit.status == CacheLookup::Status::invalid)
      warnings.push_back("cache: ignored entry " + hit.problem + "; recomputed");
    if (hit.status != CacheLookup::Status::hit) return false;
    NodeRecord& rec = result_.nodes[i];
    outputs_[i] = std::move(hit.artefact);
    identity_[i] = "d:" + hit.digest;
    rec.cache_hit = true;
    rec.ran = true;
    record_memory(rec);
    rec.metrics = std::move(hit.metrics);
    rec.warnings = std::move(hit.warnings);
    rec.seconds = seconds_since(t0);
    event("cached", n, rec.seconds, "");
    return true;
  }

  NodeContext context_of(size_t i) {
    const ResolvedNode& n = nodes_[i];
    NodeContext ctx;
    ctx.id = n.id;
    ctx.type = n.spec->type;
    ctx.out_dir = opt_.out_dir;
    ctx.save_all = opt_.save_all;
    ctx.on_progress = [this, &n](double f, const std::string& what) { event("progress", n, f, what); };
    for (int u : n.input_nodes)
      if (u >= 0 && frame_[size_t(u)] && !ctx.input_frame) ctx.input_frame = frame_[size_t(u)];
    return ctx;
  }

  /// Computes node i (and writes its --save-all file); false when it produced nothing, recorded: a
  /// may_skip node's empty result, or a node of a branch that threw (the branch is dropped, the others
  /// go on). \throw NodeError naming the node for any other failure
  bool compute(size_t i, const Inputs& in, NodeContext& ctx, Clock::time_point t0) {
    const ResolvedNode& n = nodes_[i];
    event("start", n, 0, "");
    try {
      Artefact out = n.spec->run(n.params, in, ctx);
      if (!out && n.spec->may_skip) return produced_nothing(i, ctx, t0, "");
      if (!n.spec->output.empty() && (!out || out.type != n.spec->output))
        throw Error("produced " + (out ? out.type : std::string("nothing")) + " instead of " + n.spec->output);
      outputs_[i] = out;
      using Role = NodeSpec::FrameRole;
      // entering: the inputs' frame, then the node's own (either may be none)
      if (n.spec->frame_role == Role::enters && ctx.frame && ctx.input_frame)
        frame_[i] = ctx.input_frame->then(*ctx.frame);
      else if (n.spec->frame_role == Role::enters)
        frame_[i] = ctx.frame ? ctx.frame : ctx.input_frame;
      if (n.spec->frame_role == Role::keeps) frame_[i] = ctx.input_frame;
      if (n.spec->frame_role == Role::leaves) frame_[i] = frames_frame(i);
      if (opt_.save_all && out) save(i, out);
    } catch (const NodeError&) {
      throw;
    } catch (const std::exception& e) {
      if (n.branch > 0 && !interrupted()) return produced_nothing(i, ctx, t0, e.what());
      NodeRecord& rec = result_.nodes[i];
      rec.seconds = seconds_since(t0);
      rec.metrics = ctx.metrics;
      rec.warnings = ctx.warnings;
      throw NodeError(n.id, n.spec->type, e.what());
    } catch (...) {
      throw NodeError(n.id, n.spec->type, "unknown exception");
    }
    return true;
  }

  /// Records that node i produced nothing (`error`: why, for a failed node of a branch); its dependants
  /// are skipped. Returns false.
  bool produced_nothing(size_t i, const NodeContext& ctx, Clock::time_point t0, std::string error) {
    NodeRecord& rec = result_.nodes[i];
    rec.skipped = true;
    rec.branch_error = std::move(error);
    rec.metrics = ctx.metrics;
    rec.warnings = ctx.warnings;
    rec.seconds = seconds_since(t0);
    event("done", nodes_[i], rec.seconds, "");
    return false;
  }

  /// The frame of node i's Frames input (the frame its frames were found in), or none.
  std::optional<RigidFrame> frames_frame(size_t i) const {
    const ResolvedNode& n = nodes_[i];
    for (size_t k = 0; k < n.input_nodes.size(); ++k)
      if (n.input_nodes[k] >= 0 && n.spec->inputs[k].artefact_type == artefact_name<Frames>())
        return frame_[size_t(n.input_nodes[k])];
    return std::nullopt;
  }

  /// --save-all: writes node i's artefact, in the input's frame. \throw Error when it cannot be turned back
  void save(size_t i, const Artefact& out) {
    auto [ext, saver] = Registry::instance().saver(out.type);
    if (!saver) return;
    Artefact shown = out;
    if (frame_[i] && !frame_[i]->is_identity()) {
      const ArtefactTurner* turn = Registry::instance().turner(out.type);
      if (!turn) throw Error("--save-all: no way to turn a " + out.type + " back into the input's frame");
      shown = (*turn)(out, frame_[i]->inverse());
    }
    saver(shown, save_all_path(nodes_, nodes_[i].id, ext, opt_.out_dir));
  }

  const std::vector<ResolvedNode>& nodes_;
  const RunOptions& opt_;
  RunResult& result_;
  std::unique_ptr<ArtefactCache> cache_;
  std::vector<Artefact> outputs_;
  std::vector<std::string> identity_;  // per node what its dependants' keys name it by
  std::vector<std::string> keys_;
  // Per computed node the frame its output is in, against the input's (NodeSpec::frame_role); none = the
  // input's frame. Only --save-all uses it (it computes every node, so no cache hit hides one).
  std::vector<std::optional<RigidFrame>> frame_;
  std::mutex event_mutex_;
};

/// Runs body(i) for every node as a tbb::flow::continue_node wired along the inputs, on `threads`
/// threads; an exception ends the graph and its message is returned ("" when none).
std::string run_flow_graph(const std::vector<ResolvedNode>& nodes, int threads,
                           const std::function<void(size_t)>& body) {
  namespace flow = oneapi::tbb::flow;
  std::string error;
  oneapi::tbb::global_control limit(oneapi::tbb::global_control::max_allowed_parallelism, size_t(threads));
  oneapi::tbb::task_arena arena(threads);
  arena.execute([&] {
    flow::graph g;
    flow::broadcast_node<flow::continue_msg> start(g);
    std::vector<std::unique_ptr<flow::continue_node<flow::continue_msg>>> fnodes;
    for (size_t i = 0; i < nodes.size(); ++i)
      fnodes.push_back(
          std::make_unique<flow::continue_node<flow::continue_msg>>(g, [&, i](const flow::continue_msg&) { body(i); }));
    for (size_t i = 0; i < nodes.size(); ++i) {
      bool has_pred = false;
      for (int u : nodes[i].input_nodes)
        if (u >= 0) {
          flow::make_edge(*fnodes[u], *fnodes[i]);
          has_pred = true;
        }
      if (!has_pred) flow::make_edge(start, *fnodes[i]);
    }
    try {
      start.try_put(flow::continue_msg());
      g.wait_for_all();
    } catch (const std::exception& e) {
      error = e.what();
    }
  });
  return error;
}

}  // namespace

RunResult Pipeline::run(const RunOptions& opt) const {
  std::error_code ec;
  std::filesystem::create_directories(opt.out_dir, ec);
  if (ec || !std::filesystem::is_directory(opt.out_dir))
    throw IOError(opt.out_dir.string() + ": cannot create output folder" + (ec ? ": " + ec.message() : ""));
  RunResult result;
  result.nodes.resize(nodes_.size());
  for (size_t i = 0; i < nodes_.size(); ++i) {
    result.nodes[i].id = nodes_[i].id;
    result.nodes[i].type = nodes_[i].spec->type;
  }
  NodeRunner runner(nodes_, opt, result);
  if (!opt.cache_dir.empty()) runner.open_cache(cache_keys());
  const int threads = opt.threads > 0 ? opt.threads : oneapi::tbb::info::default_concurrency();
  const auto t0 = Clock::now();
  result.error = run_flow_graph(nodes_, threads, [&](size_t i) { runner.run(i); });
  result.interrupted = interrupted();
  result.seconds = seconds_since(t0);
  result.peak_rss_mb = process_memory().peak_rss_mb;
  return result;
}

std::vector<const NodeRecord*> inverted_mesh_reports(const Pipeline& p, const RunResult& r) {
  const auto stage = [](const std::string& type) { return type.substr(0, type.find('/')); };
  std::map<std::string, const ResolvedNode*> node;  // by id
  for (const ResolvedNode& n : p.nodes()) node[n.id] = &n;
  int kept = 0;  // the branch whose mesh was kept; 0: none chosen, every branch counts
  for (const NodeRecord& n : r.nodes) {
    const auto sel = node.find(n.id);
    if (stage(n.type) != "select_hexes" || sel == node.end() || !n.metrics.contains("chosen") ||
        !n.metrics["chosen"].is_number_integer())
      continue;
    const long port = n.metrics["chosen"].get<long>() - 1;  // candidate_1 is port 0
    const std::vector<int>& from = sel->second->input_nodes;
    if (port >= 0 && size_t(port) < from.size() && from[size_t(port)] >= 0)
      kept = p.nodes()[size_t(from[size_t(port)])].branch;
  }
  std::vector<const NodeRecord*> out;
  for (const NodeRecord& n : r.nodes) {
    if (stage(n.type) != "optimize" && stage(n.type) != "quality") continue;
    const auto b = node.find(n.id);
    if (kept > 0 && b != node.end() && b->second->branch != 0 && b->second->branch != kept) continue;
    if (n.metrics.contains("inverted") && n.metrics["inverted"].is_number() && n.metrics["inverted"].get<double>() > 0)
      out.push_back(&n);
  }
  return out;
}

json RunResult::report() const {
  json r;
  r["polyhex_version"] = POLYHEX_VERSION;
  r["status"] = status();
  if (!error.empty()) r["error"] = error;
  r["seconds"] = seconds;
  r["peak_rss_mb"] = peak_rss_mb;
  json nodes_json = json::object();
  for (const NodeRecord& n : nodes) {
    json j;
    j["type"] = n.type;
    j["ran"] = n.ran;
    if (n.skipped) j["skipped"] = true;
    if (!n.branch_error.empty()) j["branch_error"] = n.branch_error;
    j["seconds"] = n.seconds;
    j["rss_mb"] = n.rss_mb;
    j["peak_rss_mb"] = n.peak_rss_mb;
    j["cache_hit"] = n.cache_hit;
    j["metrics"] = n.metrics;
    j["warnings"] = n.warnings;
    nodes_json[n.id] = j;
  }
  r["nodes"] = nodes_json;
  if (!retry.is_null()) r["retry"] = retry;
  return r;
}

void write_report(const RunResult& r, const std::filesystem::path& dir) {
  write_file_atomic(dir / "report.json", [&](std::ostream& out) { out << r.report().dump(2) << "\n"; });
}

}  // namespace polyhex
