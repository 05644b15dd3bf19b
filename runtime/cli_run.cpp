#include "runtime/cli_run.h"

#include <unistd.h>

#include <cstdio>

#include "graph/cache.h"

namespace polyhex {

Pipeline load_pipeline(const RunRequest& req) {
  std::map<std::string, std::string> vars;
  if (!req.input.empty()) vars["input"] = req.input;
  json j = load_config_json(req.config, vars);
  for (const std::string& s : req.sets) apply_override(j, s);
  return Pipeline::build(parse_config(j, req.config.string()));
}

RunResult run_pipeline(const Pipeline& p, const RunRequest& req) {
  RunOptions opt;
  opt.out_dir = req.out_dir;
  opt.save_all = req.save_all;
  opt.threads = req.threads;
  if (!req.no_cache) opt.cache_dir = req.cache_dir.empty() ? default_cache_dir(req.out_dir) : req.cache_dir;
  const bool show = req.verbosity > 0 || ::isatty(STDERR_FILENO);
  if (show) {
    opt.on_event = [&](const std::string& e, const std::string& id, const std::string& type, double v,
                       const std::string& what) {
      if (e == "start")
        std::fprintf(stderr, "polyhex: %-16s %-34s started\n", id.c_str(), type.c_str());
      else if (e == "done")
        std::fprintf(stderr, "polyhex: %-16s %-34s done in %.2f s\n", id.c_str(), type.c_str(), v);
      else if (e == "cached")
        std::fprintf(stderr, "polyhex: %-16s %-34s loaded from cache in %.2f s\n", id.c_str(), type.c_str(), v);
      else if (e == "progress" && req.verbosity > 0)
        std::fprintf(stderr, "polyhex: %-16s %3.0f%% %s\n", id.c_str(), 100 * v, what.c_str());
    };
  }
  RunResult r = p.run(opt);
  write_report(r, req.out_dir);
  return r;
}

}  // namespace polyhex
