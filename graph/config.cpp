#include "graph/config.h"

#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "runtime/errors.h"

namespace polyhex {

json substitute_vars(const json& j, const std::map<std::string, std::string>& vars, const std::string& source) {
  if (j.is_string()) {
    static const std::regex re(R"(\$\{([A-Za-z_][A-Za-z0-9_]*)(:-([^}]*))?\})");
    std::string s = j.get<std::string>(), out;
    auto begin = std::sregex_iterator(s.begin(), s.end(), re);
    size_t last = 0;
    for (auto it = begin; it != std::sregex_iterator(); ++it) {
      const std::smatch& m = *it;
      out += s.substr(last, m.position(0) - last);
      auto v = vars.find(m[1].str());
      if (v != vars.end() && !v->second.empty())
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
    for (auto it = r.begin(); it != r.end(); ++it) *it = substitute_vars(*it, vars, source);
    return r;
  }
  return j;
}

PipelineConfig parse_config(const json& j, const std::string& source) {
  PipelineConfig cfg;
  cfg.source = source;
  if (!j.is_object()) throw ConfigError(source + ": a config is a JSON object with a `nodes` array");
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "nodes" && it.key() != "description" && it.key() != "sweep" && it.key() != "retry")
      throw ConfigError(source + ": unknown top-level key `" + it.key() + "`; valid keys: nodes, description, sweep, retry");
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
    if (!n.contains("type") || !n["type"].is_string()) throw ConfigError(where + ": missing string `type`");
    nc.type = n["type"].get<std::string>();
    if (n.contains("params")) {
      if (!n["params"].is_object()) throw ConfigError(where + ": `params` must be an object");
      nc.params = n["params"];
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
