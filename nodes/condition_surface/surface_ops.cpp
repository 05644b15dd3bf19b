#include "nodes/condition_surface/surface_ops.h"

#define CGAL_EIGEN3_ENABLED 1
#include "runtime/errors.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/detect_features.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/alpha_wrap_3.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <array>
#include <iterator>
#include <mutex>
#include <vector>

namespace polyhex {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Polygon = std::array<std::size_t, 3>;
namespace PMP = CGAL::Polygon_mesh_processing;

struct Soup {
  std::vector<Point> points;
  std::vector<Polygon> polygons;
};

Soup to_soup(const SurfaceMesh& s) {
  Soup soup;
  soup.points.reserve(size_t(s.V.rows()));
  for (Eigen::Index v = 0; v < s.V.rows(); ++v) soup.points.emplace_back(s.V(v, 0), s.V(v, 1), s.V(v, 2));
  soup.polygons.reserve(size_t(s.F.rows()));
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    soup.polygons.push_back({size_t(s.F(f, 0)), size_t(s.F(f, 1)), size_t(s.F(f, 2))});
  return soup;
}

// A CGAL mesh of a soup that is already an oriented manifold (else orient_polygon_soup first, which
// duplicates the vertices where that is impossible).
Mesh to_cgal(Soup soup, bool must_be_manifold, const std::string& source) {
  if (!PMP::is_polygon_soup_a_polygon_mesh(soup.polygons)) {
    if (must_be_manifold)
      throw InvalidInput(source + ": not an oriented manifold triangle mesh (needed by the CGAL operation)");
    PMP::orient_polygon_soup(soup.points, soup.polygons);
  }
  Mesh m;
  PMP::polygon_soup_to_polygon_mesh(soup.points, soup.polygons, m);
  return m;
}

SurfaceMesh from_cgal(const Mesh& m, const std::string& source) {
  SurfaceMesh out;
  out.source = source;
  out.V.resize(Eigen::Index(m.number_of_vertices()), 3);
  std::vector<int> index(m.num_vertices(), -1);
  int n = 0;
  for (Mesh::Vertex_index v : m.vertices()) {
    const Point& p = m.point(v);
    out.V.row(n) << p.x(), p.y(), p.z();
    index[size_t(v)] = n++;
  }
  out.F.resize(Eigen::Index(m.number_of_faces()), 3);
  int f = 0;
  for (Mesh::Face_index fi : m.faces()) {
    int k = 0;
    for (Mesh::Vertex_index v : CGAL::vertices_around_face(m.halfedge(fi), m)) {
      if (k < 3) out.F(f, k) = index[size_t(v)];
      ++k;
    }
    if (k != 3) throw InvalidInput(source + ": CGAL returned a face with " + std::to_string(k) + " vertices");
    ++f;
  }
  return out;
}

// Counts the items written to it.
struct CountingIterator {
  using iterator_category = std::output_iterator_tag;
  using value_type = void;
  using difference_type = std::ptrdiff_t;
  using pointer = void;
  using reference = void;
  long* count;
  CountingIterator& operator*() { return *this; }
  CountingIterator& operator++() { return *this; }
  CountingIterator operator++(int) { return *this; }
  template <class T>
  CountingIterator& operator=(const T&) {
    ++*count;
    return *this;
  }
};

}  // namespace

long count_self_intersections(const SurfaceMesh& s) {
  Soup soup = to_soup(s);
  PMP::repair_polygon_soup(soup.points, soup.polygons);
  if (soup.polygons.empty()) return 0;
  const Mesh m = to_cgal(std::move(soup), false, s.source);
  long count = 0;
  PMP::self_intersections(faces(m), m, CountingIterator{&count});
  return count;
}

SurfaceMesh fill_small_holes(const SurfaceMesh& s, double max_perimeter, int& filled) {
  filled = 0;
  Mesh m = to_cgal(to_soup(s), true, s.source);
  std::vector<Mesh::Halfedge_index> cycles;
  PMP::extract_boundary_cycles(m, std::back_inserter(cycles));
  for (Mesh::Halfedge_index h : cycles) {
    double perimeter = 0;
    for (Mesh::Halfedge_index g : CGAL::halfedges_around_face(h, m))
      perimeter += std::sqrt(CGAL::squared_distance(m.point(m.source(g)), m.point(m.target(g))));
    if (perimeter > max_perimeter) continue;
    std::vector<Mesh::Face_index> new_faces;
    std::vector<Mesh::Vertex_index> new_vertices;
    PMP::triangulate_refine_and_fair_hole(m, h, std::back_inserter(new_faces), std::back_inserter(new_vertices));
    filled += new_faces.empty() ? 0 : 1;
  }
  return from_cgal(m, s.source);
}

SurfaceMesh levelset_remesh(const SurfaceMesh& s, double voxel) {
  static std::once_flag vdb_init;
  std::call_once(vdb_init, [] { openvdb::initialize(); });
  std::vector<openvdb::Vec3s> points(size_t(s.V.rows()));
  for (Eigen::Index v = 0; v < s.V.rows(); ++v)
    points[size_t(v)] = openvdb::Vec3s(float(s.V(v, 0)), float(s.V(v, 1)), float(s.V(v, 2)));
  std::vector<openvdb::Vec3I> triangles(size_t(s.F.rows()));
  for (Eigen::Index f = 0; f < s.F.rows(); ++f)
    triangles[size_t(f)] = openvdb::Vec3I(unsigned(s.F(f, 0)), unsigned(s.F(f, 1)), unsigned(s.F(f, 2)));
  const auto xf = openvdb::math::Transform::createLinearTransform(voxel);
  // A narrow band of 3 voxels each side: enough for the zero crossing; the sign inside comes from
  // OpenVDB's own flood fill from the outside, so overlapping parts become one union.
  const openvdb::FloatGrid::Ptr grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xf, points, triangles, 3.0f);
  std::vector<openvdb::Vec3s> out_points;
  std::vector<openvdb::Vec3I> out_triangles;
  std::vector<openvdb::Vec4I> out_quads;
  openvdb::tools::volumeToMesh(*grid, out_points, out_triangles, out_quads, 0.0, 0.0, true);
  if (out_triangles.empty() && out_quads.empty())
    throw InvalidInput(s.source + ": the level set at voxel " + std::to_string(voxel) +
                       " is empty: the surface encloses no volume at that resolution");
  SurfaceMesh out;
  out.source = s.source;
  out.V.resize(Eigen::Index(out_points.size()), 3);
  for (size_t v = 0; v < out_points.size(); ++v)
    out.V.row(Eigen::Index(v)) << out_points[v][0], out_points[v][1], out_points[v][2];
  out.F.resize(Eigen::Index(out_triangles.size() + 2 * out_quads.size()), 3);
  Eigen::Index f = 0;
  // OpenVDB's polygons face the other way round from ours (outward counter-clockwise).
  for (const auto& t : out_triangles) out.F.row(f++) << int(t[2]), int(t[1]), int(t[0]);
  for (const auto& q : out_quads) {
    // Split along the shorter diagonal.
    const Eigen::Vector3d p0 = out.V.row(q[0]), p1 = out.V.row(q[1]), p2 = out.V.row(q[2]), p3 = out.V.row(q[3]);
    if ((p2 - p0).squaredNorm() <= (p3 - p1).squaredNorm()) {
      out.F.row(f++) << int(q[2]), int(q[1]), int(q[0]);
      out.F.row(f++) << int(q[3]), int(q[2]), int(q[0]);
    } else {
      out.F.row(f++) << int(q[3]), int(q[1]), int(q[0]);
      out.F.row(f++) << int(q[3]), int(q[2]), int(q[1]);
    }
  }
  return out;
}

SurfaceMesh alpha_wrap(const SurfaceMesh& s, double alpha, double offset) {
  const Soup soup = to_soup(s);
  Mesh wrap;
  CGAL::alpha_wrap_3(soup.points, soup.polygons, alpha, offset, wrap);
  return from_cgal(wrap, s.source);
}

SurfaceMesh isotropic_remesh(const SurfaceMesh& s, double target, double feature_angle, int iterations,
                             long& feature_edges) {
  Mesh m = to_cgal(to_soup(s), true, s.source);
  auto sharp = m.add_property_map<Mesh::Edge_index, bool>("e:sharp", false).first;
  PMP::detect_sharp_edges(m, feature_angle, sharp);
  feature_edges = 0;
  // Corners: vertices where the sharp edges do not continue as one polyline (1 or 3+ of them).
  auto corner = m.add_property_map<Mesh::Vertex_index, bool>("v:corner", false).first;
  for (Mesh::Edge_index e : m.edges()) feature_edges += sharp[e] ? 1 : 0;
  for (Mesh::Vertex_index v : m.vertices()) {
    int n = 0;
    for (Mesh::Halfedge_index h : CGAL::halfedges_around_target(v, m)) n += sharp[m.edge(h)] ? 1 : 0;
    corner[v] = n == 1 || n > 2;
  }
  PMP::isotropic_remeshing(faces(m), target, m,
                           PMP::parameters::number_of_iterations(unsigned(iterations))
                               .edge_is_constrained_map(sharp)
                               .vertex_is_constrained_map(corner)
                               .protect_constraints(false)
                               .relax_constraints(true));
  m.collect_garbage();
  return from_cgal(m, s.source);
}

}  // namespace polyhex
