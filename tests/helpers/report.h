// Reading report.json in end-to-end tests. Header-only.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace polyhex::test {

/// The report's node `id`, or, for a node of the orientation branches, its copy in the branch the run
/// kept (`id#k`, k = nodes.best.metrics.chosen). A null JSON when there is neither.
inline nlohmann::json kept_node(const nlohmann::json& report, const std::string& id) {
  const nlohmann::json& nodes = report["nodes"];
  if (nodes.contains(id)) return nodes[id];
  if (!nodes.contains("best")) return nullptr;
  const std::string copy = id + "#" + std::to_string(nodes["best"]["metrics"]["chosen"].get<int>());
  return nodes.contains(copy) ? nodes[copy] : nlohmann::json();
}

}  // namespace polyhex::test
