#include "nodes/boundary_groups/boundary_groups.h"

#include "nodes/algorithms/features.h"
#include "nodes/algorithms/hex_quality.h"
#include "nodes/algorithms/triangle_tree.h"
#include "nodes/artefacts/boundary_groups.h"
#include "runtime/errors.h"
#include "runtime/stopwatch.h"

#include <tbb/parallel_for.h>

#include <chrono>
#include <map>
#include <string>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;

/// A boundary face: its hex and local face, centroid and (unnormalised) outward normal.
struct Face {
  int hex, face;
  Vec3 centroid, normal;
};

/// For each face, the value `label` of the triangle of (V, F) nearest to its centroid; counts the faces
/// whose nearest triangle faces the other way.
std::vector<int> nearest_labels(const std::vector<Face>& faces, const RowMatrixX3d& V, const RowMatrixX3i& F,
                                const Eigen::VectorXi& label, long& facing_away) {
  const TriangleTree tree(V, F);
  std::vector<int> out(faces.size());
  std::vector<char> away(faces.size(), 0);
  tbb::parallel_for(size_t(0), faces.size(), [&](size_t i) {
    const int t = tree.closest(faces[i].centroid).triangle;
    out[i] = label[t];
    const Vec3 n = (V.row(F(t, 1)) - V.row(F(t, 0))).cross(V.row(F(t, 2)) - V.row(F(t, 0))).transpose();
    away[i] = n.dot(faces[i].normal) < 0;
  });
  for (char a : away) facing_away += a;
  return out;
}

/// One group per distinct label, in label order, named `<family>_<label>`.
void add_family(HexMesh& out, const std::vector<Face>& faces, const std::vector<int>& label, const std::string& family,
                int* groups) {
  std::map<int, BoundaryGroup> by_label;
  for (size_t i = 0; i < faces.size(); ++i) {
    BoundaryGroup& g = by_label[label[i]];
    g.faces.push_back({faces[i].hex, faces[i].face});
  }
  for (auto& [id, g] : by_label) {
    g.name = family + "_" + std::to_string(id);
    g.family = family;
    g.id = id;
    std::sort(g.faces.begin(), g.faces.end());
    out.groups.push_back(std::move(g));
  }
  *groups = int(by_label.size());
}

}  // namespace

HexMesh add_boundary_groups(const HexMesh& mesh, const PolyCubeMap* map, const SurfaceMesh* surface,
                            const BoundaryGroupsParams& p, BoundaryGroupsStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  BoundaryGroupsStats local;
  BoundaryGroupsStats& s = stats ? *stats : local;
  s = BoundaryGroupsStats{};
  check_hex_mesh(mesh);
  const std::string name = mesh.source.empty() ? std::string("hex mesh") : mesh.source;
  if (p.feature_angle != 0 && !(p.feature_angle >= 1 && p.feature_angle <= 179))
    throw InvalidInput("boundary groups: feature_angle = " + std::to_string(p.feature_angle) +
                       " must be 0 (no patch groups) or in [1, 179] degrees");
  if (p.charts) {
    if (!map || !map->input || !map->segmentation)
      throw InvalidInput(
          "boundary groups: chart groups need the PolyCube map with its input tets and segmentation "
          "(connect `map`, or set charts to false)");
    const auto& seg = *map->segmentation;
    if (seg.F.rows() == 0 || seg.chart.size() != seg.F.rows())
      throw InvalidInput("boundary groups: the segmentation has " + std::to_string(seg.F.rows()) + " triangles and " +
                         std::to_string(seg.chart.size()) + " chart ids");
  }
  if (p.feature_angle > 0 && (!surface || surface->F.rows() == 0))
    throw InvalidInput(
        "boundary groups: patch groups need the input surface (connect `surface`, or set "
        "feature_angle to 0)");

  std::vector<int> hex_of, face_of;
  const auto Q = hex_boundary_quads(mesh, &hex_of, &face_of);
  if (Q.rows() == 0) throw InvalidInput(name + ": no boundary face (every hex face is shared)");
  std::vector<Face> faces(size_t(Q.rows()));
  for (Eigen::Index q = 0; q < Q.rows(); ++q) {
    Face& f = faces[size_t(q)];
    f.hex = hex_of[size_t(q)];
    f.face = face_of[size_t(q)];
    const Vec3 a = mesh.V.row(Q(q, 0)), b = mesh.V.row(Q(q, 1)), c = mesh.V.row(Q(q, 2)), d = mesh.V.row(Q(q, 3));
    f.centroid = 0.25 * (a + b + c + d);
    f.normal = (c - a).cross(d - b);  // outward: the quad's vertices turn counter-clockwise seen from outside
  }

  HexMesh out;
  out.V = mesh.V;
  out.H = mesh.H;
  out.source = mesh.source;
  BoundaryGroup all{"boundary", "boundary", 0, {}};
  for (const Face& f : faces) all.faces.push_back({f.hex, f.face});
  std::sort(all.faces.begin(), all.faces.end());
  s.boundary_faces = long(all.faces.size());
  out.groups.push_back(std::move(all));

  if (p.charts) {
    const auto& seg = *map->segmentation;
    add_family(out, faces, nearest_labels(faces, map->input->V, seg.F, seg.chart, s.facing_away), "chart",
               &s.chart_groups);
  }
  if (p.feature_angle > 0) {
    const Eigen::VectorXi patch = surface_patches(*surface, p.feature_angle, &s.surface_patches);
    add_family(out, faces, nearest_labels(faces, surface->V, surface->F, patch, s.facing_away), "patch",
               &s.patch_groups);
  }
  if (const std::string problem = boundary_groups_problem(out); !problem.empty())
    throw InvalidInput(name + ": " + problem);  // e.g. a negative chart id in the segmentation
  s.seconds = seconds_since(t0);
  return out;
}

}  // namespace polyhex
