/// @file position_deform_node.cpp
/// @brief Binding of `position_deform/chart_planes` (paper §5.2): tets, deformed tets, segmentation -> PolyCubeMap.
#include "nodes/position_deform/position_deform.h"

#include "graph/node.h"
#include "graph/stat_metrics.h"
#include "nodes/formats/polycube_vtk.h"
#include "nodes/formats/tetmesh_io.h"

namespace polyhex {
namespace {

using P = PositionDeformParams;

const bool registered = register_node(
    make_node<P>(
        "position_deform/chart_planes",
        "§5.2 PolyCube map: charts onto integer planes (hex edge units), distance constraints, MVC Laplace",
        ParamSet<P>()
            .add("edge_length", &P::edge_length, "hex edge length, fraction of the input's reference length", 1e-4, 0.5)
            .add_enum("lattice_spacing", &P::lattice_spacing,
                      {{LatticeSpacing::polycube, "polycube"}, {LatticeSpacing::input_volume, "input_volume"}},
                      "the lattice spacing on the PolyCube: the hex edge (polycube, the paper), or scaled by the cube "
                      "root of the Poisson map's volume ratio so that the lattice has about input volume / h^3 cells "
                      "(input_volume)")
            .add("distance_weight", &P::distance_weight, "scale of the same-axis chart distance constraints (0 = off)",
                 0.0, 1e6)
            .add_enum("final_solve", &P::final_solve,
                      {{FinalSolve::mvc_laplace, "mvc_laplace"}, {FinalSolve::poisson, "poisson"}},
                      "final solve with pinned charts: mean value Laplace (paper) or Poisson")
            .add_enum("level_placement", &P::level_placement,
                      {{LevelPlacement::balanced, "balanced"}, {LevelPlacement::push_up, "push_up"}},
                      "chart levels keeping the orders apart: weighted least-squares placement, or the push of each "
                      "chart above those below it")
            .add("poisson_direct_max", &P::poisson_direct_max,
                 "the Poisson step is factored up to this many unknowns, solved by conjugate gradients above", 0,
                 2000000000)
            .add("final_jacobi_iterations", &P::final_jacobi_iterations,
                 "mvc_laplace: BiCGSTAB iterations with the diagonal preconditioner before the incomplete LU (0 = ILU "
                 "at once, the default, or 5,000 above final_ilu_max: see position_deform.h)",
                 0, 1000000)
            .add("final_ilu_max", &P::final_ilu_max,
                 "mvc_laplace: a final system with more unknowns starts with the diagonal preconditioner", 0,
                 2000000000)
            .add("untangle_iterations", &P::untangle_iterations,
                 "L-BFGS iterations of the map's untangling (0 = keep the folds)", 0, 1000000)
            .add("untangle_rings", &P::untangle_rings,
                 "the untangling moves the inverted tets' vertices grown by this many rings", 0, 50)
            .add("untangle_shrink", &P::untangle_shrink,
                 "the untangling's rounds after the first move only the tets still inverted grown by untangle_rings "
                 "rings")
            .add("untangle_seconds", &P::untangle_seconds, "wall-time cap of the untangling (0 = none)", 0.0, 3600.0)
            .add_enum("map_polish", &P::map_polish,
                      {{MapPolish::region, "region"}, {MapPolish::everywhere, "everywhere"}},
                      "after the untangling, the barrier polish of the untangled region or of the whole map")
            .add("map_polish_iterations", &P::map_polish_iterations, "L-BFGS iterations of the polish (0 = none)", 0,
                 100000)
            .add_enum("map_polish_preconditioner", &P::map_polish_preconditioner,
                      {{PolishPreconditioner::none, "none"},
                       {PolishPreconditioner::cholesky, "laplacian"},
                       {PolishPreconditioner::incomplete_cholesky, "incomplete_laplacian"}},
                      "the polish's L-BFGS plain, or preconditioned by the map energy's stiffness: its Cholesky factor "
                      "(laplacian) or its incomplete Cholesky factor (incomplete_laplacian); fewer iterations")
            .add("max_hexes", &P::max_hexes, "refuse up front when volume / h^3 exceeds this", 1e3, 2e9)
            .add("feature_lines", &P::feature_lines,
                 "creases inside a chart, straight along an axis of its plane, are put on lattice lines")
            .add("feature_line_room", &P::feature_line_room,
                 "a feature line between two charts of its axis facing each other (a V-slot's bottom between its "
                 "walls) gets a level between them: the two are put 2 levels apart (off by default)"),
        {{"tets", artefact_name<TetMesh>()},
         {"deformed", artefact_name<TetMesh>()},
         {"segmentation", artefact_name<PolyCubeSegmentation>()}},
        artefact_name<PolyCubeMap>(),
        [](const P& p, const Inputs& in, NodeContext& ctx) {
          PositionDeformStats s;
          PolyCubeMap m = position_deform(in.get<TetMesh>(0), *in.get<TetMesh>(1), in.get<PolyCubeSegmentation>(2), p,
                                          &s, ctx.progress_fn());
          put_stats(s, ctx.metrics);
          ctx.metrics["edge_length_abs"] = m.edge_length;
          if (s.flipped_after_rounding > 0)
            ctx.warn(std::to_string(s.flipped_after_rounding) +
                     " same-axis chart pairs could not keep their order after rounding");
          if (s.merged_same_axis_charts > 0)
            ctx.warn(std::to_string(s.merged_same_axis_charts) +
                     " same-axis charts share a vertex and were put on one plane");
          return make_artefact(std::move(m));
        })
        .with_version("14"));

// --save-all writes the PolyCube map as the tet mesh at its PolyCube positions (<id>.polycube.vtk) and
// the PolyCube surface with chart ids and labels as cell data (<id>.polycube_surface.vtk).
const bool saver_registered = [] {
  Registry::instance().add_saver(
      artefact_name<PolyCubeMap>(), ".polycube.vtk", [](const Artefact& a, const std::filesystem::path& path) {
        auto m = a.as<PolyCubeMap>();
        TetMesh t;
        t.V = m->U;
        t.T = m->input->T;
        write_tetmesh(t, path);
        std::string surface = path.string();
        surface.replace(surface.size() - std::string(".vtk").size(), std::string::npos, "_surface.vtk");
        write_polycube_vtk(surface, m->U, *m->segmentation);
      });
  Registry::instance().add_turner(artefact_name<PolyCubeMap>(), [](const Artefact& a, const RigidFrame& f) {
    PolyCubeMap m = *a.as<PolyCubeMap>();
    TetMesh input = *m.input;
    input.V = f.apply(input.V);
    m.input = std::make_shared<const TetMesh>(std::move(input));
    m.U = f.apply(m.U);
    return make_artefact(std::move(m));
  });
  return true;
}();

}  // namespace
}  // namespace polyhex
