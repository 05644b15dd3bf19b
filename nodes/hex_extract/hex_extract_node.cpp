/// @file hex_extract_node.cpp
/// @brief Binding of `hex_extract/lattice` (paper §6).
#include "nodes/hex_extract/hex_extract.h"

#include "graph/node.h"
#include "graph/stat_metrics.h"

namespace polyhex {
namespace {

using P = HexExtractParams;

const bool registered = register_node(make_node<P>(
    "hex_extract/lattice",
    "§6 hex mesh of a PolyCube map: lattice vertices (corners, edges, facets, volume) and centroids mapped "
    "back by barycentric coordinates, hexes by search within the volume",
    ParamSet<P>()
        .add("duplicate_distance", &P::duplicate_distance,
             "hex edges: a lattice point taken by a vertex mapped this close is a duplicate (paper: 5)", 0.5, 100.0)
        .add("search_margin", &P::search_margin,
             "lattice units: the hex search visits tets meeting its cube grown by this", 1e-3, 2.0)
        .add("perturbation", &P::perturbation, "lattice units: fixed tie-breaking offset of containment tests", 0.0,
             1e-3),
    {{"map", artefact_name<PolyCubeMap>()}}, artefact_name<HexMesh>(),
    [](const P& p, const Inputs& in, NodeContext& ctx) {
      HexExtractStats s;
      HexMesh out = extract_hexes(*in.get<PolyCubeMap>(0), p, &s);
      put_stats(s, ctx.metrics);
      if (s.exploded_tets > 0)
        ctx.warn(std::to_string(s.exploded_tets) + " tets of the map span more than " +
                 std::to_string(long(kMaxLatticePointsPerTet)) +
                 " lattice points (the map exploded there): not rasterised");
      if (s.hexes_skipped > 0)
        ctx.warn(std::to_string(s.hexes_skipped) + " hex centroids gave no complete hex (" +
                 std::to_string(s.unlocated) + " corners not found): the mesh has holes there");
      if (s.inverted > 0)
        ctx.warn(std::to_string(s.inverted) + " extracted hexes are inverted (before padding and optimization)");
      return make_artefact(std::move(out));
    }));

}  // namespace
}  // namespace polyhex
