/// @file shapes.cpp
/// @brief Built-in closed surfaces: analytic parametrisations (sphere, torus, bumpy torus, box), exact
/// polyhedral solids with sharp edges (sharp L-block, chamfered box, filleted cylinder) and
/// CSG solids given by signed distance functions, sampled into an OpenVDB narrow-band level set and
/// meshed with openvdb::tools::volumeToMesh (rod with holes, L-block, bent pipe, fandisk-like block).
#include "nodes/algorithms/shapes.h"

#include "runtime/errors.h"

#include <Eigen/Geometry>
#include <openvdb/openvdb.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <mutex>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------
// Mesh assembly helpers

/// Appends the two triangles of quad (a, b, c, d) (counter-clockwise), split along the shorter
/// diagonal so that neither triangle is needlessly obtuse.
void add_quad(const std::vector<Vec3>& V, std::vector<Eigen::Vector3i>& F, int a, int b, int c, int d) {
  if ((V[a] - V[c]).squaredNorm() <= (V[b] - V[d]).squaredNorm()) {
    F.emplace_back(a, b, c);
    F.emplace_back(a, c, d);
  } else {
    F.emplace_back(a, b, d);
    F.emplace_back(b, c, d);
  }
}

/// Signed volume enclosed by a closed triangle surface (divergence theorem).
double signed_volume(const std::vector<Vec3>& V, const std::vector<Eigen::Vector3i>& F) {
  double vol = 0;
  for (const auto& f : F) vol += V[f[0]].dot(V[f[1]].cross(V[f[2]]));
  return vol / 6.0;
}

/// Packs the lists into a SurfaceMesh, drops unused vertices and flips every triangle when the
/// enclosed volume comes out negative, so the result is outward oriented.
SurfaceMesh pack(const std::vector<Vec3>& V, std::vector<Eigen::Vector3i> F, const std::string& name) {
  if (signed_volume(V, F) < 0)
    for (auto& f : F) std::swap(f[1], f[2]);
  std::vector<int> remap(V.size(), -1);
  int n = 0;
  for (const auto& f : F)
    for (int k = 0; k < 3; ++k)
      if (remap[f[k]] < 0) remap[f[k]] = n++;
  SurfaceMesh m;
  m.source = "shapes:" + name;
  m.V.resize(n, 3);
  for (size_t i = 0; i < V.size(); ++i)
    if (remap[i] >= 0) m.V.row(remap[i]) = V[i].transpose();
  m.F.resize(static_cast<Eigen::Index>(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i)
    for (int k = 0; k < 3; ++k) m.F(static_cast<Eigen::Index>(i), k) = remap[F[i][k]];
  return m;
}

/// The boundary of the integer lattice box [0,nx] x [0,ny] x [0,nz]: lattice points (as doubles)
/// and outward quads split into triangles. Callers map the points (scale, project to a sphere).
void lattice_box_surface(int nx, int ny, int nz, std::vector<Vec3>& V, std::vector<Eigen::Vector3i>& F) {
  std::map<std::array<int, 3>, int> index;
  auto vid = [&](int i, int j, int k) {
    auto [it, fresh] = index.emplace(std::array<int, 3>{i, j, k}, static_cast<int>(V.size()));
    if (fresh) V.emplace_back(i, j, k);
    return it->second;
  };
  const int n[3] = {nx, ny, nz};
  // For each axis a and side s, walk the face grid in the two other axes (u, w) chosen so that
  // (u, w, a) is right-handed; the side at 0 is walked the other way round to face outward.
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    for (int s = 0; s < 2; ++s) {
      auto corner = [&](int iu, int iw) {
        int c[3];
        c[a] = s ? n[a] : 0;
        c[u] = iu;
        c[w] = iw;
        return vid(c[0], c[1], c[2]);
      };
      for (int iu = 0; iu < n[u]; ++iu)
        for (int iw = 0; iw < n[w]; ++iw) {
          int p00 = corner(iu, iw), p10 = corner(iu + 1, iw), p11 = corner(iu + 1, iw + 1), p01 = corner(iu, iw + 1);
          if (s)
            add_quad(V, F, p00, p10, p11, p01);
          else
            add_quad(V, F, p00, p01, p11, p10);
        }
    }
  }
}

/// A closed surface from a doubly periodic parametrisation x(u, v), u, v in [0, 2 pi), on an
/// nu by nv grid (torus topology).
SurfaceMesh periodic_surface(int nu, int nv, const std::function<Vec3(double, double)>& x, const std::string& name) {
  std::vector<Vec3> V;
  std::vector<Eigen::Vector3i> F;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) V.push_back(x(2 * kPi * i / nu, 2 * kPi * j / nv));
  auto id = [&](int i, int j) { return (i % nu) * nv + (j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) add_quad(V, F, id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
  return pack(V, std::move(F), name);
}

/// Collapses edges shorter than min_len to their midpoints. Dual contouring puts one vertex per
/// voxel at the mean of its edge crossings, so where the surface passes close to a lattice point
/// neighbouring vertices can nearly coincide (edges of 1e-6 voxel, needle triangles). A collapse is
/// skipped unless it keeps the surface a closed 2-manifold (link condition: the two end points share
/// exactly the two opposite vertices) and turns no surviving triangle by more than ~80 degrees.
/// Dead triangles are removed from F; vertices left unused are dropped later by pack().
void collapse_short_edges(std::vector<Vec3>& V, std::vector<Eigen::Vector3i>& F, double min_len) {
  std::vector<std::vector<int>> faces_of(V.size());
  for (size_t f = 0; f < F.size(); ++f)
    for (int k = 0; k < 3; ++k) faces_of[F[f][k]].push_back(static_cast<int>(f));
  std::vector<char> dead(F.size(), 0);
  auto normal = [&](const Eigen::Vector3i& f) { return (V[f[1]] - V[f[0]]).cross(V[f[2]] - V[f[0]]); };
  auto neighbours = [&](int v) {
    std::vector<int> n;
    for (int f : faces_of[v])
      for (int k = 0; k < 3; ++k)
        if (F[f][k] != v) n.push_back(F[f][k]);
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
    return n;
  };
  bool changed = true;
  while (changed) {
    changed = false;
    for (size_t f0 = 0; f0 < F.size(); ++f0)
      for (int k = 0; k < 3 && !dead[f0]; ++k) {
        const int a = F[f0][k], b = F[f0][(k + 1) % 3];
        if ((V[a] - V[b]).norm() >= min_len) continue;
        std::vector<int> shared, common, na = neighbours(a), nb = neighbours(b);
        for (int f : faces_of[a])
          if (F[f][0] == b || F[f][1] == b || F[f][2] == b) shared.push_back(f);
        std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
        if (shared.size() != 2 || common.size() != 2) continue;
        const Vec3 mid = 0.5 * (V[a] + V[b]), keep_a = V[a], keep_b = V[b];
        // Try the move, check the triangles that survive, undo if one turns over.
        std::vector<std::pair<int, Vec3>> before;
        for (int v : {a, b})
          for (int f : faces_of[v])
            if (f != shared[0] && f != shared[1]) before.emplace_back(f, normal(F[f]));
        V[a] = V[b] = mid;
        bool ok = true;
        for (auto& [f, n0] : before) {
          Vec3 n1 = normal(F[f]);
          ok = ok && n1.dot(n0) > 0.17 * n1.norm() * n0.norm();
        }
        if (!ok) {
          V[a] = keep_a;
          V[b] = keep_b;
          continue;
        }
        for (int f : shared) dead[f] = 1;
        for (int f : faces_of[b]) {
          if (dead[f]) continue;
          for (int j = 0; j < 3; ++j)
            if (F[f][j] == b) F[f][j] = a;
          faces_of[a].push_back(f);
        }
        faces_of[b].clear();
        for (int v : common)
          faces_of[v].erase(std::remove_if(faces_of[v].begin(), faces_of[v].end(), [&](int f) { return dead[f] != 0; }),
                            faces_of[v].end());
        faces_of[a].erase(std::remove_if(faces_of[a].begin(), faces_of[a].end(), [&](int f) { return dead[f] != 0; }),
                          faces_of[a].end());
        changed = true;
      }
  }
  std::vector<Eigen::Vector3i> alive;
  for (size_t f = 0; f < F.size(); ++f)
    if (!dead[f]) alive.push_back(F[f]);
  F.swap(alive);
}

// ---------------------------------------------------------------------------------------------
// Analytic shapes

/// Unit-diameter sphere from a cube whose faces are gridded at equal angles and projected.
SurfaceMesh make_sphere(int res) {
  const int n = std::max(2, res / 2);
  std::vector<Vec3> V;
  std::vector<Eigen::Vector3i> F;
  lattice_box_surface(n, n, n, V, F);
  for (auto& p : V) {
    for (int k = 0; k < 3; ++k) p[k] = std::tan((2.0 * p[k] / n - 1.0) * kPi / 4);
    p = 0.5 * p.normalized();
  }
  return pack(V, std::move(F), "sphere");
}

constexpr double kTorusR = 0.5, kTorusr = 0.2;

SurfaceMesh make_torus(int res, bool bumpy) {
  const int nu = std::max(8, res), nv = std::max(6, res / 2);
  return periodic_surface(
      nu, nv,
      [bumpy](double u, double v) {
        // Bumps: the tube radius varies by +-20 % (6 lobes around, 4 across), never self-touching.
        double r = kTorusr * (bumpy ? 1.0 + 0.2 * std::cos(6 * u) * std::cos(4 * v) : 1.0);
        return Vec3((kTorusR + r * std::cos(v)) * std::cos(u), (kTorusR + r * std::cos(v)) * std::sin(u),
                    r * std::sin(v));
      },
      bumpy ? "bumpy_torus" : "torus");
}

constexpr double kBox[3] = {1.0, 0.6, 0.4};

SurfaceMesh make_box(int res) {
  int n[3];
  for (int k = 0; k < 3; ++k) n[k] = std::max(1, static_cast<int>(std::lround(res * kBox[k] / kBox[0])));
  std::vector<Vec3> V;
  std::vector<Eigen::Vector3i> F;
  lattice_box_surface(n[0], n[1], n[2], V, F);
  for (auto& p : V)
    for (int k = 0; k < 3; ++k) p[k] = kBox[k] * (p[k] / n[k] - 0.5);
  return pack(V, std::move(F), "box");
}

// ---------------------------------------------------------------------------------------------
// Signed distance functions (negative inside) and CSG on them. min / max of exact distances give
// the exact zero set of union / intersection / difference, which is all the mesher needs.

using Sdf = std::function<double(const Vec3&)>;

double sd_box(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  Vec3 q = (p - 0.5 * (lo + hi)).cwiseAbs() - 0.5 * (hi - lo);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}
/// Infinite cylinder with axis through c along unit direction a.
double sd_cylinder(const Vec3& p, const Vec3& c, const Vec3& a, double r) {
  Vec3 d = p - c;
  return (d - d.dot(a) * a).norm() - r;
}
/// Half-space n.p <= off (n unit).
double sd_halfspace(const Vec3& p, const Vec3& n, double off) { return n.dot(p) - off; }
double sd_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  Vec3 ab = b - a;
  double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - a - t * ab).norm();
}
double csg_union(double a, double b) { return std::min(a, b); }
double csg_intersect(double a, double b) { return std::max(a, b); }
double csg_difference(double a, double b) { return std::max(a, -b); }

/// Samples f into a narrow-band level set with voxel = longest side of [lo, hi] / res, meshes the
/// zero set with OpenVDB's volume-to-mesh and splits its quads into triangles.
SurfaceMesh mesh_sdf(const Sdf& f, const Vec3& lo, const Vec3& hi, int res, const std::string& name) {
  static std::once_flag vdb_init;
  std::call_once(vdb_init, [] { openvdb::initialize(); });

  const double voxel = (hi - lo).maxCoeff() / res;
  const float band = static_cast<float>(3.0 * voxel);
  auto grid = openvdb::FloatGrid::create(band);
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  // An irrational-ish offset of the lattice keeps the axis-aligned faces of the solids off the
  // sample points, so no sample is exactly on the surface.
  const Vec3 shift = voxel * Vec3(0.3137, 0.2718, 0.1414);
  auto xf = openvdb::math::Transform::createLinearTransform(voxel);
  xf->postTranslate(openvdb::Vec3d(shift[0], shift[1], shift[2]));
  grid->setTransform(xf);

  auto acc = grid->getAccessor();
  const Eigen::Vector3i i0 = ((lo - shift) / voxel).array().floor().cast<int>() - 3;
  const Eigen::Vector3i i1 = ((hi - shift) / voxel).array().ceil().cast<int>() + 3;
  for (int i = i0[0]; i <= i1[0]; ++i)
    for (int j = i0[1]; j <= i1[1]; ++j)
      for (int k = i0[2]; k <= i1[2]; ++k) {
        double d = f(shift + voxel * Vec3(i, j, k));
        if (std::abs(d) < band) acc.setValue(openvdb::Coord(i, j, k), static_cast<float>(d));
      }
  openvdb::tools::signedFloodFill(grid->tree());

  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, tris, quads, 0.0, 0.0, true);

  std::vector<Vec3> V;
  V.reserve(points.size());
  for (const auto& p : points) V.emplace_back(p[0], p[1], p[2]);
  std::vector<Eigen::Vector3i> F;
  F.reserve(2 * quads.size() + tris.size());
  for (const auto& t : tris) F.emplace_back(int(t[0]), int(t[1]), int(t[2]));
  for (const auto& q : quads) add_quad(V, F, int(q[0]), int(q[1]), int(q[2]), int(q[3]));
  collapse_short_edges(V, F, 0.2 * voxel);
  return pack(V, std::move(F), name);
}

/// A flat bar with rounded ends (stadium cross-section in xy, thickness in z) and two round
/// through-holes along z: genus 2.
SurfaceMesh make_rod_with_holes(int res) {
  const double half_len = 0.45, half_w = 0.2, half_t = 0.1, hole_r = 0.1;
  Sdf f = [=](const Vec3& p) {
    double d2 = sd_segment(Vec3(p.x(), p.y(), 0), Vec3(-half_len, 0, 0), Vec3(half_len, 0, 0)) - half_w;
    Eigen::Vector2d w(d2, std::abs(p.z()) - half_t);  // extrusion of the 2-d stadium along z
    double rod = w.cwiseMax(0.0).norm() + std::min(w.maxCoeff(), 0.0);
    for (double cx : {-0.3, 0.3}) rod = csg_difference(rod, sd_cylinder(p, Vec3(cx, 0, 0), Vec3::UnitZ(), hole_r));
    return rod;
  };
  Vec3 ext(half_len + half_w, half_w, half_t);
  return mesh_sdf(f, -ext, ext, res, "rod_with_holes");
}

/// An L-shaped block: a long foot and an upright, each a box, joined by a CSG union.
SurfaceMesh make_l_block(int res) {
  Sdf f = [](const Vec3& p) {
    return csg_union(sd_box(p, Vec3(0, 0, 0), Vec3(1.0, 0.5, 0.3)), sd_box(p, Vec3(0, 0, 0), Vec3(0.3, 0.5, 0.8)));
  };
  return mesh_sdf(f, Vec3(0, 0, 0), Vec3(1.0, 0.5, 0.8), res, "l_block");
}

/// A thick-walled pipe bent by 90 degrees: straight leg, quarter torus, straight leg, open at both
/// ends (genus 1).
SurfaceMesh make_bent_pipe(int res) {
  const double bend = 0.5, leg = 0.4, r_out = 0.15, r_in = 0.09;
  // Distance to the centreline; the legs run past the end planes so the bore cuts them open.
  auto centreline = [=](const Vec3& p) {
    double rho = std::hypot(p.x(), p.y());
    double t = std::atan2(p.y(), p.x());
    double d = (t >= 0 && t <= kPi / 2) ? std::hypot(rho - bend, p.z()) : 1e9;
    d = std::min(d, sd_segment(p, Vec3(bend, 0, 0), Vec3(bend, -leg - 0.5, 0)));
    return std::min(d, sd_segment(p, Vec3(0, bend, 0), Vec3(-leg - 0.5, bend, 0)));
  };
  Sdf f = [=](const Vec3& p) {
    double d = centreline(p);
    double solid = csg_intersect(d - r_out, sd_halfspace(p, -Vec3::UnitY(), leg));
    solid = csg_intersect(solid, sd_halfspace(p, -Vec3::UnitX(), leg));
    return csg_difference(solid, d - r_in);
  };
  return mesh_sdf(f, Vec3(-leg, -leg, -r_out), Vec3(bend + r_out, bend + r_out, r_out), res, "bent_pipe");
}

/// A CAD-like block in the spirit of the fandisk: a base plate with a raised block, a 45 degree
/// chamfer on each, and a cylindrical trough cut across the raised block (sharp convex and concave
/// edges, a curved patch). Genus 0.
SurfaceMesh make_fandisk_like(int res) {
  Sdf f = [](const Vec3& p) {
    const double s = std::sqrt(0.5);
    double base = sd_box(p, Vec3(0, 0, 0), Vec3(1.0, 0.6, 0.3));
    base = csg_intersect(base, sd_halfspace(p, Vec3(0, -s, s), s * 0.22));  // chamfer the front top edge
    double raised = sd_box(p, Vec3(0.2, 0.25, 0.25), Vec3(1.0, 0.6, 0.55));
    raised = csg_intersect(raised, sd_halfspace(p, Vec3(-s, 0, s), s * (0.55 - 0.35)));  // chamfer its left top edge
    double solid = csg_union(base, raised);
    return csg_difference(solid, sd_cylinder(p, Vec3(0.65, 0, 0.58), Vec3::UnitY(), 0.15));
  };
  return mesh_sdf(f, Vec3(0, 0, 0), Vec3(1.0, 0.6, 0.55), res, "fandisk_like");
}

// ---------------------------------------------------------------------------------------------
// Exact polyhedral solids with sharp edges (CAD-like: the creases are the solid's own, not a level
// set's rounding), built from structured quad grids so that no triangle is a sliver.

/// A planar quad mesh of a cross-section: points (u, w) and quads counter-clockwise.
struct Section {
  std::vector<Eigen::Vector2d> P;
  std::vector<std::array<int, 4>> Q;
};

/// Adds to `s` the grid of quad (a, b, c, d) (counter-clockwise corners), nu x nw cells, bilinear; points on
/// its sides are shared with quads added before (matched by position).
void add_grid(Section& s, const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
              const Eigen::Vector2d& d, int nu, int nw) {
  auto id = [&](const Eigen::Vector2d& x) {
    for (size_t i = 0; i < s.P.size(); ++i)
      if ((s.P[i] - x).norm() < 1e-12) return int(i);
    s.P.push_back(x);
    return int(s.P.size()) - 1;
  };
  std::vector<int> g(size_t((nu + 1) * (nw + 1)));
  for (int j = 0; j <= nw; ++j)
    for (int i = 0; i <= nu; ++i) {
      const double u = double(i) / nu, w = double(j) / nw;
      g[size_t(j * (nu + 1) + i)] = id((1 - u) * (1 - w) * a + u * (1 - w) * b + u * w * c + (1 - u) * w * d);
    }
  for (int j = 0; j < nw; ++j)
    for (int i = 0; i < nu; ++i)
      s.Q.push_back({g[size_t(j * (nu + 1) + i)], g[size_t(j * (nu + 1) + i + 1)],
                     g[size_t((j + 1) * (nu + 1) + i + 1)], g[size_t((j + 1) * (nu + 1) + i)]});
}

/// The closed surface of a cross-section (in the xz plane) extruded along y over [0, length] in `layers`.
SurfaceMesh extrude(const Section& s, double length, int layers, const std::string& name) {
  std::vector<Vec3> V;
  std::vector<Eigen::Vector3i> F;
  const int n = int(s.P.size());
  for (int l = 0; l <= layers; ++l)
    for (const auto& p : s.P) V.emplace_back(p[0], length * l / layers, p[1]);
  auto at = [&](int i, int l) { return l * n + i; };
  for (const auto& q : s.Q) {  // caps: y = 0 faces -y, y = length faces +y (pack orients the whole)
    add_quad(V, F, at(q[0], 0), at(q[1], 0), at(q[2], 0), at(q[3], 0));
    add_quad(V, F, at(q[3], layers), at(q[2], layers), at(q[1], layers), at(q[0], layers));
  }
  std::map<std::pair<int, int>, int> uses;  // section edges in one quad only: the outline
  for (const auto& q : s.Q)
    for (int k = 0; k < 4; ++k) ++uses[{std::min(q[k], q[(k + 1) % 4]), std::max(q[k], q[(k + 1) % 4])}];
  for (const auto& q : s.Q)
    for (int k = 0; k < 4; ++k) {
      const int a = q[k], b = q[(k + 1) % 4];
      if (uses[{std::min(a, b), std::max(a, b)}] != 1) continue;
      for (int l = 0; l < layers; ++l) add_quad(V, F, at(b, l), at(a, l), at(a, l + 1), at(b, l + 1));
    }
  return pack(V, std::move(F), name);
}

/// Cells of about `step` along a side of length `len` (at least one).
int cells(double len, double step) { return std::max(1, int(std::lround(len / step))); }

/// An exact L-shaped block, the l_block's solid without the level set's rounding: a 1 x 0.5 x 0.3 foot and a
/// 0.3 x 0.5 x 0.5 upright on its end (cross-section in xz, extruded along y). Sharp edges, genus 0.
SurfaceMesh make_sharp_l_block(int res) {
  const double step = 1.0 / res;
  Section s;
  using P2 = Eigen::Vector2d;
  add_grid(s, P2(0, 0), P2(0.3, 0), P2(0.3, 0.3), P2(0, 0.3), cells(0.3, step), cells(0.3, step));
  add_grid(s, P2(0.3, 0), P2(1, 0), P2(1, 0.3), P2(0.3, 0.3), cells(0.7, step), cells(0.3, step));
  add_grid(s, P2(0, 0.3), P2(0.3, 0.3), P2(0.3, 0.8), P2(0, 0.8), cells(0.3, step), cells(0.5, step));
  return extrude(s, 0.5, cells(0.5, step), "sharp_l_block");
}

/// A 1 x 0.6 x 0.4 box (cross-section 1 x 0.4 in xz, extruded 0.6 along y) with its top edge at x = 1
/// chamfered at 45 degrees, 0.15 wide along each face: two creases of 45 degrees and the box's of 90.
SurfaceMesh make_chamfered_box(int res) {
  const double step = 1.0 / res, c = 0.15;
  Section s;
  using P2 = Eigen::Vector2d;
  add_grid(s, P2(0, 0), P2(1 - c, 0), P2(1 - c, 0.4), P2(0, 0.4), cells(1 - c, step), cells(0.4, step));
  add_grid(s, P2(1 - c, 0), P2(1, 0), P2(1, 0.4 - c), P2(1 - c, 0.4), cells(c, step), cells(0.4, step));
  return extrude(s, 0.6, cells(0.6, step), "chamfered_box");
}

/// A cylinder of radius 0.3 and height 0.5 on the xy plane whose bottom edge is a fillet of radius 0.1 (smooth:
/// no crease) and whose top rim is sharp (90 degrees). The flat disks are a square grid mapped onto the disk
/// (elliptical grid mapping), the side a surface of revolution through the disks' rim points.
SurfaceMesh make_filleted_cylinder(int res) {
  const double R = 0.3, H = 0.5, f = 0.1;
  const int n = std::max(4, res / 4);  // disk grid: n x n cells, 4 n rim points
  std::vector<Vec3> V;
  std::vector<Eigen::Vector3i> F;
  // rim points of the square [-1, 1]^2, counter-clockwise, and the disk grid
  std::vector<Eigen::Vector2d> rim;
  for (int i = 0; i < n; ++i) rim.emplace_back(-1 + 2.0 * i / n, -1);
  for (int i = 0; i < n; ++i) rim.emplace_back(1, -1 + 2.0 * i / n);
  for (int i = 0; i < n; ++i) rim.emplace_back(1 - 2.0 * i / n, 1);
  for (int i = 0; i < n; ++i) rim.emplace_back(-1, 1 - 2.0 * i / n);
  auto disk = [](const Eigen::Vector2d& p) {
    return Eigen::Vector2d(p[0] * std::sqrt(1 - p[1] * p[1] / 2), p[1] * std::sqrt(1 - p[0] * p[0] / 2));
  };
  const int m = int(rim.size());
  // profile (radius, height) from the bottom disk's rim round the fillet up to the top rim
  std::vector<Eigen::Vector2d> profile;
  const int arc = std::max(4, res / 8);
  for (int k = 0; k <= arc; ++k) {
    const double t = 0.5 * kPi * k / arc;
    profile.emplace_back(R - f + f * std::sin(t), f - f * std::cos(t));
  }
  const int up = cells(H - f, 2 * kPi * R / m);
  for (int k = 1; k <= up; ++k) profile.emplace_back(R, f + (H - f) * k / up);
  // side: ring k of the profile at the rim points' angles
  for (const auto& pr : profile)
    for (const auto& r : rim) {
      const Eigen::Vector2d d = disk(r);
      V.emplace_back(pr[0] * d[0], pr[0] * d[1], pr[1]);
    }
  auto ring = [&](size_t k, int j) { return int(k) * m + (j % m); };
  for (size_t k = 0; k + 1 < profile.size(); ++k)
    for (int j = 0; j < m; ++j) add_quad(V, F, ring(k, j), ring(k, j + 1), ring(k + 1, j + 1), ring(k + 1, j));
  // disks: grid points, their rim taken from the side's first and last rings
  for (int cap = 0; cap < 2; ++cap) {
    const double radius = cap ? R : R - f, z = cap ? H : 0.0;
    const size_t k = cap ? profile.size() - 1 : 0;
    std::map<std::pair<int, int>, int> id;
    for (int j = 0; j < m; ++j) {  // rim point j of the square is grid point (i, l)
      const Eigen::Vector2d& r = rim[size_t(j)];
      id[{int(std::lround((r[0] + 1) * n / 2)), int(std::lround((r[1] + 1) * n / 2))}] = ring(k, j);
    }
    auto vid = [&](int i, int l) {
      auto it = id.find({i, l});
      if (it != id.end()) return it->second;
      const Eigen::Vector2d d = disk(Eigen::Vector2d(-1 + 2.0 * i / n, -1 + 2.0 * l / n));
      V.emplace_back(radius * d[0], radius * d[1], z);
      return id[{i, l}] = int(V.size()) - 1;
    };
    for (int l = 0; l < n; ++l)
      for (int i = 0; i < n; ++i)
        if (cap)
          add_quad(V, F, vid(i, l), vid(i + 1, l), vid(i + 1, l + 1), vid(i, l + 1));
        else
          add_quad(V, F, vid(i, l), vid(i, l + 1), vid(i + 1, l + 1), vid(i + 1, l));
  }
  return pack(V, std::move(F), "filleted_cylinder");
}

/// A square ring (outer 1 x 1, hole 1/3 x 1/3, in the xz plane) whose top climbs around it, from y = 0.3 to
/// 0.4, and drops back by one step wall 0.1 high, at z = 0.5 between the outside and the hole (x in [0, 1/3]):
/// its top is one smooth face both on the step's top and at its foot, a structure in which no one plane per
/// face gives the step a height (chart_order.h, self bridges). Cells of about 1 / resolution (walls in
/// layers of two cells); sharp edges, genus 1.
SurfaceMesh make_stepped_ring(int res) {
  const int N = 6 * std::max(1, int(std::lround(res / 6.0)));  // x = 1/3, 2/3 and z = 1/2 on grid lines
  const int a = N / 3, b = 2 * N / 3, m = N / 2;
  const double c = 1.0 / N, y0 = 0.3, dy = 0.1;
  const int L = std::max(1, int(std::lround(y0 / (2 * c))));  // wall layers below the step's foot
  const double layer = y0 / L;
  auto in_ring = [&](int i, int k) {
    return i >= 0 && k >= 0 && i < N && k < N && !(i >= a && i < b && k >= a && k < b);
  };
  auto on_step = [&](int i, int k) { return k == m && i <= a; };
  auto at = [&](int i, int k) { return k * (N + 1) + i; };
  std::vector<Vec3> V;
  std::vector<int> bot((N + 1) * (N + 1)), top((N + 1) * (N + 1));
  for (int k = 0; k <= N; ++k)
    for (int i = 0; i <= N; ++i) {
      const double x = c * i, z = c * k;
      bot[at(i, k)] = int(V.size());
      V.emplace_back(x, 0.0, z);
      // the angle about the ring's centre: pi on the step line (its high side), -pi just below it
      const double u = (std::atan2(z - 0.5, x - 0.5) + kPi) / (2 * kPi);
      top[at(i, k)] = int(V.size());
      V.emplace_back(x, y0 + dy * u, z);
    }
  // A boundary point's wall column, bottom to top: levels `layer` apart, the last one at least half a layer
  // below the top. On the step line the level y0 is the step's foot (the low side's top corner).
  std::map<int, std::vector<int>> columns;
  auto column = [&](int i, int k) -> const std::vector<int>& {
    auto it = columns.find(at(i, k));
    if (it != columns.end()) return it->second;
    std::vector<int> col{bot[at(i, k)]};
    const double y_top = V[size_t(top[at(i, k)])].y();
    for (int j = 1; j * layer < y_top - 0.5 * layer || (on_step(i, k) && j <= L); ++j) {
      col.push_back(int(V.size()));
      V.emplace_back(c * i, j * layer, c * k);
    }
    col.push_back(top[at(i, k)]);
    return columns.emplace(at(i, k), std::move(col)).first->second;
  };
  std::vector<int> low(size_t(a) + 1);
  for (int i = 0; i <= a; ++i) low[size_t(i)] = column(i, m)[size_t(L)];
  // a cell's top corner: on the step line, the high copy for cells above it (k >= m), the foot below
  auto tv = [&](int i, int k, int cell_k) { return on_step(i, k) && cell_k < m ? low[size_t(i)] : top[at(i, k)]; };
  auto bv = [&](int i, int k) { return bot[at(i, k)]; };
  // a column as a cell sees it: up to the foot for the low side of the step line, all of it otherwise
  auto side_column = [&](int i, int k, int cell_k) {
    std::vector<int> col = column(i, k);
    if (on_step(i, k) && cell_k < m) col.resize(size_t(L) + 1);
    return col;
  };
  std::vector<Eigen::Vector3i> F;
  // the strip between columns P and Q, where P -> Q along the boundary and then up is counter-clockwise
  // seen from outside: triangles advance on the column whose next vertex is lower
  auto strip = [&](const std::vector<int>& P, const std::vector<int>& Q) {
    size_t i = 0, j = 0;
    while (i + 1 < P.size() || j + 1 < Q.size()) {
      const bool up_p = j + 1 == Q.size() || (i + 1 < P.size() && V[size_t(P[i + 1])].y() <= V[size_t(Q[j + 1])].y());
      if (up_p)
        F.emplace_back(P[i], Q[j], P[i + 1]), ++i;
      else
        F.emplace_back(P[i], Q[j], Q[j + 1]), ++j;
    }
  };
  for (int k = 0; k < N; ++k)
    for (int i = 0; i < N; ++i) {
      if (!in_ring(i, k)) continue;
      add_quad(V, F, bv(i, k), bv(i + 1, k), bv(i + 1, k + 1), bv(i, k + 1));                 // -y
      add_quad(V, F, tv(i, k, k), tv(i, k + 1, k), tv(i + 1, k + 1, k), tv(i + 1, k, k));     // +y
      if (!in_ring(i - 1, k)) strip(side_column(i, k, k), side_column(i, k + 1, k));          // -x
      if (!in_ring(i + 1, k)) strip(side_column(i + 1, k + 1, k), side_column(i + 1, k, k));  // +x
      if (!in_ring(i, k - 1)) strip(side_column(i + 1, k, k), side_column(i, k, k));          // -z
      if (!in_ring(i, k + 1)) strip(side_column(i, k + 1, k), side_column(i + 1, k + 1, k));  // +z
    }
  for (int i = 0; i < a; ++i) {  // the step wall, facing -z: the columns above the foot
    const std::vector<int>& p = column(i + 1, m);
    const std::vector<int>& q = column(i, m);
    strip(std::vector<int>(p.begin() + L, p.end()), std::vector<int>(q.begin() + L, q.end()));
  }
  return pack(V, std::move(F), "stepped_ring");
}

}  // namespace

std::vector<std::string> shape_names() {
  return {"sphere",       "torus", "bumpy_torus",   "rod_with_holes", "l_block",           "bent_pipe",
          "fandisk_like", "box",   "sharp_l_block", "chamfered_box",  "filleted_cylinder", "stepped_ring"};
}

SurfaceMesh make_shape(const ShapeParams& p) {
  if (p.resolution < 1) throw InvalidInput("shapes: resolution must be positive, got " + std::to_string(p.resolution));
  const int r = p.resolution;
  if (p.name == "sphere") return make_sphere(r);
  if (p.name == "torus") return make_torus(r, false);
  if (p.name == "bumpy_torus") return make_torus(r, true);
  if (p.name == "rod_with_holes") return make_rod_with_holes(r);
  if (p.name == "l_block") return make_l_block(r);
  if (p.name == "bent_pipe") return make_bent_pipe(r);
  if (p.name == "fandisk_like") return make_fandisk_like(r);
  if (p.name == "box") return make_box(r);
  if (p.name == "sharp_l_block") return make_sharp_l_block(r);
  if (p.name == "chamfered_box") return make_chamfered_box(r);
  if (p.name == "filleted_cylinder") return make_filleted_cylinder(r);
  if (p.name == "stepped_ring") return make_stepped_ring(r);
  std::string list;
  for (auto& n : shape_names()) list += (list.empty() ? "" : ", ") + n;
  throw InvalidInput("shapes: unknown shape `" + p.name + "`; valid shapes: " + list);
}

}  // namespace polyhex
