/// @file optimize_node.cpp
/// @brief Binding of `optimize/sj` (paper §6: vertex repositioning and shape improvement).
#include "nodes/optimize/optimize.h"

#include "graph/node.h"
#include "graph/stat_metrics.h"

namespace polyhex {
namespace {

using P = OptimizeParams;

const bool registered = register_node(
    make_node<P>(
        "optimize/sj",
        "§6 optimization: untangle (regularised Winslow energy), per-vertex max-min scaled Jacobian, global shape "
        "improvement; boundary vertices stay on the input surface",
        ParamSet<P>()
            .add("global_iterations", &P::global_iterations, "eps updates of the global L-BFGS untangling (0 = off)", 0,
                 1000)
            .add("global_rings", &P::global_rings,
                 "global untangling frees the inverted hexes' vertices grown by this many rings", 0, 50)
            .add("untangle_iterations", &P::untangle_iterations, "max untangling sweeps", 0, 10000)
            .add("iterations", &P::iterations, "max max-min scaled Jacobian sweeps", 0, 10000)
            .add("element_iterations", &P::element_iterations,
                 "rounds of whole-hex moves towards the best-fitting cube, each followed by max-min sweeps", 0, 1000)
            .add("smooth_iterations", &P::smooth_iterations,
                 "rounds of region smoothing around the worst hexes, kept while the minimum scaled Jacobian rises", 0,
                 1000)
            .add("average_iterations", &P::average_iterations,
                 "L-BFGS iterations of the global average scaled Jacobian ascent before the shape sweeps (0 = off)", 0,
                 100000)
            .add("average_work", &P::average_work,
                 "the average ascent's iterations are also capped at this divided by the hexes of its region", 0.0,
                 1e12)
            .add("average_barrier", &P::average_barrier,
                 "weight of the Winslow barrier against inversion in the average ascent's energy (0 = none)", 0.0, 1.0)
            .add("average_below_sj", &P::average_below_sj,
                 "the average ascent moves the interior vertices of hexes below this scaled Jacobian", 0.0, 1.0)
            .add("average_rings", &P::average_rings, "the average ascent's region grows by this many rings of hexes", 0,
                 50)
            .add("average_tolerance", &P::average_tolerance,
                 "the average ascent stops when 25 iterations raise its region's scaled Jacobians by less per hex", 0.0,
                 1.0)
            .add("minimum_iterations", &P::minimum_iterations,
                 "L-BFGS iterations of each round of the last phase, the minimum scaled Jacobian ascent around the "
                 "worst hexes (0 = off)",
                 0, 100000)
            .add("minimum_rounds", &P::minimum_rounds,
                 "rounds of the minimum ascent, kept while the minimum scaled Jacobian rises", 0, 100)
            .add("minimum_rings", &P::minimum_rings,
                 "the minimum ascent's region: the hexes within minimum_band of the minimum grown by this many rings",
                 0, 50)
            .add("minimum_band", &P::minimum_band, "see minimum_rings", 0.0, 1.0)
            .add("shape_iterations", &P::shape_iterations, "max global shape-improvement sweeps", 0, 10000)
            .add("shape_tolerance", &P::shape_tolerance,
                 "the shape sweeps stop when a pair of them raises the average scaled Jacobian by less", 0.0, 1.0)
            .add("target_sj", &P::target_sj, "max-min sweeps move vertices of hexes below this scaled Jacobian", 0.0,
                 1.0)
            .add("shape_target_sj", &P::shape_target_sj,
                 "shape sweeps move vertices of hexes below this scaled Jacobian", 0.0, 1.0)
            .add("time_budget", &P::time_budget, "seconds for the whole stage", 0.0, 1e6)
            .add("move_boundary", &P::move_boundary, "boundary vertices may slide on the surface")
            .add("release_boundary", &P::release_boundary,
                 "last resort: boundary corners of hexes still inverted after untangling may leave the surface "
                 "(once untangled they go back as far as their hexes allow without lowering the minimum)")
            .add("return_rings", &P::return_rings,
                 "a released vertex that cannot go back alone goes back with its neighbours within this many rings "
                 "of hexes re-placed around it (0 = alone)",
                 0, 10)
            .add("feature_angle", &P::feature_angle,
                 "an edge of the surface sharper than this many degrees is a crease (0 = no crease handling); when "
                 "the first result is poor (see fallback_below_sj), the mesh is optimized again with paths of "
                 "boundary edges put on the crease lines, and the better result kept",
                 0.0, 179.0)
            .add("keep_creases", &P::keep_creases,
                 "boundary vertices the lattice put on a crease of the surface slide along it, those at its corners "
                 "stay")
            .add(
                "fallback_below_sj", &P::fallback_below_sj,
                "with a fallback input: also optimize it when the first result's minimum scaled Jacobian is below this",
                0.0, 1.0)
            .add("skip_failed_steps", &P::skip_failed_steps,
                 "the max-min sweeps skip a vertex whose last step failed while nothing around it has moved "
                 "since (the same mesh bit for bit, faster)"),
        {{"hexes", artefact_name<HexMesh>()},
         {"surface", artefact_name<SurfaceMesh>()},
         {"fallback", artefact_name<HexMesh>(), true}},
        artefact_name<HexMesh>(),
        [](const P& p, const Inputs& in, NodeContext& ctx) {
          OptimizeStats s;
          FallbackOutcome fb;
          auto fallback = in.has(2) ? in.get<HexMesh>(2) : nullptr;
          HexMesh out = optimize_hexes_or_fallback(*in.get<HexMesh>(0), fallback.get(), *in.get<SurfaceMesh>(1), p, &s,
                                                   &fb, ctx.progress_fn());
          auto& j = ctx.metrics;
          // <name>_ran, _kept, and the figures of a candidate that ran
          auto candidate = [&](const std::string& name, bool ran, bool kept, const OptimizeStats& cs) {
            j[name + "_ran"] = ran;
            j[name + "_kept"] = kept;
            if (!ran) return;
            j[name + "_inverted"] = cs.inverted_after;
            j[name + "_sj_min"] = cs.sj_min_after;
            j[name + "_seconds"] = cs.seconds;
          };
          candidate("fallback", fb.ran, fb.kept, fb.stats);
          candidate("creases", fb.creases_ran, fb.creases_kept, fb.creases_stats);
          // the kept candidate's creases: lines found, lines with a vertex on them, vertices kept on them
          j["crease_lines"] = s.crease_lines;
          j["crease_lines_snapped"] = s.crease_lines_snapped;
          j["crease_vertices"] = s.crease_vertices;
          put_stats(s, j);
          if (s.released_vertices > s.returned_vertices)
            ctx.warn(std::to_string(s.released_vertices - s.returned_vertices) +
                     " boundary vertices left the surface to untangle hexes (max distance " +
                     std::to_string(s.boundary_distance_max) + " of the bbox diagonal)");
          if (s.inverted_after > 0)
            ctx.warn(std::to_string(s.inverted_after) + " hexes are still inverted after optimization (" +
                     std::to_string(s.inverted_before) + " before)");
          if (s.time_budget_hit)
            ctx.warn("optimization stopped at its time budget of " + std::to_string(p.time_budget) + " s");
          return make_artefact(std::move(out));
        })
        .with_version("31"));

}  // namespace
}  // namespace polyhex
