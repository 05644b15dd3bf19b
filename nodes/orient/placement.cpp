// The canonical frame of a surface. See placement.h.
#include "nodes/orient/placement.h"

#include "runtime/errors.h"

#include <cmath>
#include <string>

namespace polyhex {

Frames placement_frame(const SurfaceMesh& s, const PlacementParams& p, PlacementStats* stats) {
  if (p.grid_bits < 8 || p.grid_bits > 40) throw ConfigError("placement: grid_bits must be in [8, 40]");
  if (!s.V.allFinite()) throw InvalidInput(s.source + ": a vertex coordinate is not finite");
  Frames f;
  FrameCandidate c;
  c.branch = 1;
  c.source = "input";
  if (p.frame == PlacementFrame::canonical) {
    const Eigen::Index n = s.V.rows();
    if (n < 3) throw InvalidInput(s.source + ": fewer than 3 vertices, no frame to place it in");
    const Eigen::Vector3d centre = s.V.colwise().mean().transpose();
    const RowMatrixX3d Q = s.V.rowwise() - centre.transpose();
    const Eigen::VectorXd d = Q.rowwise().norm();
    const double r = d.maxCoeff();
    if (!(r > 0)) throw InvalidInput(s.source + ": every vertex is at one point, no frame to place it in");
    // the first vertex in the file's order that is far enough (not the farthest: a symmetric shape has
    // several, and which one is the farthest is decided by rounding)
    auto first_at_least = [](const Eigen::VectorXd& x, double bound) {
      Eigen::Index i = 0;
      while (x[i] < bound) ++i;
      return i;
    };
    const Eigen::Index a = first_at_least(d, 0.9 * r);
    const Eigen::Vector3d e1 = Q.row(a).transpose() / d[a];
    const RowMatrixX3d off = Q - (Q * e1) * e1.transpose();
    const Eigen::VectorXd dl = off.rowwise().norm();
    const double rl = dl.maxCoeff();
    if (!(rl > 1e-9 * r)) throw InvalidInput(s.source + ": every vertex is on one line, no frame to place it in");
    const Eigen::Index b = first_at_least(dl, 0.5 * rl);
    const Eigen::Vector3d e2 = off.row(b).transpose() / dl[b];
    c.R.row(0) = e1.transpose();
    c.R.row(1) = e2.transpose();
    c.R.row(2) = e1.cross(e2).transpose();
    c.centre = centre;
    c.grid = std::ldexp(1.0, int(std::floor(std::log2(r))) - p.grid_bits);
    c.source = "canonical";
    if (stats) *stats = PlacementStats{int(a), int(b), r, c.grid};
  } else if (stats) {
    *stats = PlacementStats{};
  }
  f.candidates.push_back(c);
  return f;
}

}  // namespace polyhex
