// `polyhex sweep`: run a pipeline config once per parameter case and tabulate the results.
//
// ## The `sweep` key of a config
//
// Either axes, whose cartesian product gives the cases:
//
//     "sweep": {"rotate.anchor_weight": [0.5, 1, 4], "rotate.feature_angle": [45, 60]}
//
// (keys `<node id>.<param>`; a key `a.x+b.y` is one linked axis that sets both params to the same
// value; each axis a non-empty array of distinct values; axes in alphabetical key order, the last one
// varying fastest; case names `rotate.anchor_weight=0.5,rotate.feature_angle=45`), or named cases:
//
//     "sweep": {"cases": [{"name": "paper", "set": {}},
//                         {"name": "strong_anchors", "set": {"rotate.anchor_weight": 10}}]}
//
// (`name` of letters, digits and `._+=,-`, unique; `set` maps `<node id>.<param>` to a value; no
// other keys). Everything is checked before anything runs: the shape of the `sweep` value, every id
// and param (against the node's registered params), and every value, by building the pipeline of each
// case; a ConfigError names the path (`sweep."rotate.anchor_weight"[2]`, `sweep.cases[1].set."x.y"`).
// `--set` applies to every case and may not name a swept param.
//
// ## Running
//
// Every case runs as a child process (`/proc/self/exe sweep CONFIG --case NAME ...`, output in
// `OUT/<name>/log.txt`), at most `--jobs` at a time, each with `--threads / jobs` worker threads.
// Processes rather than one task_arena per case in this process, because Pipeline::run sets a
// `tbb::global_control` max_allowed_parallelism, which is process-wide (concurrent controls take the
// minimum, and all arenas share one worker pool), so cases in one process could not each get their
// share of the thread budget; a process also isolates a case that crashes or aborts, and returns its
// memory when it ends.
// All cases share one artefact cache (`--cache DIR`, default `OUT/.polyhex-cache`). With the cache on,
// a case that shares a computation with an earlier case (a node with inputs, same type and params,
// same upstream) waits for that case, so it finds the shared artefacts in the cache instead of
// computing them at the same time; `--list` shows these dependencies (`depends_on`). Nodes without
// inputs (readers, shapes) do not count: they are cheap and would serialise every sweep.
//
// ## Outputs (all written atomically)
//
// `OUT/<case>/`: report.json, config.json (the case's resolved config: `polyhex run` on it repeats
// the case), log.txt, the writers' files. `OUT/sweep.json` (schema 1) and `OUT/sweep.csv`: one row per
// case with the swept values, the quality figures of the last `quality` node (hexes, inverted, sj_min,
// sj_avg, irregular_pct, hausdorff_mean, hausdorff_max), the seconds and cache hit of every node, the
// status (ok, error, crashed, interrupted, not_run), the child's exit code and the error.
// Exit code: 0 every case ran, 1 some case failed, 2 bad config or command line, 130 interrupted.
#include "graph/pipeline.h"
#include "runtime/atomic_file.h"
#include "runtime/cancel.h"
#include "tools/cli_run.h"
#include "tools/commands.h"

#include <CLI/CLI.hpp>
#include <sys/prctl.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <regex>
#include <set>
#include <signal.h>
#include <spawn.h>
#include <sstream>
#include <thread>
#include <unistd.h>

extern char** environ;

namespace polyhex {
namespace {

namespace fs = std::filesystem;

constexpr int kSweepSchema = 1;
constexpr size_t kMaxCases = 10000;
/// Quality figures copied from the last `quality` node into each row.
const char* const kQualityKeys[] = {"hexes",         "inverted",       "sj_min",       "sj_avg",
                                    "irregular_pct", "hausdorff_mean", "hausdorff_max"};

struct SweepOptions {
  fs::path config;
  std::string input;
  std::vector<std::string> sets;
  fs::path out_dir = "polyhex-sweep";
  int jobs = 1;
  int threads = 0;
  fs::path cache_dir;
  bool no_cache = false;
  std::string only_case;  ///< --case: run this case in this process (what the children do)
  bool list = false;
};

struct SweepCase {
  std::string name;
  std::vector<std::pair<std::string, json>> set;  ///< id.param -> value
  int depends_on = -1;                            ///< index of the case to wait for, -1 = none
};

struct SweepPlan {
  std::string source;
  json base;                      ///< the config without `sweep`, ${vars} substituted, --set applied
  std::vector<std::string> keys;  ///< every swept id.param, in order of first appearance
  std::vector<SweepCase> cases;
  std::vector<Pipeline> pipelines;                ///< one per case
  std::vector<std::optional<RetryPlan>> retries;  ///< one per case: the config's retry block on the case's config
};

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + v[i];
  return s;
}

// Checks `key` = `<id>.<param>` (or `vars.<name>`) against the base pipeline. \throw ConfigError naming `where`
void check_target(const std::string& key, const Pipeline& base, const std::string& where) {
  const auto dot = key.find('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == key.size() || key.find('.', dot + 1) != std::string::npos)
    throw ConfigError(where + ": `" + key + "` is not `<node id>.<param>`");
  const std::string id = key.substr(0, dot), param = key.substr(dot + 1);
  if (id == "vars") return;  // a config var: set_param checks it when the case is built
  std::vector<std::string> ids;
  for (const ResolvedNode& n : base.nodes()) {
    ids.push_back(n.id);
    if (n.id != id) continue;
    std::vector<std::string> names;
    for (const ParamInfo& p : n.spec->params) {
      if (p.name == param) return;
      names.push_back(p.name);
    }
    throw ConfigError(where + ": node `" + id + "` (`" + n.spec->type + "`) has no param `" + param +
                      "`; params: " + (names.empty() ? "(none)" : join(names, ", ")));
  }
  throw ConfigError(where + ": no node with id `" + id + "`; ids: " + join(ids, ", "));
}

// The config with the case's values set.
json case_config(const json& base, const std::vector<std::pair<std::string, json>>& set) {
  json j = base;
  for (const auto& [key, value] : set) {
    const auto dot = key.find('.');
    set_param(j, key.substr(0, dot), key.substr(dot + 1), value);  // keys checked by check_target
  }
  return j;
}

Pipeline build_case(const json& base, const std::vector<std::pair<std::string, json>>& set, const std::string& source,
                    const std::string& where) {
  try {
    return Pipeline::build(parse_config(case_config(base, set), source));
  } catch (const ConfigError& e) {
    throw ConfigError(where + ": " + strip_source(e.what(), source));
  }
}

// Text of a value in a case name: strings as they are, other values as JSON; characters other than
// letters, digits and `._+-` become `_`.
std::string name_text(const json& v) {
  std::string s = v.is_string() ? v.get<std::string>() : v.dump();
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '+' && c != '-') c = '_';
  return s;
}

// Cases of `"sweep": {"a.x": [...], "b.y+c.z": [...]}`.
void expand_axes(const json& sweep, const Pipeline& base_pipeline, SweepPlan& plan) {
  struct Axis {
    std::string key;
    std::vector<std::string> targets;
    std::vector<json> values;
  };
  std::vector<Axis> axes;
  std::set<std::string> seen;
  size_t count = 1;
  for (auto it = sweep.begin(); it != sweep.end(); ++it) {
    const std::string where = plan.source + ": sweep.\"" + it.key() + "\"";
    Axis a;
    a.key = it.key();
    std::stringstream ks(it.key());
    std::string t;
    while (std::getline(ks, t, '+')) {
      check_target(t, base_pipeline, where);
      if (!seen.insert(t).second) throw ConfigError(where + ": `" + t + "` is swept twice");
      a.targets.push_back(t);
      plan.keys.push_back(t);
    }
    if (a.targets.empty() || it.key().back() == '+')
      throw ConfigError(where + ": `" + it.key() + "` is not `<node id>.<param>`");
    if (!it.value().is_array() || it.value().empty())
      throw ConfigError(where + ": an axis is a non-empty array of values, got " + it.value().dump());
    for (size_t k = 0; k < it.value().size(); ++k) {
      const json& v = it.value()[k];
      for (size_t m = 0; m < k; ++m)
        if (it.value()[m] == v)
          throw ConfigError(where + "[" + std::to_string(k) + "]: value " + v.dump() + " is listed twice");
      // Each value alone on the base config: an invalid one is reported at its own path.
      std::vector<std::pair<std::string, json>> one;
      for (auto& target : a.targets) one.push_back({target, v});
      build_case(plan.base, one, plan.source, where + "[" + std::to_string(k) + "] = " + v.dump());
      a.values.push_back(v);
    }
    count *= a.values.size();
    if (count > kMaxCases)
      throw ConfigError(plan.source + ": sweep: more than " + std::to_string(kMaxCases) + " cases");
    axes.push_back(std::move(a));
  }
  if (axes.empty())
    throw ConfigError(plan.source + ": sweep: no axis (give {\"<id>.<param>\": [values]} or {\"cases\": [...]})");
  std::map<std::string, size_t> names;
  for (size_t c = 0; c < count; ++c) {
    SweepCase sc;
    std::vector<std::string> parts;
    size_t rest = c;
    std::vector<size_t> pick(axes.size());
    for (size_t a = axes.size(); a-- > 0;) {
      pick[a] = rest % axes[a].values.size();
      rest /= axes[a].values.size();
    }
    for (size_t a = 0; a < axes.size(); ++a) {
      const json& v = axes[a].values[pick[a]];
      for (auto& target : axes[a].targets) sc.set.push_back({target, v});
      parts.push_back(axes[a].key + "=" + name_text(v));
    }
    sc.name = join(parts, ",");
    if (!names.emplace(sc.name, c).second)
      throw ConfigError(plan.source + ": sweep: two cases have the folder name `" + sc.name +
                        "` (values that differ only in punctuation)");
    plan.cases.push_back(std::move(sc));
  }
}

// Cases of `"sweep": {"cases": [{"name": ..., "set": {...}}, ...]}`.
void expand_named(const json& cases, const Pipeline& base_pipeline, SweepPlan& plan) {
  const std::string where0 = plan.source + ": sweep.cases";
  if (!cases.is_array() || cases.empty()) throw ConfigError(where0 + ": a non-empty array of {name, set} objects");
  static const std::regex name_re("[A-Za-z0-9_.+=,-]+");
  std::set<std::string> names;
  for (size_t i = 0; i < cases.size(); ++i) {
    const json& c = cases[i];
    const std::string where = where0 + "[" + std::to_string(i) + "]";
    if (!c.is_object()) throw ConfigError(where + ": each case is an object {name, set}");
    for (auto it = c.begin(); it != c.end(); ++it)
      if (it.key() != "name" && it.key() != "set")
        throw ConfigError(where + ": unknown key `" + it.key() + "`; valid keys: name, set");
    if (!c.contains("name") || !c["name"].is_string()) throw ConfigError(where + ": missing string `name`");
    SweepCase sc;
    sc.name = c["name"].get<std::string>();
    if (!std::regex_match(sc.name, name_re) || sc.name[0] == '.' || sc.name == "sweep.csv" || sc.name == "sweep.json")
      throw ConfigError(
          where + ": case name `" + sc.name +
          "` must use letters, digits and ._+=,- only, not start with `.`, and not be sweep.csv/sweep.json");
    if (!names.insert(sc.name).second) throw ConfigError(where + ": duplicate case name `" + sc.name + "`");
    const json set = c.value("set", json::object());
    if (!set.is_object()) throw ConfigError(where + ".set: an object {\"<node id>.<param>\": value}");
    for (auto it = set.begin(); it != set.end(); ++it) {
      const std::string w = where + ".set.\"" + it.key() + "\"";
      check_target(it.key(), base_pipeline, w);
      build_case(plan.base, {{it.key(), it.value()}}, plan.source, w + " = " + it.value().dump());
      sc.set.push_back({it.key(), it.value()});
      if (std::find(plan.keys.begin(), plan.keys.end(), it.key()) == plan.keys.end()) plan.keys.push_back(it.key());
    }
    plan.cases.push_back(std::move(sc));
  }
}

// Identity of each node's computation (type, canonical params, upstream identities); empty for nodes
// without connected inputs. Two cases with the same identity at a node compute the same artefact.
std::vector<std::string> computation_keys(const Pipeline& p) {
  const auto& nodes = p.nodes();
  std::vector<std::string> full(nodes.size()), key(nodes.size());
  std::function<const std::string&(int)> identity = [&](int v) -> const std::string& {
    if (full[v].empty()) {
      std::string k = nodes[v].spec->type + nodes[v].params.dump() + "(";
      for (int u : nodes[v].input_nodes) k += (u >= 0 ? identity(u) : std::string("-")) + ";";
      full[v] = k + ")";
    }
    return full[v];
  };
  for (size_t i = 0; i < nodes.size(); ++i)
    for (int u : nodes[i].input_nodes)
      if (u >= 0) key[i] = identity(int(i));
  return key;
}

// Reads the config, applies --set, expands and validates every case. \throw ConfigError
SweepPlan plan_sweep(const SweepOptions& o) {
  SweepPlan plan;
  plan.source = o.config.string();
  std::map<std::string, std::string> vars;
  if (!o.input.empty()) vars["input"] = o.input;
  json j = load_config_json(o.config, vars);
  if (!j.is_object() || !j.contains("sweep"))
    throw ConfigError(plan.source +
                      ": no `sweep` key: a sweep config holds \"sweep\": {\"<id>.<param>\": [values]} or "
                      "{\"cases\": [{\"name\": ..., \"set\": {...}}]} (see configs/sweeps/)");
  const json sweep = j["sweep"];
  j.erase("sweep");
  for (const std::string& s : o.sets) apply_override(j, s);
  plan.base = j;
  const Pipeline base_pipeline = Pipeline::build(parse_config(j, plan.source));
  if (!sweep.is_object() || sweep.empty())
    throw ConfigError(plan.source +
                      ": sweep: an object of axes {\"<id>.<param>\": [values]} or {\"cases\": [...]}, got " +
                      sweep.dump());
  if (sweep.contains("cases")) {
    if (sweep.size() != 1) throw ConfigError(plan.source + ": sweep: `cases` cannot be combined with axes");
    expand_named(sweep["cases"], base_pipeline, plan);
  } else {
    expand_axes(sweep, base_pipeline, plan);
  }
  for (const std::string& s : o.sets) {
    const std::string key = s.substr(0, s.find('='));
    if (std::find(plan.keys.begin(), plan.keys.end(), key) != plan.keys.end())
      throw ConfigError("--set " + s + ": `" + key + "` is swept by " + plan.source + "; edit the sweep instead");
  }
  std::map<std::string, int> first_with;
  for (size_t c = 0; c < plan.cases.size(); ++c) {
    const SweepCase& sc = plan.cases[c];
    plan.pipelines.push_back(
        build_case(plan.base, sc.set, plan.source, plan.source + ": sweep case `" + sc.name + "`"));
    try {
      plan.retries.push_back(retry_plan(case_config(plan.base, sc.set), plan.pipelines.back(), plan.source));
    } catch (const ConfigError& e) {
      throw ConfigError(plan.source + ": sweep case `" + sc.name + "`: " + strip_source(e.what(), plan.source));
    }
    for (const std::string& k : computation_keys(plan.pipelines.back())) {
      if (k.empty()) continue;
      auto [it, inserted] = first_with.emplace(k, int(c));
      if (!inserted && (plan.cases[c].depends_on < 0 || it->second < plan.cases[c].depends_on))
        plan.cases[c].depends_on = it->second;
    }
  }
  if (o.no_cache)
    for (SweepCase& sc : plan.cases) sc.depends_on = -1;
  return plan;
}

fs::path cache_dir(const SweepOptions& o) { return o.cache_dir.empty() ? o.out_dir / ".polyhex-cache" : o.cache_dir; }

int total_threads(const SweepOptions& o) {
  if (o.threads > 0) return o.threads;
  return std::max(1, int(std::thread::hardware_concurrency()));
}

// `--case NAME`: run one case in this process; the exit code is that of `polyhex run` without the
// inverted-hex code (the sweep reports inverted hexes in its table).
int run_one_case(const SweepOptions& o) {
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // the sweep ended (e.g. a second Ctrl-C): stop at a safe point
  SweepPlan plan = plan_sweep(o);
  size_t c = 0;
  while (c < plan.cases.size() && plan.cases[c].name != o.only_case) ++c;
  if (c == plan.cases.size()) {
    std::vector<std::string> names;
    for (auto& sc : plan.cases) names.push_back(sc.name);
    throw ConfigError("--case " + o.only_case + ": no such case in " + plan.source + "; cases: " + join(names, " "));
  }
  RunRequest req;
  req.config = o.config;
  req.input = o.input;
  req.out_dir = o.out_dir / o.only_case;
  req.threads = o.threads;
  req.cache_dir = cache_dir(o);
  req.no_cache = o.no_cache;
  req.verbosity = command_env().verbosity;
  fs::create_directories(req.out_dir);
  json cfg = case_config(plan.base, plan.cases[c].set);
  cfg["description"] = "sweep case `" + o.only_case + "` of " + plan.source;
  write_file_atomic(req.out_dir / "config.json", [&](std::ostream& out) { out << cfg.dump(2) << "\n"; });
  RunResult r = run_with_retry(plan.pipelines[c], plan.retries[c], req);
  if (!r.error.empty()) std::fprintf(stderr, "polyhex: %s: %s\n", r.status().c_str(), r.error.c_str());
  return r.interrupted ? 130 : r.error.empty() ? 0 : 1;
}

struct CaseOutcome {
  std::string status = "not_run";
  std::string error;
  int exit_code = -1;
  double seconds = 0;
  json report;  ///< report.json of the case, null when there is none
};

std::string last_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  return last;
}

pid_t spawn_case(const SweepOptions& o, const std::string& name, int threads) {
  const fs::path dir = o.out_dir / name;
  fs::create_directories(dir);
  fs::remove(dir / "report.json");  // a report left by an earlier sweep must not pass for this one
  std::vector<std::string> args = {"polyhex"};
  for (int v = 0; v < command_env().verbosity; ++v) args.push_back("-v");
  args.insert(args.end(), {"sweep", o.config.string(), "--case", name, "--out", o.out_dir.string(), "--threads",
                           std::to_string(threads)});
  if (!o.input.empty()) args.insert(args.end(), {"--input", o.input});
  for (const std::string& s : o.sets) args.insert(args.end(), {"--set", s});
  if (o.no_cache)
    args.push_back("--no-cache");
  else
    args.insert(args.end(), {"--cache", cache_dir(o).string()});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string log = (dir / "log.txt").string();
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  // Own process group: a Ctrl-C on the terminal reaches only the sweep, which forwards one SIGTERM
  // (a second signal would end a child at once, without its report).
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, "/proc/self/exe", &fa, &attr, argv.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) throw IOError("sweep: cannot start a process for case `" + name + "`: " + std::strerror(rc));
  return pid;
}

// Status of a finished child from its exit status and its report.json.
CaseOutcome collect(const fs::path& dir, int wstatus, double seconds) {
  CaseOutcome c;
  c.seconds = seconds;
  std::ifstream in(dir / "report.json");
  if (in) {
    try {
      c.report = json::parse(in);
    } catch (const json::exception&) {
      c.report = json();
    }
  }
  if (WIFSIGNALED(wstatus)) {
    c.status = "crashed";
    c.error = std::string("killed by signal ") + std::to_string(WTERMSIG(wstatus)) + " (" +
              strsignal(WTERMSIG(wstatus)) + "); see " + (dir / "log.txt").string();
    return c;
  }
  c.exit_code = WEXITSTATUS(wstatus);
  if (c.report.is_object() && c.report.contains("status")) {
    c.status = c.report["status"].get<std::string>();
    c.error = c.report.value("error", "");
  } else {
    c.status = c.exit_code == 130 ? "interrupted" : "error";
    c.error = last_line(dir / "log.txt");
    if (c.error.empty()) c.error = "exit code " + std::to_string(c.exit_code) + " and no report";
  }
  if (c.status == "ok" && c.exit_code != 0) {
    c.status = "error";
    c.error = last_line(dir / "log.txt");
  }
  return c;
}

json set_json(const SweepCase& sc) {
  json set = json::object();
  for (auto& [k, v] : sc.set) set[k] = v;
  return set;
}

// The effective value of `key` (id.param) in a case's pipeline.
json effective_value(const Pipeline& p, const std::string& key) {
  const auto dot = key.find('.');
  for (const ResolvedNode& n : p.nodes())
    if (n.id == key.substr(0, dot)) return n.params.value(key.substr(dot + 1), json());
  return json();
}

std::string csv_field(const json& v) {
  std::string s = v.is_null() ? "" : v.is_string() ? v.get<std::string>() : v.dump();
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return q + "\"";
}

// sweep.json and sweep.csv from the outcomes.
json write_summary(const SweepOptions& o, const SweepPlan& plan, const std::vector<CaseOutcome>& out, int jobs,
                   int threads_per_case, double seconds, bool was_interrupted) {
  const Pipeline& first = plan.pipelines.front();
  std::string quality_id;
  for (const ResolvedNode& n : first.nodes())
    if (n.spec->stage() == "quality") quality_id = n.id;
  int failed = 0;
  json cases = json::array();
  for (size_t c = 0; c < plan.cases.size(); ++c) {
    const SweepCase& sc = plan.cases[c];
    const CaseOutcome& r = out[c];
    json row;
    row["name"] = sc.name;
    row["dir"] = sc.name;
    row["status"] = r.status;
    row["error"] = r.error;
    row["exit_code"] = r.exit_code;
    row["seconds"] = r.seconds;
    row["set"] = set_json(sc);
    json values = json::object();
    for (const std::string& k : plan.keys) values[k] = effective_value(plan.pipelines[c], k);
    row["values"] = values;
    json quality = nullptr;
    const json* nodes = r.report.is_object() && r.report.contains("nodes") ? &r.report["nodes"] : nullptr;
    if (!quality_id.empty() && nodes && nodes->contains(quality_id) && (*nodes)[quality_id].value("ran", false)) {
      quality = json::object();
      const json& m = (*nodes)[quality_id]["metrics"];
      for (const char* k : kQualityKeys) quality[k] = m.value(k, json());
    }
    row["quality"] = quality;
    json nj = json::object();
    for (const ResolvedNode& n : plan.pipelines[c].nodes()) {
      json e = {{"type", n.spec->type}, {"seconds", nullptr}, {"cache_hit", nullptr}, {"ran", false}};
      if (nodes && nodes->contains(n.id)) {
        const json& rn = (*nodes)[n.id];
        e["seconds"] = rn.value("seconds", 0.0);
        e["cache_hit"] = rn.value("cache_hit", false);
        e["ran"] = rn.value("ran", false);
      }
      nj[n.id] = e;
    }
    row["nodes"] = nj;
    if (r.status != "ok") ++failed;
    cases.push_back(row);
  }
  json s;
  s["schema"] = kSweepSchema;
  s["polyhex_version"] = POLYHEX_VERSION;
  s["config"] = plan.source;
  s["input"] = o.input;
  s["sets"] = o.sets;
  s["out"] = o.out_dir.string();
  s["jobs"] = jobs;
  s["threads_per_case"] = threads_per_case;
  s["cache"] = o.no_cache ? json(nullptr) : json(cache_dir(o).string());
  s["swept"] = plan.keys;
  s["quality_node"] = quality_id.empty() ? json(nullptr) : json(quality_id);
  json node_list = json::array();
  for (const ResolvedNode& n : first.nodes()) node_list.push_back({{"id", n.id}, {"type", n.spec->type}});
  s["nodes"] = node_list;
  s["seconds"] = seconds;
  s["failed"] = failed;
  s["status"] = was_interrupted ? "interrupted" : failed ? "failed" : "ok";
  s["cases"] = cases;
  write_file_atomic(o.out_dir / "sweep.json", [&](std::ostream& f) { f << s.dump(2) << "\n"; });

  std::vector<std::string> header = {"case", "status"};
  for (auto& k : plan.keys) header.push_back(k);
  if (!quality_id.empty())
    for (const char* k : kQualityKeys) header.push_back(k);
  header.push_back("seconds");
  for (const ResolvedNode& n : first.nodes()) header.push_back(n.id + ".seconds");
  for (const ResolvedNode& n : first.nodes()) header.push_back(n.id + ".cache_hit");
  header.push_back("exit_code");
  header.push_back("error");
  write_file_atomic(o.out_dir / "sweep.csv", [&](std::ostream& f) {
    f << join(header, ",") << "\n";
    for (const json& row : cases) {
      std::vector<std::string> cells = {csv_field(row["name"]), csv_field(row["status"])};
      for (auto& k : plan.keys) cells.push_back(csv_field(row["values"][k]));
      if (!quality_id.empty())
        for (const char* k : kQualityKeys)
          cells.push_back(csv_field(row["quality"].is_object() ? row["quality"][k] : json()));
      cells.push_back(csv_field(row["seconds"]));
      for (const ResolvedNode& n : first.nodes()) cells.push_back(csv_field(row["nodes"][n.id]["seconds"]));
      for (const ResolvedNode& n : first.nodes()) cells.push_back(csv_field(row["nodes"][n.id]["cache_hit"]));
      cells.push_back(csv_field(row["exit_code"]));
      cells.push_back(csv_field(row["error"]));
      f << join(cells, ",") << "\n";
    }
  });
  return s;
}

int run_sweep(const SweepOptions& o) {
  if (!o.only_case.empty()) return run_one_case(o);
  SweepPlan plan = plan_sweep(o);
  const int threads = total_threads(o);
  const int jobs = std::max(1, std::min({o.jobs, threads, int(plan.cases.size())}));
  const int per_case = std::max(1, threads / jobs);
  if (o.list) {
    json list = json::array();
    for (const SweepCase& sc : plan.cases) {
      list.push_back({{"name", sc.name},
                      {"set", set_json(sc)},
                      {"depends_on", sc.depends_on < 0 ? json(nullptr) : json(plan.cases[sc.depends_on].name)}});
    }
    std::cout << json({{"swept", plan.keys}, {"jobs", jobs}, {"threads_per_case", per_case}, {"cases", list}}).dump(2)
              << "\n";
    return 0;
  }
  fs::create_directories(o.out_dir);
  std::fprintf(stderr, "polyhex sweep: %zu cases, %d at a time, %d threads each, cache %s\n", plan.cases.size(), jobs,
               per_case, o.no_cache ? "off" : cache_dir(o).c_str());

  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  std::vector<CaseOutcome> out(plan.cases.size());
  std::vector<bool> started(plan.cases.size(), false), finished(plan.cases.size(), false);
  std::map<pid_t, std::pair<size_t, clock::time_point>> running;
  size_t done = 0;
  bool forwarded = false;
  for (;;) {
    if (interrupted() && !forwarded) {  // SIGINT from a terminal reached the children too; SIGTERM may not have
      for (auto& [pid, c] : running) ::kill(pid, SIGTERM);
      forwarded = true;
    }
    if (!interrupted())
      for (size_t c = 0; c < plan.cases.size() && int(running.size()) < jobs; ++c) {
        const int dep = plan.cases[c].depends_on;
        if (started[c] || (dep >= 0 && !finished[dep])) continue;
        started[c] = true;
        running[spawn_case(o, plan.cases[c].name, per_case)] = {c, clock::now()};
        std::fprintf(stderr, "polyhex sweep: started  %s\n", plan.cases[c].name.c_str());
      }
    if (running.empty()) break;
    int wstatus = 0;
    const pid_t pid = ::waitpid(-1, &wstatus, WNOHANG);
    if (pid <= 0 || !running.count(pid)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    auto [c, t] = running[pid];
    running.erase(pid);
    finished[c] = true;
    out[c] = collect(o.out_dir / plan.cases[c].name, wstatus, std::chrono::duration<double>(clock::now() - t).count());
    ++done;
    std::fprintf(stderr, "polyhex sweep: [%zu/%zu] %s: %s in %.2f s%s%s\n", done, plan.cases.size(),
                 plan.cases[c].name.c_str(), out[c].status.c_str(), out[c].seconds, out[c].error.empty() ? "" : ": ",
                 out[c].error.c_str());
  }
  const bool was_interrupted = interrupted();
  const json summary = write_summary(o, plan, out, jobs, per_case,
                                     std::chrono::duration<double>(clock::now() - t0).count(), was_interrupted);
  int failed = 0;
  int width = 4;
  for (const SweepCase& sc : plan.cases) width = std::max(width, int(sc.name.size()));
  std::printf("%-*s %-11s %9s %9s %9s %9s\n", width, "case", "status", "seconds", "hexes", "inverted", "sj_min");
  for (const json& row : summary["cases"]) {
    const json& q = row["quality"];
    auto fig = [&](const char* k) { return q.is_object() && !q[k].is_null() ? q[k].dump() : std::string("-"); };
    std::printf("%-*s %-11s %9.2f %9s %9s %9.9s\n", width, row["name"].get<std::string>().c_str(),
                row["status"].get<std::string>().c_str(), row["seconds"].get<double>(), fig("hexes").c_str(),
                fig("inverted").c_str(), fig("sj_min").c_str());
    if (row["status"] != "ok") ++failed;
  }
  std::map<std::string, int> by_status;
  for (const json& row : summary["cases"]) ++by_status[row["status"].get<std::string>()];
  std::string counts;
  for (auto& [status, n] : by_status) counts += (counts.empty() ? "" : ", ") + std::to_string(n) + " " + status;
  std::fprintf(stderr, "polyhex sweep: %s%zu cases: %s; %s and %s\n", was_interrupted ? "interrupted; " : "",
               plan.cases.size(), counts.c_str(), (o.out_dir / "sweep.csv").c_str(),
               (o.out_dir / "sweep.json").c_str());
  return was_interrupted ? 130 : failed ? 1 : 0;
}

const bool registered = register_commands([](CLI::App& app, std::vector<Command>& out) {
  auto o = std::make_shared<SweepOptions>();
  auto* c = app.add_subcommand("sweep",
                               "run a config once per case of its `sweep`; OUT/sweep.csv, OUT/sweep.json, OUT/<case>/");
  c->add_option("config", o->config, "pipeline config (JSON) with a `sweep` key")->required();
  c->add_option("--input,-i", o->input, "value of ${input} in the config");
  c->add_option("--set,-s", o->sets, "override a param of every case: id.param=value (repeatable; not a swept param)");
  c->add_option("--out,-o", o->out_dir, "output folder (default polyhex-sweep)");
  c->add_option("--jobs", o->jobs, "cases run at the same time (default 1)")->check(CLI::Range(1, 256));
  c->add_option("--threads,-j", o->threads, "worker threads in all, split between the jobs (default: all cores)")
      ->check(CLI::Range(1, 4096));
  c->add_option("--cache", o->cache_dir, "artefact cache shared by the cases (default OUT/.polyhex-cache)");
  c->add_flag("--no-cache", o->no_cache, "no artefact cache: every case computes every node");
  c->add_option("--case", o->only_case, "run only this case, in this process (what the sweep's child processes do)");
  c->add_flag("--list", o->list, "print the cases (name, set, depends_on) as JSON and run nothing");
  out.push_back({c, [o] { return run_sweep(*o); }});
});

}  // namespace
}  // namespace polyhex
