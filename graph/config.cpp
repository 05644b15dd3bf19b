#include "graph/config.h"

#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "runtime/errors.h"

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
      throw ConfigError(where + ": `${" + name + "}` is not a var of the config; vars: " +
                        (names.empty() ? "(none)" : names));
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
        it.key() != "vars")
      throw ConfigError(source + ": unknown top-level key `" + it.key() +
                        "`; valid keys: nodes, vars, description, sweep, retry");
  const json vars = j.contains("vars") ? j["vars"] : json::object();
  if (!vars.is_object()) throw ConfigError(source + ": `vars` must be an object {\"name\": value}");
  static const std::regex var_name_re("[A-Za-z_][A-Za-z0-9_]*");
  for (auto it = vars.begin(); it != vars.end(); ++it) {
    if (!std::regex_match(it.key(), var_name_re))
      throw ConfigError(source + ": vars: `" + it.key() + "` is not a name ([A-Za-z_][A-Za-z0-9_]*)");
    if (!it.value().is_number() && !it.value().is_string() && !it.value().is_boolean())
      throw ConfigError(source + ": vars." + it.key() + ": a number, string or boolean, got " + it.value().dump());
  }
  if (!j.contains("nodes") || !j["nodes"].is_array() || j["nodes"].empty())
    throw ConfigError(source + ": `nodes` must be a non-empty array");
  std::set<std::string> ids;
  static const std::regex id_re("[A-Za-z0-9_-]+");
  size_t index = 0;
  for (const json& n : j["nodes"]) {
    std::string where = source + ": nodes[" + std::to_string(index++) + "]";
    if (!n.is_object()) throw ConfigError(where + ": each node is an object {id, type, params, inputs}");
    for (auto it = n.begin(); it != n.end(); ++it)
      if (it.key() != "id" && it.key() != "type" && it.key() != "params" && it.key() != "inputs")
        throw ConfigError(where + ": unknown key `" + it.key() + "`; valid keys: id, type, params, inputs");
    if (!n.contains("id") || !n["id"].is_string()) throw ConfigError(where + ": missing string `id`");
    NodeConfig nc;
    nc.id = n["id"].get<std::string>();
    where = source + ": node `" + nc.id + "`";
    if (!std::regex_match(nc.id, id_re)) throw ConfigError(where + ": an id uses only letters, digits, _ and -");
    if (!ids.insert(nc.id).second) throw ConfigError(where + ": duplicate id");
    if (nc.id == "vars") throw ConfigError(where + ": `vars` is reserved (`--set vars.NAME=value` sets a config var)");
    if (!n.contains("type") || !n["type"].is_string()) throw ConfigError(where + ": missing string `type`");
    nc.type = n["type"].get<std::string>();
    if (n.contains("params")) {
      if (!n["params"].is_object()) throw ConfigError(where + ": `params` must be an object");
      nc.params = resolve_value(n["params"], vars, where);
    }
    if (n.contains("inputs")) {
      const json& in = n["inputs"];
      bool ok = in.is_object() || in.is_array();
      for (auto& v : in) ok = ok && v.is_string();
      if (!ok) throw ConfigError(where + ": `inputs` must map port names to node ids, or list node ids");
      nc.inputs = in;
    }
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
