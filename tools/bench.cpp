// `polyhex bench`: stage throughput. Runs a config `--warmup` times untimed, then `--repeat` times,
// all without the artefact cache, and reports per node the min / median / max wall seconds and the
// throughput in the node's own unit (see kUnits), plus the factorization figures of the nodes that use
// the CHOLMOD helper (runtime/factorization.h). A table goes to stdout, JSON to `--json FILE`.
//
// JSON (schema 1):
//   {schema: 1, kind: "polyhex-bench", polyhex_version, config, input, sets, threads, hardware_threads,
//    repeat, warmup, cache: false, started_utc,
//    total: {seconds: [repeat], min, median, max},
//    nodes: [{id, type, seconds: [repeat], min, median, max,
//             count: {metric, value, node} | null,    // the size the throughput divides: metric `metric`
//                                                     // of node `node` (itself or the producer of an input)
//             unit: "tets/s" | ... | null, throughput: count.value / median | null,
//             solver?: {analyses, factorizations, solves,
//                       analyse_seconds|factor_seconds|solve_seconds: {seconds: [repeat], min, median, max},
//                       factor_seconds_each: median factor seconds / factorizations,
//                       solves_per_second: solves / median solve seconds},
//             rss_mb: the largest resident memory (MiB) at the node's end over the timed runs,
//             metrics: the node's metrics of the last run}],
//    peak_rss_mb: the process's resident high-water mark at the end (warm-up runs included),
//    units: {stage: "unit: what is counted"}}
// Medians of an even count are the mean of the two middle values.
#include "graph/pipeline.h"
#include "runtime/atomic_file.h"
#include "runtime/memory.h"
#include "tools/cli_run.h"
#include "tools/commands.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <memory>
#include <thread>

namespace polyhex {
namespace {

constexpr int kBenchSchema = 1;

/// The throughput unit of a stage: `metric` of the node itself, or (when `port` is set) of the node
/// feeding that input port. A node that lacks the metric but maps an artefact to one of the same type
/// (optimize: HexMesh -> HexMesh) passes the question on to that input.
struct UnitRule {
  const char* stage;
  const char* metric;
  const char* port;  ///< nullptr = the node's own metrics
  const char* unit;
  const char* doc;
};

const UnitRule kUnits[] = {
    {"shapes", "faces", nullptr, "triangles/s", "triangles of the built surface (metrics.faces)"},
    {"read_surface", "faces", nullptr, "triangles/s", "triangles read (metrics.faces)"},
    {"read_tetmesh", "tets", nullptr, "tets/s", "tets read (metrics.tets)"},
    {"tetrahedralize", "tets", nullptr, "tets/s", "tets generated (metrics.tets)"},
    {"rotation_deform", "tets", nullptr, "tets/s",
     "tets deformed, all iterations together (metrics.tets); solver: solves/s of the factored systems"},
    {"polycube_segment", "boundary_triangles", nullptr, "triangles/s",
     "boundary triangles labelled (metrics.boundary_triangles)"},
    {"position_deform", "tets", "tets", "tets/s", "tets mapped (metrics.tets of the `tets` input)"},
    {"hex_extract", "hexes", nullptr, "hexes/s", "hexes extracted (metrics.hexes)"},
    {"hex_from_tets", "hexes", nullptr, "hexes/s", "hexes made (metrics.hexes)"},
    {"pad", "hexes", nullptr, "hexes/s", "hexes of the padded mesh (metrics.hexes)"},
    {"optimize", "hexes", "hexes", "hexes/s", "hexes optimized (metrics.hexes of the `hexes` input)"},
    {"quality", "hexes", nullptr, "hexes/s", "hexes measured (metrics.hexes)"},
    {"write_hex", "hexes", "mesh", "hexes/s", "hexes written (hexes of the `mesh` input)"},
    {"write_tetmesh", "tets", "mesh", "tets/s", "tets written (tets of the `mesh` input)"},
};
/// Node types without a rule: the first of these metrics found (own, or through a same-type input).
const char* const kFallbackMetrics[] = {"hexes", "tets", "faces"};
/// Factorization figures (FactorizationStats::merge_into) timed per run.
const char* const kSolverSeconds[] = {"analyse_seconds", "factor_seconds", "solve_seconds"};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

json stats(const std::vector<double>& v) {
  return {{"seconds", v},
          {"min", v.empty() ? 0.0 : *std::min_element(v.begin(), v.end())},
          {"median", median(v)},
          {"max", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}};
}

// The value of `metric` at node i, or through an input of the node's own output type. {node, value}
std::pair<int, json> find_metric(const Pipeline& p, const std::vector<json>& metrics, int i,
                                 const std::string& metric) {
  const json& m = metrics[i];
  if (m.contains(metric) && m[metric].is_number()) return {i, m[metric]};
  const ResolvedNode& n = p.nodes()[i];
  for (size_t k = 0; k < n.input_nodes.size(); ++k)
    if (n.input_nodes[k] >= 0 && n.spec->inputs[k].artefact_type == n.spec->output)
      return find_metric(p, metrics, n.input_nodes[k], metric);
  return {-1, nullptr};
}

// {count json or null, unit or null}
std::pair<json, json> node_count(const Pipeline& p, const std::vector<json>& metrics, int i) {
  const ResolvedNode& n = p.nodes()[i];
  auto make = [&](const std::pair<int, json>& hit, const std::string& metric,
                  const std::string& unit) -> std::pair<json, json> {
    if (hit.first < 0) return {nullptr, nullptr};
    return {json{{"metric", metric}, {"value", hit.second}, {"node", p.nodes()[hit.first].id}}, unit};
  };
  for (const UnitRule& r : kUnits) {
    if (n.spec->stage() != r.stage) continue;
    int from = i;
    if (r.port) {
      from = -1;
      for (size_t k = 0; k < n.spec->inputs.size(); ++k)
        if (n.spec->inputs[k].name == r.port) from = n.input_nodes[k];
      if (from < 0) return {nullptr, nullptr};
    }
    return make(find_metric(p, metrics, from, r.metric), r.metric, r.unit);
  }
  for (const char* metric : kFallbackMetrics) {
    auto hit = find_metric(p, metrics, i, metric);
    if (hit.first >= 0) return make(hit, metric, std::string(metric) + "/s");
  }
  return {nullptr, nullptr};
}

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

struct BenchOptions {
  RunRequest req;
  int repeat = 3;
  int warmup = 1;
  std::string json_path;
};

int cmd_bench(BenchOptions o) {
  RunRequest& req = o.req;
  req.no_cache = true;
  const Pipeline p = load_pipeline(req);
  const size_t nn = p.nodes().size();
  const std::string started = utc_now();
  std::vector<std::vector<double>> seconds(nn);
  std::vector<std::map<std::string, std::vector<double>>> solver(nn);
  std::vector<json> metrics(nn, json::object());
  std::vector<double> rss(nn, 0.0);
  std::vector<double> totals;
  FILE* table = o.json_path == "-" ? stderr : stdout;
  for (int k = 0; k < o.warmup + o.repeat; ++k) {
    const bool timed = k >= o.warmup;
    RunResult r = run_pipeline(p, req);
    if (r.interrupted) {
      std::fprintf(stderr, "polyhex bench: interrupted: %s\n", r.error.c_str());
      return 130;
    }
    if (!r.error.empty()) {
      std::fprintf(stderr, "polyhex bench: %s run %d failed: %s\n", timed ? "timed" : "warm-up",
                   timed ? k - o.warmup + 1 : k + 1, r.error.c_str());
      return 1;
    }
    std::fprintf(stderr, "polyhex bench: %s run %d of %d: %.2f s\n", timed ? "timed" : "warm-up",
                 timed ? k - o.warmup + 1 : k + 1, timed ? o.repeat : o.warmup, r.seconds);
    if (!timed) continue;
    totals.push_back(r.seconds);
    for (size_t i = 0; i < nn; ++i) {
      const NodeRecord& n = r.nodes[i];
      seconds[i].push_back(n.seconds);
      metrics[i] = n.metrics;
      rss[i] = std::max(rss[i], n.rss_mb);
      for (const char* key : kSolverSeconds)
        if (n.metrics.contains(key) && n.metrics[key].is_number())
          solver[i][key].push_back(n.metrics[key].get<double>());
    }
  }

  json out;
  out["schema"] = kBenchSchema;
  out["kind"] = "polyhex-bench";
  out["polyhex_version"] = POLYHEX_VERSION;
  out["config"] = req.config.string();
  out["input"] = req.input;
  out["sets"] = req.sets;
  out["threads"] = req.threads > 0 ? req.threads : int(std::thread::hardware_concurrency());
  out["hardware_threads"] = int(std::thread::hardware_concurrency());
  out["repeat"] = o.repeat;
  out["warmup"] = o.warmup;
  out["cache"] = false;
  out["started_utc"] = started;
  out["total"] = stats(totals);
  out["peak_rss_mb"] = process_memory().peak_rss_mb;  // at least every node's figure (runtime/memory.cpp)
  json units = json::object();
  for (const UnitRule& r : kUnits) units[r.stage] = std::string(r.unit) + ": " + r.doc;
  units["(other)"] =
      "hexes/s, tets/s or faces/s: the first of metrics hexes, tets, faces the node (or its same-type input) reports";
  out["units"] = units;

  std::fprintf(table, "%-12s %-34s %9s %9s %9s %12s %s\n", "node", "type", "median s", "min s", "max s", "throughput",
               "unit");
  json nodes = json::array();
  std::vector<std::string> solver_lines;
  for (size_t i = 0; i < nn; ++i) {
    const ResolvedNode& n = p.nodes()[i];
    json j = stats(seconds[i]);
    j["id"] = n.id;
    j["type"] = n.spec->type;
    auto [count, unit] = node_count(p, metrics, int(i));
    const double med = j["median"].get<double>();
    j["count"] = count;
    j["unit"] = unit;
    j["throughput"] = count.is_object() && med > 0 ? json(count["value"].get<double>() / med) : json(nullptr);
    if (!solver[i].empty()) {
      json s;
      for (const char* c : {"analyses", "factorizations", "solves"}) s[c] = metrics[i].value(c, json());
      for (auto& [key, v] : solver[i]) s[key] = stats(v);
      const double f = s.contains("factor_seconds") ? s["factor_seconds"]["median"].get<double>() : 0.0;
      const double sv = s.contains("solve_seconds") ? s["solve_seconds"]["median"].get<double>() : 0.0;
      const double nf = s["factorizations"].is_number() ? s["factorizations"].get<double>() : 0.0;
      const double ns = s["solves"].is_number() ? s["solves"].get<double>() : 0.0;
      s["factor_seconds_each"] = nf > 0 ? json(f / nf) : json(nullptr);
      s["solves_per_second"] = sv > 0 ? json(ns / sv) : json(nullptr);
      char line[256];
      std::snprintf(
          line, sizeof line,
          "%-12s factor %.3f s median (%g factorizations, %.3f s each); solve %.3f s (%g solves, %.1f solves/s)",
          n.id.c_str(), f, nf, nf > 0 ? f / nf : 0.0, sv, ns, sv > 0 ? ns / sv : 0.0);
      solver_lines.push_back(line);
      j["solver"] = s;
    }
    j["rss_mb"] = rss[i];
    j["metrics"] = metrics[i];
    std::string tp = j["throughput"].is_number() ? std::to_string(long(j["throughput"].get<double>() + 0.5)) : "-";
    std::fprintf(table, "%-12s %-34s %9.3f %9.3f %9.3f %12s %s\n", n.id.c_str(), n.spec->type.c_str(), med,
                 j["min"].get<double>(), j["max"].get<double>(), tp.c_str(),
                 unit.is_string() ? unit.get<std::string>().c_str() : "");
    nodes.push_back(j);
  }
  out["nodes"] = nodes;
  std::fprintf(table, "%-12s %-34s %9.3f %9.3f %9.3f\n", "total", "", out["total"]["median"].get<double>(),
               out["total"]["min"].get<double>(), out["total"]["max"].get<double>());
  std::fprintf(table, "peak resident memory %.0f MiB\n", out["peak_rss_mb"].get<double>());
  if (!solver_lines.empty()) {
    std::fprintf(table, "factorization helper (CHOLMOD):\n");
    for (auto& l : solver_lines) std::fprintf(table, "  %s\n", l.c_str());
  }
  if (o.json_path == "-")
    std::cout << out.dump(2) << "\n";
  else if (!o.json_path.empty())
    write_file_atomic(o.json_path, [&](std::ostream& f) { f << out.dump(2) << "\n"; });
  return 0;
}

const bool registered = register_commands([](CLI::App& app, std::vector<Command>& out) {
  auto o = std::make_shared<BenchOptions>();
  o->req.out_dir = "polyhex-bench";
  auto* bench = app.add_subcommand(
      "bench", "stage throughput: warm-up, then N runs without cache; per node min/median/max seconds and throughput");
  bench->add_option("config", o->req.config, "pipeline config (JSON)")->required();
  bench->add_option("--input,-i", o->req.input, "value of ${input} in the config (a surface or tet mesh file)");
  bench
      ->add_option("--hex-edge", o->req.hex_edge,
                   "hex edge, fraction of the reference length (the config var hex_edge)")
      ->check(CLI::Range(1e-4, 0.5));
  bench->add_option("--set,-s", o->req.sets, "override a param: id.param=value (repeatable)");
  bench->add_option("--threads,-j", o->req.threads, "worker threads (default: all cores)");
  bench->add_option("--out,-o", o->req.out_dir, "output folder of the runs (default polyhex-bench)");
  bench->add_option("--repeat,-r", o->repeat, "timed runs (default 3)")->check(CLI::Range(1, 1000));
  bench->add_option("--warmup", o->warmup, "untimed runs first (default 1)")->check(CLI::Range(0, 100));
  bench->add_option("--json", o->json_path, "write the JSON here (`-`: stdout, the table then goes to stderr)");
  out.push_back({bench, [o] {
                   o->req.verbosity = command_env().verbosity;
                   return cmd_bench(*o);
                 }});
});

}  // namespace
}  // namespace polyhex
