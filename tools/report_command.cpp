// `polyhex report RUN_DIR`: RUN_DIR/report.html from the run's report.json and hex mesh
// (report/report_html.h). Exit 0 when written; 1 naming the file when report.json, the mesh or three.js
// is missing or malformed (no report.html is written then).
#include "report/report_html.h"
#include "tools/commands.h"

#include <cstdio>
#include <memory>
#include <string>

namespace polyhex {
namespace {

const bool registered = register_commands([](CLI::App& app, std::vector<Command>& out) {
  auto dir = std::make_shared<std::string>();
  auto params = std::make_shared<ReportHtmlParams>();
  CLI::App* c =
      app.add_subcommand("report", "write RUN_DIR/report.html: quality, histograms, times and a 3D view of a run");
  c->add_option("run_dir", *dir, "output folder of `polyhex run` (holds report.json and the hex mesh)")->required();
  c->add_option("--max-quads", params->max_boundary_quads,
                "boundary quads drawn at most (the page grows ~43 bytes a quad)")
      ->check(CLI::Range(1L, 10000000L));
  c->add_option("--min-sj", params->default_min_sj, "sj_min threshold when the run had no retry block")
      ->check(CLI::Range(-1.0, 1.0));
  out.push_back({c, [dir, params] {
                   std::fprintf(stderr, "polyhex: wrote %s\n", write_report_html(*dir, *params).c_str());
                   return 0;
                 }});
});

}  // namespace
}  // namespace polyhex
