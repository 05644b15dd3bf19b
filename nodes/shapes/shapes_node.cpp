/// @file shapes_node.cpp
/// @brief Binding of the `shapes` node: a built-in closed surface, no input.
#include "nodes/algorithms/shapes.h"

#include "graph/node.h"

namespace polyhex {
namespace {

const bool registered = register_node(
    make_node<ShapeParams>("shapes", "built-in closed test surface (no file needed)",
                           ParamSet<ShapeParams>()
                               .add_choice("name", &ShapeParams::name, shape_names(), "shape to build")
                               .add("resolution", &ShapeParams::resolution,
                                    "samples along the longest side (level-set voxels or parameter steps)", 8, 512),
                           {}, artefact_name<SurfaceMesh>(), [](const ShapeParams& p, const Inputs&, NodeContext& ctx) {
                             auto mesh = make_shape(p);
                             ctx.metrics["vertices"] = mesh.V.rows();
                             ctx.metrics["faces"] = mesh.F.rows();
                             return make_artefact(std::move(mesh));
                           }));

}  // namespace
}  // namespace polyhex
