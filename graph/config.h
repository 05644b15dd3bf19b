/// @file config.h
/// @brief Pipeline configs: JSON `{"vars": {...}, "nodes": [{id, type, params, inputs}]}`, `${var}`
/// substitution and `--set id.param=value` overrides.
///
/// Two kinds of `${name}`: command-line vars (`--input FILE` is `${input}`), replaced when the file is
/// loaded, and the config's own `vars` block (`"vars": {"tet_edge": 0.02}`), replaced in the node params
/// when the config is parsed, after every override: one value that several params follow (the tet size
/// used by the surface conditioning and by TetGen). `--set vars.tet_edge=0.03`, a sweep axis
/// `vars.tet_edge` and a retry variant's `"vars.tet_edge"` change it; `--set tets.edge_length=0.03`
/// still sets that one param alone. A var may be a product of numbers and other vars, `"tet_edge":
/// "2 * ${hex_edge}"`: one value (`--hex-edge`, `--set vars.hex_edge=...`) then sets both sizes.
///
/// `"branches": {"count": N, "nodes": [ids]}` runs the listed nodes N times side by side: each becomes
/// the copies `id#1` .. `id#N`, whose inputs naming listed nodes name the copy of the same branch, and
/// in whose params `${branch}` is the copy's number. Nodes outside name one copy (`unframe#2`); `--set
/// id.param`, sweeps and retry variants set the param of every copy. The orientation search uses it
/// (one branch per candidate frame; docs/orientation.md).
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace polyhex {

using json = nlohmann::json;

/// One node as written in a config.
struct NodeConfig {
  std::string id;    ///< unique name, [A-Za-z0-9_-]+
  std::string type;  ///< "stage" or "stage/variant"
  json params = json::object();
  /// port name -> id of the producing node. A config may give `inputs` as an object
  /// {"port": "id"} or as an array of ids in port order (resolved against the node spec).
  json inputs = json::object();
  int branch = 0;  ///< the copy's number for a node of the config's `branches` (id `name#branch`), else 0
};

struct PipelineConfig {
  std::vector<NodeConfig> nodes;
  std::string source;  ///< file name or "<string>", for messages
};

/// Replaces `${name}` and `${name:-default}` in every string of `j` by vars[name] (or the default),
/// except the names of j's own `vars` block, which parse_config resolves.
/// \throw ConfigError naming `source` when a variable has no value and no default.
json substitute_vars(const json& j, const std::map<std::string, std::string>& vars, const std::string& source);

/// Checks the structure of a config (top-level object with a `nodes` array, each node an object with
/// string `id` and `type`, optional object `params`, object-or-array `inputs`, no other keys, unique ids).
/// The optional top-level `description`, `sweep` (tools/sweep.cpp) and `retry` (tools/cli_run.h) are
/// checked by their users. `vars` (name -> number, string, boolean or a product like "2 * ${hex_edge}")
/// is substituted into the params: a param that is exactly `"${name}"` takes the var's value and type.
/// `branches` is expanded (see above).
/// \throw ConfigError naming the source and the node (a reference to an undefined var lists the vars;
///        the id `vars` is reserved; a var product that does not parse or refers in a cycle; a branch
///        node named by a node outside without its copy's number).
PipelineConfig parse_config(const json& j, const std::string& source);

/// Reads a JSON config file, then substitutes variables.
/// \throw ConfigError when the file is missing or not valid JSON (with the parser's position).
json load_config_json(const std::filesystem::path& path, const std::map<std::string, std::string>& vars);

/// `msg` without a leading "`source`: " (to re-prefix a config error with a more precise place).
std::string strip_source(const std::string& msg, const std::string& source);

/// Sets param `param` of the node with id `id` in the config JSON to `value` (creating its `params`);
/// id `vars` sets the config var `param` instead.
/// \throw ConfigError "no node with id `ID`; ids: ..." when no node has that id; "the config has no var"
///        for an undefined var.
void set_param(json& config, const std::string& id, const std::string& param, const json& value);

/// Applies `id.param=value` to the config JSON. The value is parsed as JSON when it parses
/// (numbers, true/false, quoted strings), else taken as a plain string.
/// \throw ConfigError when the syntax is wrong or no node has that id (lists the ids).
void apply_override(json& config, const std::string& assignment);

}  // namespace polyhex
