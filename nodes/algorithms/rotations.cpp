#include "nodes/algorithms/rotations.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace polyhex {
namespace {

double radical_inverse(unsigned i, unsigned base) {
  double inv = 1.0 / base, f = inv, r = 0;
  for (; i > 0; i /= base, f *= inv) r += f * double(i % base);
  return r;
}

/// The 24 proper signed permutation matrices, in a fixed order.
const std::vector<Eigen::Matrix3d>& cube_rotations() {
  static const std::vector<Eigen::Matrix3d> all = [] {
    std::vector<Eigen::Matrix3d> out;
    std::array<int, 3> perm{0, 1, 2};
    do {
      for (int signs = 0; signs < 8; ++signs) {
        Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
        for (int r = 0; r < 3; ++r) P(r, perm[size_t(r)]) = (signs >> r) & 1 ? -1.0 : 1.0;
        if (P.determinant() > 0) out.push_back(P);
      }
    } while (std::next_permutation(perm.begin(), perm.end()));
    return out;
  }();
  return all;
}

}  // namespace

Eigen::Matrix3d spread_rotation(unsigned i) {
  const double u1 = radical_inverse(i + 1, 2), u2 = radical_inverse(i + 1, 3), u3 = radical_inverse(i + 1, 5);
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1), two_pi = 2 * M_PI;
  const Eigen::Quaterniond q(b * std::cos(two_pi * u3), a * std::sin(two_pi * u2), a * std::cos(two_pi * u2),
                             b * std::sin(two_pi * u3));
  return q.normalized().toRotationMatrix();
}

Eigen::Matrix3d turn(const Eigen::Vector3d& w, const Eigen::Matrix3d& R0) {
  const double angle = w.norm();
  if (angle == 0) return R0;
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() * R0;
}

Eigen::Matrix3d canonical_frame(const Eigen::Matrix3d& R) {
  const Eigen::Matrix3d* best = nullptr;
  double best_trace = -HUGE_VAL;
  for (const Eigen::Matrix3d& P : cube_rotations()) {
    const double t = (P * R).trace();
    if (t > best_trace + 1e-12) best_trace = t, best = &P;
  }
  return *best * R;
}

double frame_distance_degrees(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  double best = 180;
  const Eigen::Matrix3d D = A * B.transpose();
  for (const Eigen::Matrix3d& P : cube_rotations()) {
    const double c = std::clamp(((P * D).trace() - 1) / 2, -1.0, 1.0);
    best = std::min(best, std::acos(c) * 180 / M_PI);
  }
  return best;
}

}  // namespace polyhex
