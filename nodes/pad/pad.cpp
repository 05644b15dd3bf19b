// Padding layer (paper §6 inset). See pad.h.
#include "nodes/pad/pad.h"

#include <tbb/parallel_for.h>

#include <array>
#include <chrono>
#include <string>
#include <vector>

#include "nodes/quality/quality.h"
#include "nodes/quality/triangle_tree.h"
#include "runtime/errors.h"

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;

std::array<Vec3, 8> hex_points(const RowMatrixX3d& V, const RowMatrixX8i& H, Eigen::Index h) {
  std::array<Vec3, 8> p;
  for (int k = 0; k < 8; ++k) p[size_t(k)] = V.row(H(h, k)).transpose();
  return p;
}

}  // namespace

HexMesh pad_boundary(const HexMesh& mesh, const SurfaceMesh* surface, const PadParams& p, PadStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  check_hex_mesh(mesh);
  const auto Q = hex_boundary_quads(mesh);
  if (Q.rows() == 0) throw InvalidInput((mesh.source.empty() ? std::string("hex mesh") : mesh.source) + ": no boundary quads to pad");
  const Eigen::Index nv = mesh.V.rows(), nh = mesh.H.rows();

  PadStats st;
  std::vector<int> inner(size_t(nv), -1);
  int nb = 0;
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k)
      if (inner[size_t(Q(q, k))] < 0) inner[size_t(Q(q, k))] = int(nv) + nb++;

  HexMesh out;
  out.source = mesh.source;
  out.V.resize(nv + nb, 3);
  out.V.topRows(nv) = mesh.V;
  if (surface) {
    TriangleTree tree(surface->V, surface->F);
    tbb::parallel_for(Eigen::Index(0), nv, [&](Eigen::Index v) {
      if (inner[size_t(v)] >= 0) out.V.row(v) = tree.closest(mesh.V.row(v).transpose()).point.transpose();
    });
  }
  // averaged outward normal (area weighted) and mean boundary edge length of each boundary vertex
  std::vector<Vec3> normal(static_cast<size_t>(nb), Vec3::Zero());
  std::vector<double> edge(static_cast<size_t>(nb), 0.0);
  std::vector<int> edges(static_cast<size_t>(nb), 0);
  for (Eigen::Index q = 0; q < Q.rows(); ++q) {
    Vec3 c[4];
    for (int k = 0; k < 4; ++k) c[k] = out.V.row(Q(q, k)).transpose();
    const Vec3 n = 0.5 * (c[2] - c[0]).cross(c[3] - c[1]);
    for (int k = 0; k < 4; ++k) {
      const size_t b = size_t(inner[size_t(Q(q, k))] - nv);
      normal[b] += n;
      edge[b] += (c[(k + 1) % 4] - c[k]).norm() + (c[(k + 3) % 4] - c[k]).norm();
      edges[b] += 2;
    }
  }
  std::vector<Vec3> offset(static_cast<size_t>(nb));
  for (size_t b = 0; b < size_t(nb); ++b) {
    const double len = normal[b].norm();
    offset[b] = len > 0 ? Vec3(-normal[b] / len * p.thickness * edge[b] / std::max(edges[b], 1)) : Vec3::Zero();
  }
  for (Eigen::Index v = 0; v < nv; ++v)
    if (inner[size_t(v)] >= 0) out.V.row(inner[size_t(v)]) = out.V.row(v) + offset[size_t(inner[size_t(v)] - nv)].transpose();

  // hexes: the old ones on the inner copies, then one per boundary quad (inner quad at the bottom)
  out.H.resize(nh + Q.rows(), 8);
  for (Eigen::Index h = 0; h < nh; ++h)
    for (int k = 0; k < 8; ++k) {
      const int v = mesh.H(h, k);
      out.H(h, k) = inner[size_t(v)] >= 0 ? inner[size_t(v)] : v;
    }
  for (Eigen::Index q = 0; q < Q.rows(); ++q)
    for (int k = 0; k < 4; ++k) {
      out.H(nh + q, k) = inner[size_t(Q(q, k))];
      out.H(nh + q, k + 4) = Q(q, k);
    }

  // limit the offsets so that no hex that was valid, and no layer hex, inverts
  std::vector<char> was_inverted(size_t(out.H.rows()), 0);
  for (Eigen::Index h = 0; h < nh; ++h) was_inverted[size_t(h)] = hex_scaled_jacobian(hex_points(mesh.V, mesh.H, h)).corner_min <= 0;
  std::vector<double> scale(static_cast<size_t>(nb), 1.0);
  for (int round = 0; round <= p.max_halvings; ++round) {
    std::vector<char> shrink(static_cast<size_t>(nb), 0);
    bool any = false;
    for (Eigen::Index h = 0; h < out.H.rows(); ++h) {
      if (was_inverted[size_t(h)] || hex_scaled_jacobian(hex_points(out.V, out.H, h)).corner_min > 0) continue;
      for (int k = 0; k < 8; ++k)
        if (out.H(h, k) >= nv) shrink[size_t(out.H(h, k) - nv)] = 1, any = true;
    }
    if (!any || round == p.max_halvings) break;
    for (Eigen::Index v = 0; v < nv; ++v) {
      const int b = inner[size_t(v)] - int(nv);
      if (b < 0 || !shrink[size_t(b)]) continue;
      scale[size_t(b)] *= 0.5;
      out.V.row(nv + b) = out.V.row(v) + scale[size_t(b)] * offset[size_t(b)].transpose();
    }
  }
  for (double s : scale) st.limited += s < 1.0;
  Eigen::VectorXd sj, corner;
  hex_scaled_jacobians(out, sj, corner);
  st.inverted = long((corner.array() <= 0).count());
  st.hexes_added = long(Q.rows());
  st.vertices_added = nb;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats = st;
  return out;
}

}  // namespace polyhex
