/// @file split_node.cpp
/// @brief Binding of `hex_from_tets/split`, the all-hex baseline (4 hexes per tet).
#include "nodes/hex_from_tets/split.h"

#include "graph/node.h"

namespace polyhex {
namespace {

const bool registered = register_node(make_node<SplitParams>(
    "hex_from_tets/split",
    "BASELINE, not the PolyCube method: splits every tet into 4 hexes (corner, edge midpoints, face centres, "
    "centroid); valid and conforming but every vertex irregular",
    ParamSet<SplitParams>(), {{"tets", artefact_name<TetMesh>()}}, artefact_name<HexMesh>(),
    [](const SplitParams&, const Inputs& in, NodeContext& ctx) {
      HexMesh out = split_tets_to_hexes(*in.get<TetMesh>(0));
      ctx.metrics["hexes"] = out.H.rows();
      ctx.metrics["vertices"] = out.V.rows();
      return make_artefact(std::move(out));
    }));

}  // namespace
}  // namespace polyhex
