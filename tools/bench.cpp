// `polyhex bench`: run a config several times and report per-node wall times.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>

#include "graph/pipeline.h"
#include "runtime/atomic_file.h"
#include "runtime/cli_run.h"
#include "tools/commands.h"

namespace polyhex {
namespace {

int cmd_bench(RunRequest req, int repeat, const std::string& json_path) {
  Pipeline p = load_pipeline(req);
  json runs = json::array();
  std::map<std::string, std::vector<double>> times;
  std::vector<double> totals;
  json last_metrics = json::object();
  for (int k = 0; k < repeat; ++k) {
    RunResult r = run_pipeline(p, req);
    if (!r.error.empty()) {
      std::fprintf(stderr, "polyhex bench: run %d failed: %s\n", k + 1, r.error.c_str());
      return 1;
    }
    totals.push_back(r.seconds);
    for (auto& n : r.nodes) {
      times[n.id].push_back(n.seconds);
      last_metrics[n.id] = n.metrics;
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
  };
  json out;
  out["config"] = req.config.string();
  out["input"] = req.input;
  out["repeat"] = repeat;
  out["threads"] = req.threads;
  out["total_seconds"] = totals;
  out["total_median"] = median(totals);
  json nodes = json::object();
  std::printf("%-18s %-36s %10s %10s\n", "node", "type", "median s", "min s");
  for (auto& n : p.nodes()) {
    auto& t = times[n.id];
    json j;
    j["type"] = n.spec->type;
    j["seconds"] = t;
    j["median"] = median(t);
    j["min"] = t.empty() ? 0.0 : *std::min_element(t.begin(), t.end());
    j["metrics"] = last_metrics[n.id];
    nodes[n.id] = j;
    std::printf("%-18s %-36s %10.3f %10.3f\n", n.id.c_str(), n.spec->type.c_str(), j["median"].get<double>(),
                j["min"].get<double>());
  }
  out["nodes"] = nodes;
  std::printf("%-18s %-36s %10.3f\n", "total", "", median(totals));
  if (!json_path.empty()) write_file_atomic(json_path, [&](std::ostream& o) { o << out.dump(2) << "\n"; });
  else std::cout << out.dump(2) << "\n";
  return 0;
}

struct BenchOptions {
  RunRequest req;
  int repeat = 3;
  std::string json_path;
};

const bool registered = register_commands([](CLI::App& app, std::vector<Command>& out) {
  auto o = std::make_shared<BenchOptions>();
  o->req.out_dir = "polyhex-bench";
  auto* bench = app.add_subcommand("bench", "run a config several times; per-node wall times as JSON and a table");
  bench->add_option("config", o->req.config, "pipeline config (JSON)")->required();
  bench->add_option("--input,-i", o->req.input, "value of ${input} in the config (a surface or tet mesh file)");
  bench->add_option("--set,-s", o->req.sets, "override a param: id.param=value (repeatable)");
  bench->add_option("--threads,-j", o->req.threads, "worker threads (default: all cores)");
  bench->add_option("--out,-o", o->req.out_dir, "output folder of the runs (default polyhex-bench)");
  bench->add_option("--repeat,-r", o->repeat, "number of runs (default 3)")->check(CLI::Range(1, 1000));
  bench->add_option("--json", o->json_path, "write the JSON here (default: stdout)");
  out.push_back({bench, [o] {
                   o->req.verbosity = command_env().verbosity;
                   return cmd_bench(o->req, o->repeat, o->json_path);
                 }});
});

}  // namespace
}  // namespace polyhex
