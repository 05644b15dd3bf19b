// polyhex: command-line interface of the all-hex PolyCube mesher.
//
//   polyhex run CONFIG [--input FILE] [--hex-edge H] [--out DIR] [--set id.param=value]... [--threads N] [--save-all]
//               [--cache DIR | --no-cache] [--html] [-v]
//   polyhex report RUN_DIR [--max-quads N] [--min-sj X]   (RUN_DIR/report.html, tools/report_command.cpp)
//   polyhex bench CONFIG [--input FILE] [--repeat N] [--json FILE] [--set ...] [--threads N]
//   polyhex graph CONFIG [--input FILE]          (Graphviz DOT on stdout)
//   polyhex nodes [--json]                        (registered node types and their params)
//
//   polyhex check MESH [--surface SURF] [--json]   (the quality node alone; exit 3 if a hex is inverted)
//   polyhex shapes NAME --out FILE                 (a built-in closed surface)
//   polyhex cache stats|clear|prune [--cache DIR]  (the artefact cache, tools/cache_command.cpp)
//
// Exit codes: 0 success, 1 a node failed (report.json says which), 2 bad command line or config,
// 3 the result has inverted hexes, 130 interrupted (SIGINT/SIGTERM).
//
// Subcommands come from command modules (tools/commands.h): this file holds run, graph and nodes.
#include "graph/pipeline.h"
#include "report/report_html.h"
#include "runtime/atomic_file.h"
#include "runtime/cancel.h"
#include "tools/cli_run.h"
#include "tools/commands.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <optional>

using namespace polyhex;

namespace {

void add_run_options(CLI::App* c, RunRequest& req) {
  c->add_option("config", req.config, "pipeline config (JSON)")->required();
  c->add_option("--input,-i", req.input, "value of ${input} in the config (a surface or tet mesh file)");
  c->add_option("--hex-edge", req.hex_edge,
                "hex edge as a fraction of the shape's reference length (its tightest bounding-box diagonal); the "
                "default configs derive every other size from it (sets the config var hex_edge)")
      ->check(CLI::Range(1e-4, 0.5));
  c->add_option("--set,-s", req.sets, "override a param: id.param=value (repeatable)");
  c->add_option("--threads,-j", req.threads, "worker threads (default: all cores)");
}

int cmd_run(const RunRequest& req, bool html) {
  std::optional<RetryPlan> retry;
  Pipeline p = load_pipeline(req, &retry);
  RunResult r = run_with_retry(p, retry, req);
  if (r.interrupted) {
    std::fprintf(stderr, "polyhex: interrupted: %s; %s\n", r.error.c_str(),
                 r.retry.is_null() ? "no mesh written" : "the first attempt's files stay in the output folder");
    return 130;
  }
  if (!r.error.empty()) {
    std::fprintf(stderr, "polyhex: error: %s\n", r.error.c_str());
    std::fprintf(stderr, "polyhex: partial report in %s%s\n", (req.out_dir / "report.json").c_str(),
                 html ? " (no report.html: the run wrote no mesh to show)" : "");
    return 1;
  }
  std::fprintf(stderr, "polyhex: done in %.2f s; report: %s\n", r.seconds, (req.out_dir / "report.json").c_str());
  if (html) std::fprintf(stderr, "polyhex: wrote %s\n", write_report_html(req.out_dir).c_str());
  // A mesh a solver would reject is not a success: the kept mesh's optimization or its quality report saw
  // inverted hexes.
  const std::vector<const NodeRecord*> inverted = inverted_mesh_reports(p, r);
  for (const NodeRecord* n : inverted)
    std::fprintf(stderr, "polyhex: node `%s` (`%s`) reports %s inverted hexes\n", n->id.c_str(), n->type.c_str(),
                 n->metrics["inverted"].dump().c_str());
  return inverted.empty() ? 0 : 3;
}

int cmd_nodes(bool as_json) {
  json all = json::object();
  for (const std::string& t : Registry::instance().types()) {
    const NodeSpec* s = Registry::instance().find(t);
    json j;
    j["doc"] = s->doc;
    j["output"] = s->output;
    j["inputs"] = json::array();
    for (auto& p : s->inputs)
      j["inputs"].push_back({{"name", p.name}, {"type", p.artefact_type}, {"optional", p.optional}});
    j["params"] = json::array();
    for (auto& p : s->params) {
      json pj{{"name", p.name}, {"kind", p.kind}, {"default", p.default_value}, {"doc", p.doc}};
      if (p.lo) pj["min"] = *p.lo;
      if (p.hi) pj["max"] = *p.hi;
      if (!p.choices.empty()) pj["choices"] = p.choices;
      j["params"].push_back(pj);
    }
    all[t] = j;
    if (!as_json) {
      std::printf("%s -> %s\n    %s\n", t.c_str(), s->output.empty() ? "(sink)" : s->output.c_str(), s->doc.c_str());
      for (auto& p : s->inputs)
        std::printf("    input  %-14s %s%s\n", p.name.c_str(), p.artefact_type.c_str(),
                    p.optional ? " (optional)" : "");
      for (auto& p : s->params)
        std::printf("    param  %-22s %-8s = %-14s %s\n", p.name.c_str(), p.kind.c_str(),
                    p.default_value.dump().c_str(), p.doc.c_str());
    }
  }
  if (as_json) std::cout << all.dump(2) << "\n";
  return 0;
}

const bool registered = register_commands([](CLI::App& app, std::vector<Command>& out) {
  auto run_req = std::make_shared<RunRequest>();
  auto* run = app.add_subcommand("run", "run a pipeline config; writes OUT/report.json and the writers' files");
  add_run_options(run, *run_req);
  run->add_option("--out,-o", run_req->out_dir, "output folder (default polyhex-out)");
  run->add_flag("--save-all", run_req->save_all, "also write every mesh artefact as OUT/<node id>.<ext>");
  auto* cache_opt = run->add_option("--cache", run_req->cache_dir,
                                    "artefact cache folder (default: .polyhex-cache beside the output folder)");
  run->add_flag("--no-cache", run_req->no_cache, "run every node; read and write no cache")->excludes(cache_opt);
  auto html = std::make_shared<bool>(false);
  run->add_flag("--html", *html, "also write OUT/report.html at the end (as `polyhex report OUT` does)");
  out.push_back({run, [run_req, html] {
                   run_req->verbosity = command_env().verbosity;
                   return cmd_run(*run_req, *html);
                 }});

  auto graph_req = std::make_shared<RunRequest>();
  auto* graph = app.add_subcommand("graph", "print the pipeline as Graphviz DOT");
  graph->add_option("config", graph_req->config, "pipeline config (JSON)")->required();
  graph->add_option("--input,-i", graph_req->input, "value of ${input}");
  graph->add_option("--set,-s", graph_req->sets, "override a param: id.param=value");
  out.push_back({graph, [graph_req] {
                   std::cout << load_pipeline(*graph_req).dot();
                   return 0;
                 }});

  auto nodes_json = std::make_shared<bool>(false);
  auto* nodes = app.add_subcommand("nodes", "list registered node types, their ports and params");
  nodes->add_flag("--json", *nodes_json, "as JSON");
  out.push_back({nodes, [nodes_json] { return cmd_nodes(*nodes_json); }});
});

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"polyhex " POLYHEX_VERSION ": all-hex meshes by volumetric PolyCube deformation"};
  app.require_subcommand(1);
  app.add_flag("-v,--verbose", command_env().verbosity, "more detail (repeatable)");
  std::vector<Command> commands;
  for (const CommandModule& m : command_modules()) m(app, commands);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  install_interrupt_handlers();
  try {
    for (const Command& c : commands)
      if (c.sub->parsed()) return c.run();
    return 2;
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "polyhex: config error: %s\n", e.what());
    return 2;
  } catch (const Interrupted& e) {
    std::fprintf(stderr, "polyhex: %s\n", e.what());
    return 130;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "polyhex: error: %s\n", e.what());
    return 1;
  }
}
