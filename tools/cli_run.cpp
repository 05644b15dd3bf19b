#include "tools/cli_run.h"

#include "graph/cache.h"
#include "runtime/errors.h"
#include "runtime/progress.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <system_error>
#include <unistd.h>

namespace polyhex {
namespace {

namespace fs = std::filesystem;

/// The config with the variant's "<id>.<param>": value pairs set.
json variant_config(json j, const json& variant, const std::string& where) {
  for (auto it = variant.begin(); it != variant.end(); ++it) {
    const std::string& key = it.key();
    const auto dot = key.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == key.size())
      throw ConfigError(where + ": `" + key + "` is not <id>.<param>");
    try {
      set_param(j, key.substr(0, dot), key.substr(dot + 1), it.value());
    } catch (const ConfigError& e) {
      throw ConfigError(where + ": " + e.what());
    }
  }
  return j;
}

RetryPlan parse_retry(const json& block, const json& config, const Pipeline& base, const std::string& source) {
  const std::string where = source + ": retry";
  if (!block.is_object())
    throw ConfigError(where + ": an object {node, max_inverted, min_sj, variants}, got " + block.dump());
  for (auto it = block.begin(); it != block.end(); ++it)
    if (it.key() != "node" && it.key() != "max_inverted" && it.key() != "min_sj" && it.key() != "variants" &&
        it.key() != "on_failure")
      throw ConfigError(where + ": unknown key `" + it.key() +
                        "`; valid keys: node, max_inverted, min_sj, variants, on_failure");
  RetryPlan r;
  if (!block.contains("node") || !block["node"].is_string()) throw ConfigError(where + ": missing string `node`");
  r.node = block["node"].get<std::string>();
  bool known = false;
  for (const ResolvedNode& n : base.nodes()) known = known || n.id == r.node;
  if (!known) throw ConfigError(where + ".node: no node with id `" + r.node + "`");
  auto number = [&](const char* key, double lo, double hi, double& out) {
    if (!block.contains(key)) return;
    if (!block[key].is_number() || block[key].get<double>() < lo || block[key].get<double>() > hi)
      throw ConfigError(where + "." + key + ": a number in [" + json(lo).dump() + ", " + json(hi).dump() + "], got " +
                        block[key].dump());
    out = block[key].get<double>();
  };
  number("max_inverted", 0, 1e12, r.max_inverted);
  number("min_sj", -1, 1, r.min_sj);
  if (!block.contains("variants") || !block["variants"].is_array() || block["variants"].empty())
    throw ConfigError(where + ": `variants` must be a non-empty array of {\"<id>.<param>\": value} objects");
  if (block.contains("on_failure") && !block["on_failure"].is_array())
    throw ConfigError(where + ": `on_failure` must be an array of {\"<id>.<param>\": value} objects");
  json all = block["variants"];
  r.regular = all.size();
  if (block.contains("on_failure"))
    for (const json& v : block["on_failure"]) all.push_back(v);
  if (all.size() > 16) throw ConfigError(where + ": more than 16 variants");
  for (size_t k = 0; k < all.size(); ++k) {
    const json& v = all[k];
    const std::string w = where + (k < r.regular ? ".variants[" + std::to_string(k) + "]"
                                                 : ".on_failure[" + std::to_string(k - r.regular) + "]");
    if (!v.is_object() || v.empty()) throw ConfigError(w + ": a non-empty object {\"<id>.<param>\": value}");
    json c = variant_config(config, v, w);
    try {
      r.pipelines.push_back(Pipeline::build(parse_config(c, source)));
    } catch (const ConfigError& e) {
      throw ConfigError(w + ": " + strip_source(e.what(), source));
    }
    r.variants.push_back(v);
  }
  return r;
}

struct Judgement {
  double inverted = 0, sj_min = 0;
};

Judgement judge(const RunResult& r, const std::string& node) {
  for (const NodeRecord& n : r.nodes)
    if (n.id == node) {
      const json& m = n.metrics;
      if (!m.contains("inverted") || !m["inverted"].is_number() || !m.contains("sj_min") || !m["sj_min"].is_number())
        throw ConfigError("retry: node `" + node + "` (`" + n.type +
                          "`) reports no numeric `inverted` and `sj_min` metrics");
      return {m["inverted"].get<double>(), m["sj_min"].get<double>()};
    }
  throw ConfigError("retry: no node `" + node + "` in the run");
}

/// Moves every file of `from` (not report.json) into `to`, replacing what is there; each by rename, so a
/// reader never sees a half-written file.
void move_files(const fs::path& from, const fs::path& to) {
  for (const fs::directory_entry& e : fs::directory_iterator(from)) {
    if (!e.is_regular_file() || e.path().filename() == "report.json") continue;
    std::error_code ec;
    fs::rename(e.path(), to / e.path().filename(), ec);
    if (ec) throw IOError(e.path().string() + ": cannot move into " + to.string() + ": " + ec.message());
  }
}

}  // namespace

std::optional<RetryPlan> retry_plan(const json& config, const Pipeline& pipeline, const std::string& source) {
  if (!config.is_object() || !config.contains("retry")) return std::nullopt;
  json j = config;
  j.erase("retry");
  return parse_retry(config["retry"], j, pipeline, source);
}

Pipeline load_pipeline(const RunRequest& req, std::optional<RetryPlan>* retry) {
  std::map<std::string, std::string> vars;
  if (!req.input.empty()) vars["input"] = req.input;
  json j = load_config_json(req.config, vars);
  if (req.hex_edge > 0) {
    try {
      set_param(j, "vars", "hex_edge", req.hex_edge);
    } catch (const ConfigError& e) {
      throw ConfigError("--hex-edge: " + req.config.string() + ": " + e.what() +
                        " (add \"vars\": {\"hex_edge\": ...} and make the sizes follow it)");
    }
  }
  for (const std::string& s : req.sets) apply_override(j, s);
  Pipeline p = Pipeline::build(parse_config(j, req.config.string()));
  if (retry) *retry = retry_plan(j, p, req.config.string());
  return p;
}

RunResult run_pipeline(const Pipeline& p, const RunRequest& req) {
  RunOptions opt;
  opt.out_dir = req.out_dir;
  opt.save_all = req.save_all;
  opt.threads = req.threads;
  if (!req.no_cache) opt.cache_dir = req.cache_dir.empty() ? default_cache_dir(req.out_dir) : req.cache_dir;
  ProgressPrinter progress(stderr, progress_mode(req.verbosity, ::isatty(STDERR_FILENO)),
                           terminal_columns(STDERR_FILENO));
  opt.on_event = [&](const std::string& e, const std::string& id, const std::string& type, double v,
                     const std::string& what) { progress.event(e, id, type, v, what); };
  RunResult r = p.run(opt);
  progress.clear();
  write_report(r, req.out_dir);
  return r;
}

RunResult run_with_retry(const Pipeline& p, const std::optional<RetryPlan>& retry, const RunRequest& req) {
  if (!retry) return run_pipeline(p, req);
  const RetryPlan& plan = *retry;
  RunRequest base = req;
  const fs::path temp_cache = req.out_dir / ".retry-cache";
  if (req.no_cache)
    base.no_cache = false, base.cache_dir = temp_cache;
  else if (req.cache_dir.empty())
    base.cache_dir = default_cache_dir(req.out_dir);  // the variants' folders lie inside OUT: the same cache
  auto clean_up = [&] {
    std::error_code ec;
    for (size_t k = 1; k <= plan.variants.size(); ++k)
      fs::remove_all(req.out_dir / (".retry-" + std::to_string(k)), ec);
    if (req.no_cache) fs::remove_all(temp_cache, ec);
  };
  clean_up();  // leftovers of an interrupted earlier run
  struct Guard {
    std::function<void()> f;
    ~Guard() { f(); }
  } guard{clean_up};

  json attempts = json::array();
  RunResult best = run_pipeline(p, base);
  double total = best.seconds;
  size_t chosen = 0;
  Judgement best_j{};
  auto record = [&](const RunResult& r, const json& set, const Judgement* j) {
    json a{{"set", set}, {"status", r.status()}, {"seconds", r.seconds}};
    if (j) {
      a["inverted"] = j->inverted;
      a["sj_min"] = j->sj_min;
      a["accepted"] = j->inverted <= plan.max_inverted && j->sj_min >= plan.min_sj;
    } else {
      a["accepted"] = false;
    }
    attempts.push_back(a);
    return a["accepted"].get<bool>();
  };
  // A failed first run is reported as it is, unless it failed because every orientation branch did (a node
  // of a branch threw: the input was read and meshed, a frame's structure or map was not sound): that is
  // what the variants are for, and one of them may mesh it. A bad input fails before the branches.
  const bool branches_failed =
      !best.error.empty() && !best.interrupted &&
      std::any_of(best.nodes.begin(), best.nodes.end(), [](const NodeRecord& n) { return !n.branch_error.empty(); });
  if (!best.error.empty() && !branches_failed) return best;
  bool accepted = false;
  if (branches_failed) {
    record(best, json::object(), nullptr);  // best_j is not read while best has no mesh
  } else {
    best_j = judge(best, plan.node);
    accepted = record(best, json::object(), &best_j);
  }
  for (size_t k = 0; k < plan.variants.size() && !accepted; ++k) {
    if (k >= plan.regular && best.error.empty()) break;  // on_failure: only while no attempt made a mesh
    RunRequest v = base;
    v.out_dir = req.out_dir / (".retry-" + std::to_string(k + 1));
    if (req.verbosity > 0 || ::isatty(STDERR_FILENO)) {
      char first[96] = "every orientation branch failed";
      if (!branches_failed)
        std::snprintf(first, sizeof first, "%ld inverted, minimum scaled Jacobian %.3f",
                      attempts[0]["inverted"].get<long>(), attempts[0]["sj_min"].get<double>());
      std::fprintf(stderr, "polyhex: retry %zu of %zu: %s (first run: %s)\n", k + 1, plan.variants.size(),
                   plan.variants[k].dump().c_str(), first);
    }
    RunResult r = run_pipeline(plan.pipelines[k], v);
    total += r.seconds;
    if (r.interrupted) {
      record(r, plan.variants[k], nullptr);
      r.seconds = total;
      r.retry = {{"node", plan.node},
                 {"max_inverted", plan.max_inverted},
                 {"min_sj", plan.min_sj},
                 {"chosen", nullptr},
                 {"attempts", attempts}};
      write_report(r, req.out_dir);
      return r;
    }
    if (!r.error.empty()) {
      record(r, plan.variants[k], nullptr);
      continue;
    }
    const Judgement j = judge(r, plan.node);
    accepted = record(r, plan.variants[k], &j);
    if (!best.error.empty() || j.inverted < best_j.inverted ||
        (j.inverted == best_j.inverted && j.sj_min > best_j.sj_min)) {
      best = std::move(r);
      best_j = j;
      chosen = k + 1;
    }
  }
  if (chosen > 0) move_files(req.out_dir / (".retry-" + std::to_string(chosen)), req.out_dir);
  best.seconds = total;
  best.retry = {{"node", plan.node},
                {"max_inverted", plan.max_inverted},
                {"min_sj", plan.min_sj},
                {"chosen", chosen},
                {"attempts", attempts}};
  write_report(best, req.out_dir);
  return best;
}

}  // namespace polyhex
