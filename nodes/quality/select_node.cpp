/// @file select_node.cpp
/// @brief Binding of `select_hexes`: the best of the hex meshes built side by side (the branches of the
/// orientation search), by the rule the config's retry uses: fewest inverted hexes, then the highest
/// minimum scaled Jacobian, then the lowest candidate number.
#include "graph/node.h"
#include "nodes/algorithms/hex_quality.h"

#include <string>

namespace polyhex {
namespace {

constexpr int kCandidates = 8;

struct SelectParams {};

std::vector<PortSpec> candidate_ports() {
  std::vector<PortSpec> ports;
  for (int k = 1; k <= kCandidates; ++k)
    ports.push_back({"candidate_" + std::to_string(k), artefact_name<HexMesh>(), true});
  return ports;
}

const bool registered = register_node(make_node<SelectParams>(
    "select_hexes",
    "the best of up to 8 hex meshes (ports candidate_1..candidate_8; skipped ones are left out): fewest inverted "
    "hexes, then highest minimum scaled Jacobian, then the lowest port",
    ParamSet<SelectParams>(), candidate_ports(), artefact_name<HexMesh>(),
    [](const SelectParams&, const Inputs& in, NodeContext& ctx) {
      int best = -1;
      long best_inverted = 0;
      double best_min = 0;
      json all = json::array();
      for (int k = 0; k < kCandidates; ++k) {
        if (!in.has(size_t(k))) continue;
        const HexMesh& m = *in.get<HexMesh>(size_t(k));
        check_hex_mesh(m);
        Eigen::VectorXd sj, corner;
        hex_scaled_jacobians(m, sj, corner);
        const long inverted = long((corner.array() <= 0).count());
        const double sj_min = sj.minCoeff(), sj_avg = sj.mean();
        all.push_back({{"candidate", k + 1},
                       {"hexes", m.H.rows()},
                       {"inverted", inverted},
                       {"sj_min", sj_min},
                       {"sj_avg", sj_avg}});
        if (best < 0 || inverted < best_inverted || (inverted == best_inverted && sj_min > best_min))
          best = k, best_inverted = inverted, best_min = sj_min;
      }
      if (best < 0)
        throw InvalidInput(
            "no candidate mesh: every branch was skipped or failed (the report gives each failed node's branch_error)");
      ctx.metrics["candidates"] = all;
      ctx.metrics["chosen"] = best + 1;
      return in.items[size_t(best)];
    }));

}  // namespace
}  // namespace polyhex
