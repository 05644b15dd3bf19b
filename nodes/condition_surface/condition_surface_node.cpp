/// @file condition_surface_node.cpp
/// @brief Binding of `condition_surface/{auto,local,levelset,alpha_wrap}`: SurfaceMesh -> SurfaceMesh.
#include "nodes/condition_surface/condition_surface.h"

#include "graph/node.h"

namespace polyhex {
namespace {

void diagnosis_metrics(const SurfaceDiagnosis& d, json& m) {
  m = {{"vertices", d.vertices},
       {"faces", d.faces},
       {"boundary_edges", d.boundary_edges},
       {"boundary_loops", d.boundary_loops},
       {"longest_loop_edges", d.longest_loop_edges},
       {"longest_loop_hex_edges", d.longest_loop_length},
       {"nonmanifold_edges", d.nonmanifold_edges},
       {"nonmanifold_vertices", d.nonmanifold_vertices},
       {"duplicate_faces", d.duplicate_faces},
       {"degenerate_faces", d.degenerate_faces},
       {"sliver_faces", d.sliver_faces},
       {"self_intersections", d.self_intersections},
       {"orientable", d.orientable},
       {"components", d.components},
       {"volume_of_bbox", d.volume},
       {"area_hex_edges2", d.area},
       {"thickness_hex_edges", d.thickness},
       {"tessellation_ratio", d.tessellation_ratio},
       {"defects", d.defects()}};
}

NodeSpec condition_node(const std::string& variant, SurfaceRepair repair, const std::string& what) {
  return make_node<ConditionParams>(
      "condition_surface/" + variant,
      "Diagnoses the input surface and repairs its defects (" + what +
          "); remeshes it to the tet size where it is much finer",
      ParamSet<ConditionParams>()
          .add_enum("policy", &ConditionParams::policy,
                    {{DefectPolicy::repair, "auto"}, {DefectPolicy::strict, "strict"}},
                    "auto: repair defects with a warning; strict: refuse any defect")
          .add_enum("remesh", &ConditionParams::remesh,
                    {{RemeshWhen::finer, "auto"}, {RemeshWhen::never, "never"}, {RemeshWhen::always, "always"}},
                    "remesh to the tet size: auto (when finer than remesh_finer_than), never, always")
          .add("edge_length", &ConditionParams::edge_length,
               "tet edge, fraction of the reference length (the tetrahedralize node's; configs: ${tet_edge})", 0.002,
               0.5)
          .add("hex_edge_length", &ConditionParams::hex_edge_length,
               "hex edge, fraction of the reference length (unit of the costs and bounds; configs: ${hex_edge})", 0.001,
               0.5)
          .add("remesh_finer_than", &ConditionParams::remesh_finer_than,
               "remesh when the tessellation is this many times finer than the tet edge", 1.0, 1000.0)
          .add("feature_angle", &ConditionParams::feature_angle,
               "dihedral angle in degrees above which the remeshing keeps an edge sharp", 1.0, 180.0)
          .add("remesh_iterations", &ConditionParams::remesh_iterations, "isotropic remeshing iterations", 1, 20)
          .add("voxel", &ConditionParams::voxel, "level-set voxel, in hex edges", 0.02, 2.0)
          .add("alpha", &ConditionParams::alpha, "alpha-wrap ball, in hex edges (gaps narrower are closed)", 0.1, 100.0)
          .add("offset", &ConditionParams::offset, "alpha-wrap offset from the input, in hex edges", 0.005, 10.0)
          .add("max_hole_perimeter", &ConditionParams::max_hole_perimeter,
               "local repair fills holes up to this perimeter, in hex edges", 0.0, 1e6)
          .add("max_deviation", &ConditionParams::max_deviation,
               "refuse a level set, wrap or remesh straying farther than this from the original, in hex edges", 0.01,
               1e6)
          .add("min_thickness", &ConditionParams::min_thickness,
               "refuse a result thinner than this (4 volume / area), in hex edges", 0.0, 1e6),
      {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<SurfaceMesh>(),
      [repair](const ConditionParams& p, const Inputs& in, NodeContext& ctx) {
        ConditionReport r;
        ctx.progress(0, "diagnosis");
        SurfaceMesh out = condition_surface(*in.get<SurfaceMesh>(0), repair, p, r);
        json input, output;
        diagnosis_metrics(r.input, input);
        diagnosis_metrics(r.output, output);
        ctx.metrics["input"] = input;
        ctx.metrics["output"] = output;
        ctx.metrics["repair"] = r.repair;
        ctx.metrics["remeshed"] = r.remeshed;
        ctx.metrics["remesh_edge_tet_edges"] = r.remesh_edge;
        ctx.metrics["passed_through"] = r.passed_through;
        ctx.metrics["feature_edges"] = r.feature_edges;
        ctx.metrics["holes_filled"] = r.holes_filled;
        ctx.metrics["pinches_split"] = r.pinches_split;
        ctx.metrics["deviation_from_original_hex_edges"] = r.deviation_from_original;
        ctx.metrics["deviation_to_original_hex_edges"] = r.deviation_to_original;
        for (auto& w : r.warnings) ctx.warn(w);
        if (r.passed_through) return in.items[0];  // bit for bit: the very artefact
        return make_artefact(std::move(out));
      });
}

const bool registered =
    register_node(condition_node("auto", SurfaceRepair::automatic,
                                 "local where that suffices, else level set when closed, else alpha wrap")) &&
    register_node(condition_node("local", SurfaceRepair::local,
                                 "duplicate and degenerate triangles, pinch vertices, small holes")) &&
    register_node(condition_node("levelset", SurfaceRepair::levelset, "OpenVDB level-set remesh")) &&
    register_node(condition_node("alpha_wrap", SurfaceRepair::alpha_wrap, "CGAL 3D alpha wrap"));

}  // namespace
}  // namespace polyhex
