/// @file pad_node.cpp
/// @brief Binding of `pad/extrude` (paper §6: padding layer).
#include "nodes/pad/pad.h"

#include "graph/node.h"
#include "graph/stat_metrics.h"

namespace polyhex {
namespace {

using P = PadParams;

const bool registered = register_node(
    make_node<P>("pad/extrude", "§6 padding layer: every boundary quad extruded into a hex, inner copies moved inward",
                 ParamSet<P>()
                     .add("thickness", &P::thickness,
                          "inward offset of the inner layer, fraction of the local hex edge", 1e-3, 0.9)
                     .add("max_halvings", &P::max_halvings,
                          "times a vertex's offset may be halved to avoid inverted hexes", 0, 30)
                     .add("remove_doublets", &P::remove_doublets,
                          "first remove hexes at boundary doublets (boundary vertices in 2 quads)")
                     .add("peel_rounds", &P::peel_rounds,
                          "times boundary hexes with corner SJ <= peel_sj are removed first", 0, 20)
                     .add("peel_sj", &P::peel_sj, "see peel_rounds", -1.0, 0.5)
                     .add("repair_nonmanifold", &P::repair_nonmanifold,
                          "first remove hexes at non-manifold boundary edges and vertices (sheets touching along an "
                          "edge or at a vertex)")
                     .add("selective", &P::selective,
                          "pad only where the lattice turns otherwise than the surface; the layer ends on convex "
                          "creases")
                     .add("turn_tolerance", &P::turn_tolerance,
                          "degrees: a boundary edge whose lattice and surface turns differ by more is padded on both "
                          "sides",
                          0.0, 90.0)
                     .add("split_parts", &P::split_parts,
                          "selective: parts of the layer that meet on a convex crease are padded in turn, each ending "
                          "on it (false: one layer round the crease)"),
                 {{"hexes", artefact_name<HexMesh>()}, {"surface", artefact_name<SurfaceMesh>(), true}},
                 artefact_name<HexMesh>(),
                 [](const P& p, const Inputs& in, NodeContext& ctx) {
                   PadStats s;
                   auto surface = in.has(1) ? in.get<SurfaceMesh>(1) : nullptr;
                   HexMesh out = pad_boundary(*in.get<HexMesh>(0), surface.get(), p, &s);
                   put_stats(s, ctx.metrics);
                   ctx.metrics["hexes"] = out.H.rows();
                   if (s.nonmanifold_left > 0)
                     ctx.warn(std::to_string(s.nonmanifold_left) +
                              " non-manifold boundary edges / vertices left before padding");
                   if (s.inverted > 0)
                     ctx.warn(std::to_string(s.inverted) + " hexes inverted after padding (optimize untangles them)");
                   return make_artefact(std::move(out));
                 })
        .with_version("12"));

}  // namespace
}  // namespace polyhex
