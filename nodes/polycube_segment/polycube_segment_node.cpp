/// @file polycube_segment_node.cpp
/// @brief Binding of `polycube_segment/default` (paper §5.1): deformed TetMesh -> PolyCubeSegmentation.
#include "nodes/polycube_segment/polycube_segment.h"

#include "graph/node.h"
#include "nodes/formats/polycube_vtk.h"

namespace polyhex {
namespace {

using P = PolyCubeSegmentParams;

json segmentation_metrics(const PolyCubeSegmentation& s) {
  json m;
  m["charts"] = s.charts.size();
  m["corners"] = s.corners.size();
  m["edges"] = s.edges.size();
  m["splits_multi_orientation"] = s.splits_multi_orientation;
  m["splits_wedge"] = s.splits_wedge;
  m["splits_ramp"] = s.splits_ramp;
  m["splits_order_cycle"] = s.splits_order_cycle;
  m["order_cycles"] = s.order_cycles;
  m["splits_island"] = s.splits_island;
  m["repaired_corners"] = s.repaired_corners;
  m["removed_small"] = s.removed_small;
  m["removed_narrow"] = s.removed_narrow;
  m["valid"] = s.valid;
  m["failing_charts"] = s.failing_charts;
  m["problems"] = s.problems;
  m["smoothing_iterations"] = s.smoothing_iterations;
  m["boundary_triangles"] = s.F.rows();
  return m;
}

const bool registered = register_node(
    make_node<P>(
        "polycube_segment/default",
        "PolyCube structure of the deformed tet mesh (§5.1): labels, charts, clean-up, multi-orientation, wedge and "
        "ramp splits",
        ParamSet<P>()
            .add("smoothing_iterations", &P::smoothing_iterations, "normal smoothing passes before labelling", 0, 1000)
            .add("hex_edge_length", &P::hex_edge_length,
                 "target hex edge, fraction of the reference length (separating chart width)", 1e-5, 0.5)
            .add("small_chart_area", &P::small_chart_area, "small chart: area below this fraction of the surface", 0, 1)
            .add("small_chart_edges", &P::small_chart_edges, "small chart: bounded by at most this many edges", 0, 100)
            .add("split_multi_orientation", &P::split_multi_orientation, "split multi-orientation charts")
            .add("split_wedges", &P::split_wedges, "cut highly non-planar charts at wedge tips")
            .add("edge_smoothing_iterations", &P::edge_smoothing_iterations, "smoothing passes on chart edge copies", 0,
                 10000)
            .add("extremum_depth", &P::extremum_depth, "an edge doubles back by at least this many hex edges", 0, 1e6)
            .add("wedge_min_severity", &P::wedge_min_severity, "minimum wedge area, fraction of the reference length^2",
                 0, 1)
            .add("max_cut_candidates", &P::max_cut_candidates, "cut candidates tested per wedge", 1, 100000)
            .add("split_ramps", &P::split_ramps, "cut charts that climb far along their own axis (extension)")
            .add("ramp_extent", &P::ramp_extent, "a ramp spans more than this many hex edges along its axis", 0, 1e6)
            .add("ramp_extent_planar", &P::ramp_extent_planar,
                 "the same for a flat chart of the input that climbs more than half the solid's depth behind it", 0,
                 1e6)
            .add("split_order_cycles", &P::split_order_cycles,
                 "cut charts whose same-axis order evidence forms a cycle, or that sit on both ends of a step "
                 "wall along the input's creases (extension)")
            .add("max_splits", &P::max_splits, "maximum separating charts of each kind", 0, 10000)
            .add("final_cleanup", &P::final_cleanup, "after the splits, remove small charts with < 4 neighbours")
            .add("split_islands", &P::split_islands, "cut ring charts from the boundary of a chart with < 4 neighbours")
            .add("repair_corners", &P::repair_corners, "relabel a patch at 4-valent corners / opposite touch points")
            .add("min_chart_extent", &P::min_chart_extent,
                 "on a valid structure, remove charts narrower than this many hex edges ... (0 = off)", 0, 100)
            .add("narrow_chart_faces", &P::narrow_chart_faces,
                 "... and smaller than this many hex faces, where it stays valid (0 = off)", 0, 100)
            .add("fallback_retries", &P::fallback_retries, "retries with doubled smoothing when invalid", 0, 10)
            .add("follow_creases", &P::follow_creases,
                 "with the input tets: no normal smoothing across the input's creases, one label per planar face")
            .add("allow_invalid", &P::allow_invalid, "pass an invalid structure on with a warning")
            .add("save_surface", &P::save_surface, "write <id>.charts.vtk"),
        {{"deformed", artefact_name<TetMesh>()}, {"tets", artefact_name<TetMesh>(), true}},
        artefact_name<PolyCubeSegmentation>(),
        [](const P& p, const Inputs& in, NodeContext& ctx) {
          auto mesh = in.get<TetMesh>(0);
          auto input = in.has(1) ? in.get<TetMesh>(1) : nullptr;
          PolyCubeSegmentation s = segment_polycube(*mesh, p, input.get());
          ctx.metrics.update(segmentation_metrics(s));
          for (auto& w : s.warnings) ctx.warn(w);
          if (ctx.save_all || p.save_surface)
            write_polycube_vtk(ctx.out_dir / (ctx.id + ".charts.vtk"), ctx.in_input_frame(mesh->V), s);
          if (!s.valid) {
            if (!p.allow_invalid) require_valid_polycube(s);
            ctx.warn("allow_invalid: passing on an invalid PolyCube structure (failing charts " +
                     json(s.failing_charts).dump() + ")");
          }
          return make_artefact(std::make_shared<const PolyCubeSegmentation>(std::move(s)));
        })
        .with_version("15"));

}  // namespace
}  // namespace polyhex
