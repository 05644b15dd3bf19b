/// @file quality_node.cpp
/// @brief Binding of the `quality` node: a sink that puts the figures of hex_quality into the report.
#include "graph/node.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/quality/quality_json.h"

namespace polyhex {
namespace {

const bool registered = register_node(make_node<QualityParams>(
    "quality",
    "quality of a hex mesh as ../shared/tools/hexcheck.py defines it (scaled Jacobian, irregular vertices, "
    "inverted hexes; with the input surface also sampled Hausdorff distances, volume ratio and the feature "
    "fidelity: distances between the surface's crease lines and the hex boundary's edges)",
    ParamSet<QualityParams>()
        .add("samples", &QualityParams::samples, "points sampled on each surface for the distances", 1, 1e8)
        .add("feature_angle", &QualityParams::feature_angle,
             "feature fidelity: the surface's creases and the hex boundary's edges sharper than this many degrees "
             "(0 = not measured)",
             0, 179),
    {{"mesh", artefact_name<HexMesh>()}, {"surface", artefact_name<SurfaceMesh>(), true}}, "",
    [](const QualityParams& p, const Inputs& in, NodeContext& ctx) {
      auto mesh = in.get<HexMesh>(0);
      std::shared_ptr<const SurfaceMesh> surface = in.has(1) ? in.get<SurfaceMesh>(1) : nullptr;
      const HexQuality q = hex_quality(*mesh, surface.get(), p);
      ctx.metrics.update(to_json(q));
      ctx.metrics.update(feature_json(q));
      // Beyond hexcheck's keys: the feature fidelity above, and which way the distances were measured (one-sided
      // against an open input).
      if (q.has_surface) ctx.metrics["hausdorff_sides"] = q.surface_closed ? "symmetric" : "surface_to_mesh";
      if (q.inverted > 0)
        ctx.warn(std::to_string(q.inverted) + " of " + std::to_string(q.hexes) + " hexes are inverted");
      return Artefact{};
    }));

}  // namespace
}  // namespace polyhex
