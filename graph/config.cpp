#include "graph/config.h"

#include "runtime/errors.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <regex>
#include <set>
#include <sstream>

namespace polyhex {

namespace {

const std::regex& var_regex() {
  static const std::regex re(R"(\$\{([A-Za-z_][A-Za-z0-9_]*)(:-([^}]*))?\})");
  return re;
}

// Names of the config's own `vars` block (left for resolve_config_vars by substitute_vars).
std::set<std::string> config_var_names(const json& j) {
  std::set<std::string> names;
  if (j.is_object() && j.contains("vars") && j["vars"].is_object())
    for (auto it = j["vars"].begin(); it != j["vars"].end(); ++it) names.insert(it.key());
  if (j.is_object() && j.contains("branches")) names.insert("branch");  // each copy's number
  return names;
}

json substitute(const json& j, const std::map<std::string, std::string>& vars, const std::set<std::string>& keep,
                const std::string& source) {
  if (j.is_string()) {
    const std::regex& re = var_regex();
    std::string s = j.get<std::string>(), out;
    auto begin = std::sregex_iterator(s.begin(), s.end(), re);
    size_t last = 0;
    for (auto it = begin; it != std::sregex_iterator(); ++it) {
      const std::smatch& m = *it;
      out += s.substr(last, m.position(0) - last);
      auto v = vars.find(m[1].str());
      if (keep.count(m[1].str()))
        out += m.str(0);
      else if (v != vars.end() && !v->second.empty())
        out += v->second;
      else if (m[2].matched)
        out += m[3].str();
      else
        throw ConfigError(source + ": `${" + m[1].str() + "}` has no value (pass --" + m[1].str() + ")");
      last = m.position(0) + m.length(0);
    }
    out += s.substr(last);
    return out;
  }
  if (j.is_array() || j.is_object()) {
    json r = j;
    for (auto it = r.begin(); it != r.end(); ++it) *it = substitute(*it, vars, keep, source);
    return r;
  }
  return j;
}

// `${name}` of the config's `vars` in one param value: a string that is exactly one reference takes
// the var's value with its JSON type (a number stays a number); a reference inside a longer string is
// replaced by the value's text.
json resolve_value(const json& j, const json& vars, const std::string& where) {
  if (j.is_array() || j.is_object()) {
    json r = j;
    for (auto it = r.begin(); it != r.end(); ++it) *it = resolve_value(*it, vars, where);
    return r;
  }
  if (!j.is_string()) return j;
  const std::string s = j.get<std::string>();
  std::smatch m;
  auto value_of = [&](const std::string& name) -> const json& {
    if (!vars.contains(name)) {
      std::string names;
      for (auto it = vars.begin(); it != vars.end(); ++it) names += (names.empty() ? "" : ", ") + it.key();
      throw ConfigError(where + ": `${" + name +
                        "}` is not a var of the config; vars: " + (names.empty() ? "(none)" : names));
    }
    return vars[name];
  };
  if (std::regex_match(s, m, var_regex()) && !m[2].matched) return value_of(m[1].str());
  std::string out;
  size_t last = 0;
  for (auto it = std::sregex_iterator(s.begin(), s.end(), var_regex()); it != std::sregex_iterator(); ++it) {
    const json& v = value_of((*it)[1].str());
    out += s.substr(last, size_t(it->position(0)) - last) + (v.is_string() ? v.get<std::string>() : v.dump());
    last = size_t(it->position(0) + it->length(0));
  }
  return last == 0 ? j : json(out + s.substr(last));
}

// The config's vars with every product ("2 * ${hex_edge}") evaluated to its number. A product is a
// string of numbers and `${var}` references joined by `*`; its vars must be numbers or products.
json evaluate_vars(const json& vars, const std::string& source) {
  static const std::regex term(R"(\s*(\$\{([A-Za-z_][A-Za-z0-9_]*)\}|[-+]?[0-9]*\.?[0-9]+([eE][-+]?[0-9]+)?)\s*)");
  json out = vars;
  std::map<std::string, int> state;  // 1 = being evaluated, 2 = done
  std::function<json(const std::string&)> value = [&](const std::string& name) -> json {
    const std::string where = source + ": vars." + name;
    if (state[name] == 2) return out[name];
    if (state[name] == 1) throw ConfigError(where + ": the vars refer to each other in a cycle");
    const json& v = vars[name];
    if (!v.is_string() || v.get<std::string>().find("${") == std::string::npos) {
      state[name] = 2;
      return v;
    }
    state[name] = 1;
    const std::string s = v.get<std::string>();
    double product = 1;
    size_t pos = 0;
    while (true) {
      std::smatch m;
      const std::string rest = s.substr(pos);
      if (!std::regex_search(rest, m, term, std::regex_constants::match_continuous))
        throw ConfigError(where + ": `" + s + "` is not a product of numbers and ${var}s (like \"2 * ${hex_edge}\")");
      if (m[2].matched) {
        if (!vars.contains(m[2].str()))
          throw ConfigError(where + ": `${" + m[2].str() + "}` is not a var of the config");
        const json f = value(m[2].str());
        if (!f.is_number()) throw ConfigError(where + ": `${" + m[2].str() + "}` is not a number (" + f.dump() + ")");
        product *= f.get<double>();
      } else {
        product *= std::strtod(m[1].str().c_str(), nullptr);  // not std::stod: 1e999 is an answer, not a throw
      }
      if (!std::isfinite(product))
        throw ConfigError(where + ": `" + s + "` is not a finite number (a factor or the product overflows)");
      pos += size_t(m.length(0));
      if (pos == s.size()) break;
      if (s[pos] != '*')
        throw ConfigError(where + ": `" + s + "` is not a product of numbers and ${var}s (like \"2 * ${hex_edge}\")");
      ++pos;
    }
    state[name] = 2;
    return out[name] = product;
  };
  for (auto it = vars.begin(); it != vars.end(); ++it) value(it.key());
  return out;
}

// The config's nodes with its `branches` block expanded: each listed node becomes `count` copies `id#1`
// .. `id#count`, in place of the first listed node, whose inputs naming listed nodes name the copy of
// the same branch. `branch_of` gets each output node's branch (0 outside).
json expand_branches(const json& j, const std::string& source, std::vector<int>& branch_of) {
  const json& nodes = j["nodes"];
  branch_of.assign(nodes.size(), 0);
  if (!j.contains("branches")) return nodes;
  const std::string where = source + ": branches";
  const json& b = j["branches"];
  if (!b.is_object()) throw ConfigError(where + ": an object {\"count\": N, \"nodes\": [ids]}");
  for (auto it = b.begin(); it != b.end(); ++it)
    if (it.key() != "count" && it.key() != "nodes")
      throw ConfigError(where + ": unknown key `" + it.key() + "`; valid keys: count, nodes");
  if (!b.contains("count") || !b["count"].is_number_integer() || b["count"].get<int>() < 1 || b["count"].get<int>() > 8)
    throw ConfigError(where + ".count: an integer in [1, 8]");
  const int count = b["count"].get<int>();
  if (!b.contains("nodes") || !b["nodes"].is_array() || b["nodes"].empty())
    throw ConfigError(where + ".nodes: a non-empty array of node ids");
  std::set<std::string> listed, ids;
  for (const json& n : nodes)
    if (n.is_object() && n.contains("id") && n["id"].is_string()) ids.insert(n["id"].get<std::string>());
  for (const json& id : b["nodes"]) {
    if (!id.is_string()) throw ConfigError(where + ".nodes: a non-empty array of node ids");
    if (!ids.count(id.get<std::string>()))
      throw ConfigError(where + ".nodes: no node with id `" + id.get<std::string>() + "`");
    if (!listed.insert(id.get<std::string>()).second)
      throw ConfigError(where + ".nodes: `" + id.get<std::string>() + "` listed twice");
  }
  auto is_listed = [&](const json& n) {
    return n.is_object() && n.contains("id") && n["id"].is_string() && listed.count(n["id"].get<std::string>());
  };
  json out = json::array();
  std::vector<int> of;
  bool placed = false;
  for (const json& n : nodes) {
    if (!is_listed(n)) {
      if (n.is_object() && n.contains("inputs") && (n["inputs"].is_object() || n["inputs"].is_array()))
        for (const json& from : n["inputs"])
          if (from.is_string() && listed.count(from.get<std::string>()))
            throw ConfigError(source + ": node `" + n.value("id", std::string("?")) + "`: input `" +
                              from.get<std::string>() + "` is a branch node: name one copy, `" +
                              from.get<std::string>() + "#1` to `" + from.get<std::string>() + "#" +
                              std::to_string(count) + "`");
      out.push_back(n);
      of.push_back(0);
      continue;
    }
    if (placed) continue;
    placed = true;
    for (int k = 1; k <= count; ++k)
      for (const json& m : nodes) {
        if (!is_listed(m)) continue;
        json c = m;
        c["id"] = m["id"].get<std::string>() + "#" + std::to_string(k);
        if (c.contains("inputs") && (c["inputs"].is_object() || c["inputs"].is_array()))
          for (json& from : c["inputs"])
            if (from.is_string() && listed.count(from.get<std::string>()))
              from = from.get<std::string>() + "#" + std::to_string(k);
        out.push_back(c);
        of.push_back(k);
      }
  }
  branch_of = of;
  return out;
}

}  // namespace

json substitute_vars(const json& j, const std::map<std::string, std::string>& vars, const std::string& source) {
  return substitute(j, vars, config_var_names(j), source);
}

PipelineConfig parse_config(const json& j, const std::string& source) {
  PipelineConfig cfg;
  cfg.source = source;
  if (!j.is_object()) throw ConfigError(source + ": a config is a JSON object with a `nodes` array");
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "nodes" && it.key() != "description" && it.key() != "sweep" && it.key() != "retry" &&
        it.key() != "vars" && it.key() != "branches")
      throw ConfigError(source + ": unknown top-level key `" + it.key() +
                        "`; valid keys: nodes, vars, branches, description, sweep, retry");
  json vars = j.contains("vars") ? j["vars"] : json::object();
  if (!vars.is_object()) throw ConfigError(source + ": `vars` must be an object {\"name\": value}");
  static const std::regex var_name_re("[A-Za-z_][A-Za-z0-9_]*");
  for (auto it = vars.begin(); it != vars.end(); ++it) {
    if (!std::regex_match(it.key(), var_name_re))
      throw ConfigError(source + ": vars: `" + it.key() + "` is not a name ([A-Za-z_][A-Za-z0-9_]*)");
    if (!it.value().is_number() && !it.value().is_string() && !it.value().is_boolean())
      throw ConfigError(source + ": vars." + it.key() + ": a number, string or boolean, got " + it.value().dump());
  }
  vars = evaluate_vars(vars, source);
  if (!j.contains("nodes") || !j["nodes"].is_array() || j["nodes"].empty())
    throw ConfigError(source + ": `nodes` must be a non-empty array");
  if (j.contains("branches") && vars.contains("branch"))
    throw ConfigError(source +
                      ": vars: `branch` is reserved in a config with branches (`${branch}` is the copy's number)");
  std::vector<int> branch_of;
  const json nodes = expand_branches(j, source, branch_of);
  std::set<std::string> ids;
  static const std::regex id_re("[A-Za-z0-9_-]+(#[0-9])?");
  size_t index = 0;
  for (const json& n : nodes) {
    const int branch = branch_of[index];
    std::string where = source + ": nodes[" + std::to_string(index++) + "]";
    if (!n.is_object()) throw ConfigError(where + ": each node is an object {id, type, params, inputs}");
    for (auto it = n.begin(); it != n.end(); ++it)
      if (it.key() != "id" && it.key() != "type" && it.key() != "params" && it.key() != "inputs")
        throw ConfigError(where + ": unknown key `" + it.key() + "`; valid keys: id, type, params, inputs");
    if (!n.contains("id") || !n["id"].is_string()) throw ConfigError(where + ": missing string `id`");
    NodeConfig nc;
    nc.id = n["id"].get<std::string>();
    where = source + ": node `" + nc.id + "`";
    if (!std::regex_match(nc.id, id_re) || (branch == 0 && nc.id.find('#') != std::string::npos))
      throw ConfigError(where + ": an id uses only letters, digits, _ and -");
    if (!ids.insert(nc.id).second) throw ConfigError(where + ": duplicate id");
    if (nc.id == "vars") throw ConfigError(where + ": `vars` is reserved (`--set vars.NAME=value` sets a config var)");
    if (!n.contains("type") || !n["type"].is_string()) throw ConfigError(where + ": missing string `type`");
    nc.type = n["type"].get<std::string>();
    if (n.contains("params")) {
      if (!n["params"].is_object()) throw ConfigError(where + ": `params` must be an object");
      json scope = vars;
      if (branch > 0) scope["branch"] = branch;
      nc.params = resolve_value(n["params"], scope, where);
    }
    if (n.contains("inputs")) {
      const json& in = n["inputs"];
      bool ok = in.is_object() || in.is_array();
      for (auto& v : in) ok = ok && v.is_string();
      if (!ok) throw ConfigError(where + ": `inputs` must map port names to node ids, or list node ids");
      nc.inputs = in;
    }
    nc.branch = branch;
    cfg.nodes.push_back(std::move(nc));
  }
  return cfg;
}

json load_config_json(const std::filesystem::path& path, const std::map<std::string, std::string>& vars) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path.string() + ": cannot open config file");
  std::stringstream ss;
  ss << in.rdbuf();
  json j;
  try {
    j = json::parse(ss.str());
  } catch (const json::parse_error& e) {
    throw ConfigError(path.string() + ": not valid JSON: " + e.what());
  } catch (const json::exception& e) {
    // e.g. out_of_range 406 for a number beyond a double (1e400)
    throw ConfigError(path.string() + ": unusable JSON: " + e.what());
  }
  return substitute_vars(j, vars, path.string());
}

void apply_override(json& config, const std::string& assignment) {
  auto eq = assignment.find('=');
  auto dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 || dot + 1 == eq)
    throw ConfigError("--set " + assignment + ": expected id.param=value");
  std::string id = assignment.substr(0, dot), param = assignment.substr(dot + 1, eq - dot - 1);
  std::string text = assignment.substr(eq + 1);
  json value;
  try {
    value = json::parse(text);
  } catch (const json::parse_error&) {
    value = text;
  }
  try {
    set_param(config, id, param, value);
  } catch (const ConfigError& e) {
    throw ConfigError("--set " + assignment + ": " + e.what());
  }
}

std::string strip_source(const std::string& msg, const std::string& source) {
  return msg.rfind(source + ": ", 0) == 0 ? msg.substr(source.size() + 2) : msg;
}

void set_param(json& config, const std::string& id, const std::string& param, const json& value) {
  if (id == "vars") {
    if (config.is_object() && config.contains("vars") && config["vars"].is_object() && config["vars"].contains(param)) {
      config["vars"][param] = value;
      return;
    }
    std::string names;
    for (const std::string& n : config_var_names(config)) names += (names.empty() ? "" : ", ") + n;
    throw ConfigError("the config has no var `" + param + "`; vars: " + (names.empty() ? "(none)" : names));
  }
  std::string ids;
  if (config.is_object() && config.contains("nodes") && config["nodes"].is_array()) {
    for (json& n : config["nodes"]) {
      if (!n.is_object() || !n.contains("id") || !n["id"].is_string()) continue;
      if (n["id"] == id) {
        if (!n.contains("params")) n["params"] = json::object();
        n["params"][param] = value;
        return;
      }
      ids += (ids.empty() ? "" : ", ") + n["id"].get<std::string>();
    }
  }
  throw ConfigError("no node with id `" + id + "`; ids: " + ids);
}

}  // namespace polyhex
