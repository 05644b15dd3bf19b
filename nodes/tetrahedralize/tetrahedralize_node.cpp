/// @file tetrahedralize_node.cpp
/// @brief Binding of `tetrahedralize/tetgen`: SurfaceMesh -> TetMesh.
#include "graph/node.h"
#include "graph/stat_metrics.h"
#include "nodes/tetrahedralize/tetgen.h"

namespace polyhex {
namespace {

const bool registered = register_node(
    make_node<TetgenParams>(
        "tetrahedralize/tetgen", "TetGen isotropic tet mesh of a closed surface",
        ParamSet<TetgenParams>()
            .add("edge_length", &TetgenParams::edge_length,
                 "target tet edge, fraction of the reference length (the tightest bounding-box diagonal over all "
                 "orientations)",
                 0.002, 0.5)
            .add("radius_edge", &TetgenParams::radius_edge, "bound on circumradius / shortest edge (TetGen -q)", 1.1,
                 10.0)
            .add("min_dihedral", &TetgenParams::min_dihedral, "dihedral angle bound in degrees (TetGen -q ratio/angle)",
                 0.0, 18.0)
            .add("refine_surface", &TetgenParams::refine_surface,
                 "let TetGen refine the surface triangles (false: keep them as they are, -Y)")
            .add("max_tets", &TetgenParams::max_tets,
                 "refuse up front when the estimated tet count (enclosed volume / regular tet of edge h) exceeds this",
                 1000, 2000000000),
        {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<TetMesh>(),
        [](const TetgenParams& p, const Inputs& in, NodeContext& ctx) {
          TetgenStats s;
          auto mesh = tetrahedralize(*in.get<SurfaceMesh>(0), p, &s);
          put_stats(s, ctx.metrics);
          if (s.aborted_attempts > 0)
            ctx.warnings.push_back(
                "TetGen failed one of its internal checks (an assertion) in the input's frame; the "
                "tets were made in a turned frame (" +
                std::to_string(s.aborted_attempts) + " attempt(s) lost, the mesh is as valid)");
          return make_artefact(std::move(mesh));
        })
        .with_version("3"));  // 2: normalized coordinates for TetGen, max_tets; 3: aborted_attempts

}  // namespace
}  // namespace polyhex
