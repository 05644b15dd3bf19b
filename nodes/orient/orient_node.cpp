/// @file orient_node.cpp
/// @brief Bindings of `orient/search` (candidate frames scored by axis alignment, nodes/orient/orient.h)
/// and `orient/input` (the input frame alone), and of the frame nodes that carry meshes into a
/// candidate's frame and back: `frame_tets`, `frame_surface`, `unframe_hexes`.
#include "nodes/orient/orient.h"

#include "graph/node.h"
#include "graph/stat_metrics.h"
#include "nodes/orient/placement.h"

#include <Eigen/Geometry>

#include <cmath>

namespace polyhex {
namespace {

json frames_json(const Frames& f) {
  json all = json::array();
  for (const FrameCandidate& c : f.candidates) {
    const Eigen::AngleAxisd aa(c.R);
    all.push_back(
        {{"source", c.source},
         {"energy", c.energy},
         {"branch", c.branch},
         {"turn_degrees", aa.angle() * 180 / M_PI},
         {"centre", {c.centre[0], c.centre[1], c.centre[2]}},
         {"grid", c.grid},
         {"rotation",
          {{c.R(0, 0), c.R(0, 1), c.R(0, 2)}, {c.R(1, 0), c.R(1, 1), c.R(1, 2)}, {c.R(2, 0), c.R(2, 1), c.R(2, 2)}}}});
  }
  return all;
}

const bool registered_search = register_node(make_node<OrientParams>(
    "orient/search",
    "candidate frames for the PolyCube, scored by the axis alignment of the surface normals: the input frame, "
    "and local minima of the alignment energy from the principal axes, dominant normals and a spread of rotations",
    ParamSet<OrientParams>()
        .add("max_frames", &OrientParams::max_frames, "frames run as branches at most, the input frame included", 1, 8)
        .add("within", &OrientParams::within,
             "besides the lowest-energy frame, frames with energy up to (1 + within) x its energy run too", 0, 10)
        .add("distinct_degrees", &OrientParams::distinct_degrees,
             "candidates closer than this many degrees (up to the cube's symmetries) are one", 1e-3, 45)
        .add("histogram", &OrientParams::histogram, "normal bins per cube-map face side", 2, 256)
        .add("spread_starts", &OrientParams::spread_starts, "descents from rotations spread over SO(3)", 0, 1000)
        .add("flat_sigma_degrees", &OrientParams::flat_sigma_degrees,
             "a minimum is moved onto the frame of the flat faces: robust weights' first angle scale, 0 = off (3: on)",
             0, 20)
        .add("flat_min_area", &OrientParams::flat_min_area,
             "... kept when this share of the area is then within 0.1 degree of an axis", 0, 1),
    {{"surface", artefact_name<SurfaceMesh>()}, {"placement", artefact_name<Frames>(), true}}, artefact_name<Frames>(),
    [](const OrientParams& p, const Inputs& in, NodeContext& ctx) {
      OrientStats st;
      // with a canonical placement, the surface is in its frame: the input's axes are its rotation's rows
      const FrameCandidate* placed = in.has(1) ? in.get<Frames>(1)->of_branch(1) : nullptr;
      const Eigen::Matrix3d axes = placed ? Eigen::Matrix3d(placed->R.transpose()) : Eigen::Matrix3d::Identity();
      const bool canonical = placed && !placed->frame().is_identity();
      Frames f = orient_frames(*in.get<SurfaceMesh>(0), p, &st, canonical ? &axes : nullptr);
      ctx.metrics["candidates"] = frames_json(f);
      put_stats(st, ctx.metrics);
      return make_artefact(std::move(f));
    }));

const bool registered_placement = register_node(make_node<PlacementParams>(
    "placement",
    "the frame the pipeline works in: the input's own (input), or one fixed by the shape, positions rounded to a "
    "grid, so that a turned or moved copy of the input gets the same mesh bit for bit (canonical)",
    ParamSet<PlacementParams>()
        .add_enum("frame", &PlacementParams::frame,
                  {{PlacementFrame::input, "input"}, {PlacementFrame::canonical, "canonical"}},
                  "input: the input's coordinates; canonical: centred on the vertices' mean, axes towards two vertices "
                  "chosen by their order in the file, positions rounded to the grid")
        .add("grid_bits", &PlacementParams::grid_bits,
             "canonical: positions are rounded to 2^-grid_bits of the shape's radius (a power of 2)", 8, 40),
    {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<Frames>(),
    [](const PlacementParams& p, const Inputs& in, NodeContext& ctx) {
      PlacementStats st;
      Frames f = placement_frame(*in.get<SurfaceMesh>(0), p, &st);
      ctx.metrics["candidates"] = frames_json(f);
      put_stats(st, ctx.metrics);
      return make_artefact(std::move(f));
    }));

struct InputFrameParams {};

const bool registered_input = register_node(make_node<InputFrameParams>(
    "orient/input", "the input frame alone (no search): one branch, the mesh as it would be without orientation",
    ParamSet<InputFrameParams>(), {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<Frames>(),
    [](const InputFrameParams&, const Inputs& in, NodeContext& ctx) {
      Frames f = input_frame_only(*in.get<SurfaceMesh>(0));
      ctx.metrics["candidates"] = frames_json(f);
      ctx.metrics["branches"] = 1;
      return make_artefact(std::move(f));
    }));

struct FrameParams {
  int branch = 1;  ///< the branch whose frame this is (configs: "${branch}")
};

ParamSet<FrameParams> frame_params() {
  return ParamSet<FrameParams>().add(
      "branch", &FrameParams::branch,
      "the branch whose frame is used (configs: \"${branch}\"); none: nothing is produced "
      "and the branch is skipped",
      1, 8);
}

template <class Mesh>
Artefact into_frame(const FrameParams& p, const Inputs& in, NodeContext& ctx) {
  const FrameCandidate* c = in.get<Frames>(1)->of_branch(p.branch);
  if (!c) {
    ctx.metrics["frame"] = nullptr;
    return Artefact{};
  }
  ctx.metrics["frame"] = c->source;
  ctx.metrics["energy"] = c->energy;
  ctx.frame = c->frame();
  if (c->frame().is_identity() && c->grid == 0) return in.items[0];  // the input frame: the input itself
  Mesh m = *in.get<Mesh>(0);
  m.V = c->place(m.V);
  return make_artefact(std::move(m));
}

const bool registered_frame_tets = register_node(
    make_node<FrameParams>("frame_tets",
                           "the tet mesh turned into the frame of one branch's candidate (x -> R (x - centre), rounded "
                           "to its grid if it has one)",
                           frame_params(), {{"tets", artefact_name<TetMesh>()}, {"frames", artefact_name<Frames>()}},
                           artefact_name<TetMesh>(), into_frame<TetMesh>)
        .with_may_skip()
        .with_frame_role(NodeSpec::FrameRole::enters));

const bool registered_frame_surface =
    register_node(make_node<FrameParams>(
                      "frame_surface",
                      "the surface turned into the frame of one branch's candidate (x -> R (x - centre), rounded to "
                      "its grid if it has one)",
                      frame_params(), {{"surface", artefact_name<SurfaceMesh>()}, {"frames", artefact_name<Frames>()}},
                      artefact_name<SurfaceMesh>(), into_frame<SurfaceMesh>)
                      .with_may_skip()
                      .with_frame_role(NodeSpec::FrameRole::enters));

const bool registered_unframe = register_node(
    make_node<FrameParams>(
        "unframe_hexes",
        "a hex mesh built in one branch's frame turned back into the frame its frames were found in (x -> "
        "Rᵀ x + centre)",
        frame_params(), {{"hexes", artefact_name<HexMesh>()}, {"frames", artefact_name<Frames>()}},
        artefact_name<HexMesh>(),
        [](const FrameParams& p, const Inputs& in, NodeContext& ctx) {
          const FrameCandidate* c = in.get<Frames>(1)->of_branch(p.branch);
          if (!c) throw InvalidInput("no candidate frame runs as branch " + std::to_string(p.branch));
          if (c->frame().is_identity()) return in.items[0];
          HexMesh m = *in.get<HexMesh>(0);
          m.V = c->frame().inverse().apply(m.V);
          return make_artefact(std::move(m));
        })
        .with_frame_role(NodeSpec::FrameRole::leaves));

}  // namespace
}  // namespace polyhex
