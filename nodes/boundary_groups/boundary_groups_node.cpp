/// @file boundary_groups_node.cpp
/// @brief Binding of `boundary_groups`: named boundary groups (whole boundary, PolyCube charts, surface
/// patches) on the final hex mesh, for the writers.
#include "nodes/boundary_groups/boundary_groups.h"

#include "graph/node.h"
#include "graph/stat_metrics.h"

namespace polyhex {
namespace {

using P = BoundaryGroupsParams;

const bool registered = register_node(
    make_node<P>(
        "boundary_groups",
        "Named boundary groups for boundary conditions: `boundary`, `chart_<id>` per PolyCube chart, `patch_<id>` per "
        "surface patch bounded by sharp edges",
        ParamSet<P>()
            .add("charts", &P::charts, "one group per PolyCube chart (needs the map input)")
            .add("feature_angle", &P::feature_angle,
                 "one group per surface patch bounded by edges sharper than this many degrees (0 = none; needs the "
                 "surface "
                 "input)",
                 0.0, 179.0),
        {{"hexes", artefact_name<HexMesh>()},
         {"map", artefact_name<PolyCubeMap>(), true},
         {"surface", artefact_name<SurfaceMesh>(), true}},
        artefact_name<HexMesh>(),
        [](const P& p, const Inputs& in, NodeContext& ctx) {
          auto map = in.has(1) ? in.get<PolyCubeMap>(1) : nullptr;
          auto surface = in.has(2) ? in.get<SurfaceMesh>(2) : nullptr;
          BoundaryGroupsStats s;
          HexMesh out = add_boundary_groups(*in.get<HexMesh>(0), map.get(), surface.get(), p, &s);
          ctx.metrics["groups"] = out.groups.size();
          put_stats(s, ctx.metrics);
          if (s.facing_away > 0)
            ctx.warn(std::to_string(s.facing_away) +
                     " boundary faces took the chart or patch of a triangle facing the other way (a wall thinner than "
                     "a hex?)");
          return make_artefact(std::move(out));
        })
        .with_version("1"));

}  // namespace
}  // namespace polyhex
