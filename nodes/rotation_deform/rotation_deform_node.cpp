/// @file rotation_deform_node.cpp
/// @brief Binding of `rotation_deform/quaternion_laplace`: TetMesh -> deformed TetMesh (paper §4).
#include "nodes/rotation_deform/rotation_deform.h"

#include "graph/node.h"
#include "graph/stat_metrics.h"
#include "runtime/stopwatch.h"

#include <chrono>

namespace polyhex {
namespace {

using P = RotationDeformParams;

/// The JSON names of the solve modes (the param and the report's `solve_mode`).
const EnumNames<SolveMode> kSolveModes = {{SolveMode::MultiColumn, "multi_column"}, {SolveMode::Parallel, "parallel"}};

const bool registered = register_node(
    make_node<P>(
        "rotation_deform/quaternion_laplace",
        "Rotation-driven deformation (§4): quaternion Laplace field from axis-aligning boundary rotations, "
        "integrated by Eq. 1, iterated; both systems factored once",
        ParamSet<P>()
            .add("iterations", &P::iterations, "rotation-driven iterations (paper: 5)", 1, 50)
            .add("anchor_weight", &P::anchor_weight, "weight w of the soft boundary anchors (paper: 1), (0, 1e6]",
                 1e-12, 1e6)
            .add(
                "feature_angle", &P::feature_angle,
                "degrees: a boundary vertex whose incident face normals differ by more is a feature (not a constraint)",
                0, 180)
            .add("flatten", &P::flatten,
                 "fraction of a same-axis surface edge's component along its axis removed in Eq. 1's target "
                 "(0 = the paper's Eq. 1), [0, 1]",
                 0, 1)
            .add("flatten_full_angle", &P::flatten_full_angle,
                 "degrees: a surface edge whose end normals lie within this of their axis is flattened by the full β",
                 0, 90)
            .add("flatten_max_angle", &P::flatten_max_angle,
                 "degrees: no flattening where an end normal deviates more (linear in between), > flatten_full_angle",
                 0, 90)
            .add_enum("solve_mode", &P::solve_mode, kSolveModes,
                      "several right-hand sides: one multi-column solve or TBB-parallel columns")
            .add("save_iterations", &P::save_iterations, "write each iteration's mesh as <out>/<id>.iter<k>.vtk"),
        {{"tets", artefact_name<TetMesh>()}}, artefact_name<TetMesh>(),
        [](const P& p, const Inputs& in, NodeContext& ctx) {
          const auto t0 = std::chrono::steady_clock::now();
          IterationCallback on_iteration = [&ctx, &p](int k, const TetMesh&, const RotationIterationStats&) {
            ctx.progress(double(k) / p.iterations, "iteration " + std::to_string(k));
          };
          if (p.save_iterations || ctx.save_all) {
            auto [ext, saver] = Registry::instance().saver(artefact_name<TetMesh>());
            if (!saver && p.save_iterations)
              throw ConfigError(
                  "rotation_deform: save_iterations needs a TetMesh writer, and none is registered "
                  "(the io nodes register it)");
            if (!saver) {
              ctx.warn("no TetMesh writer registered: iterations not saved");
            } else {
              on_iteration = [&ctx, &p, ext = ext, saver = saver](int k, const TetMesh& m,
                                                                  const RotationIterationStats&) {
                ctx.progress(double(k) / p.iterations, "iteration " + std::to_string(k));
                TetMesh shown = m;
                shown.V = ctx.in_input_frame(m.V);
                saver(make_artefact(std::move(shown)), ctx.out_dir / (ctx.id + ".iter" + std::to_string(k) + ext));
              };
            }
          }
          RotationDeformResult r = rotation_deform(*in.get<TetMesh>(0), p, on_iteration);

          auto& m = ctx.metrics;
          m["iterations"] = static_cast<int>(r.iterations.size());
          r.factor_stats.merge_into(m);  // factorizations, solves, factor_seconds, solve_seconds, analyses, ...
          put_stats(r, m);
          m["solve_mode"] = kSolveModes.name(p.solve_mode);
          m["tets"] = r.mesh.T.rows();
          m["vertices"] = r.mesh.V.rows();
          const double fs = r.factor_stats.factor_seconds + r.factor_stats.solve_seconds;
          const double total = seconds_since(t0);
          m["compute_seconds"] = total;
          m["factor_solve_fraction"] = total > 0 ? fs / total : 0.0;  // (factor + solve) / compute time
          return make_artefact(std::move(r.mesh));
        })
        .with_version("3"));

}  // namespace
}  // namespace polyhex
