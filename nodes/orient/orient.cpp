#include "nodes/orient/orient.h"

#include "nodes/algorithms/rotations.h"
#include "runtime/errors.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

namespace polyhex {
namespace {

using Vec3 = Eigen::Vector3d;

/// Energies closer than this are equal (a tilt of about a quarter of a degree of a part whose faces are
/// all on the axes): the input frame is not replaced by a minimum next to it that gains less.
constexpr double kMinGain = 1e-4;

/// Area-weighted mean normal of the triangles whose normals fall in one cell of a cube map.
struct Bin {
  Vec3 n;
  double w = 0;
};

/// fn(cr, |cr|) for every triangle of positive, finite area; cr = (b - a) x (c - a), twice the area
/// times the unit normal.
template <class Fn>
void for_each_normal(const SurfaceMesh& s, Fn fn) {
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const Vec3 a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)), c = s.V.row(s.F(f, 2));
    const Vec3 cr = (b - a).cross(c - a);
    const double len = cr.norm();
    if (len > 0 && std::isfinite(len)) fn(cr, len);
  }
}

std::vector<Bin> normal_bins(const SurfaceMesh& s, int cells) {
  std::vector<Vec3> sum(size_t(6 * cells * cells), Vec3::Zero());
  std::vector<double> weight(sum.size(), 0);
  for_each_normal(s, [&](const Vec3& cr, double len) {
    const Vec3 u = cr / len;
    int axis = 0;
    for (int i = 1; i < 3; ++i)
      if (std::abs(u[i]) > std::abs(u[axis])) axis = i;
    const int face = 2 * axis + (u[axis] < 0 ? 1 : 0);
    auto cell = [&](double x) { return std::clamp(int((x / std::abs(u[axis]) + 1) / 2 * cells), 0, cells - 1); };
    const int i = cell(u[(axis + 1) % 3]), j = cell(u[(axis + 2) % 3]);
    const size_t k = size_t((face * cells + i) * cells + j);
    sum[k] += 0.5 * cr;  // area times the unit normal
    weight[k] += 0.5 * len;
  });
  std::vector<Bin> bins;
  for (size_t k = 0; k < sum.size(); ++k)
    if (weight[k] > 0 && sum[k].norm() > 0) bins.push_back({sum[k].normalized(), weight[k]});
  return bins;
}

double energy(const std::vector<Bin>& bins, double total, const Eigen::Matrix3d& R) {
  double e = 0;
  for (const Bin& b : bins) {
    const Vec3 m = R * b.n;
    e += b.w * (1 - m.array().pow(4).sum());
  }
  return e / (0.4 * total);
}

/// dE/dw of E(exp([w]x) R) at w = 0.
Vec3 gradient(const std::vector<Bin>& bins, double total, const Eigen::Matrix3d& R) {
  Vec3 g = Vec3::Zero();
  for (const Bin& b : bins) {
    const Vec3 m = R * b.n;
    g += b.w * m.cross(Vec3(m.array().cube()));
  }
  return -4.0 * g / (0.4 * total);
}

struct Descent {
  Eigen::Matrix3d R;
  double E;
};

/// Gradient descent on SO(3) with an adaptive step, from R0 to a local minimum of E.
Descent descend(const std::vector<Bin>& bins, double total, Eigen::Matrix3d R) {
  double E = energy(bins, total, R), step = 0.02;
  for (int it = 0; it < 1000; ++it) {
    const Vec3 g = gradient(bins, total, R);
    if (g.norm() < 1e-14 || step * g.norm() < 1e-13) break;
    const Eigen::Matrix3d Rn = turn(-step * g, R);
    const double En = energy(bins, total, Rn);
    if (En < E) {
      R = Rn, E = En;
      step *= 1.5;
    } else {
      step *= 0.5;
    }
  }
  return {R, E};
}

/// The part of a frame's area whose normals are within 0.1 degree of an axis.
double flat_area(const std::vector<Bin>& tris, double total, const Eigen::Matrix3d& R) {
  const double cos_tol = std::cos(0.1 * M_PI / 180);
  double a = 0;
  for (const Bin& b : tris)
    if ((R * b.n).cwiseAbs().maxCoeff() >= cos_tol) a += b.w;
  return a / total;
}

/// The frame of the flat faces next to a minimum d of the alignment energy (the option flat_sigma_degrees).
/// The quartic energy counts every normal, so the normals on no axis (a cylinder, a chamfer, a fillet) pull
/// its minimum off the frame of a part's flat faces: the turned copies of 7-connected and fandisk ran 0.93
/// and 4.7 degrees off it, where their originals run in it. Gauss-Newton over left turns on
/// sum_t w_t |m_t - (m_t)_i e_i|^2 (m_t = R n_t, e_i its nearest axis), with the robust weights
/// w_t = A_t exp(-|m_t - (m_t)_i e_i|^2 / sigma^2) taken anew each step and sigma narrowed in steps,
/// converges to the frame in which the faces near an axis are on it. Kept when it stays within
/// distinct_degrees of d and puts at least flat_min_area of the area within 0.1 degree of an axis;
/// otherwise (a scan, an organic shape) d is left as it is. Returns whether it was kept.
bool flat_faces(const std::vector<Bin>& tris, double total, const OrientParams& p, Descent& d) {
  if (p.flat_sigma_degrees <= 0) return false;
  Eigen::Matrix3d R = d.R;
  // sigma from flat_sigma_degrees down to 1/100 of it: the wide weights reach faces a degree or two off,
  // the narrow ones leave only the faces that are flat to the bits, whose frame is then exact.
  for (double sigma = p.flat_sigma_degrees; sigma >= 0.0099 * p.flat_sigma_degrees; sigma /= std::sqrt(10.0)) {
    const double inv_s2 = 1 / std::pow(sigma * M_PI / 180, 2);
    for (int it = 0; it < 30; ++it) {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      Vec3 g = Vec3::Zero();
      for (const Bin& b : tris) {
        const Vec3 m = R * b.n;
        int i = 0;
        m.cwiseAbs().maxCoeff(&i);
        const double off2 = std::max(0.0, 1 - m[i] * m[i]), w = b.w * std::exp(-off2 * inv_s2);
        if (!(w > 0)) continue;
        for (int j = 0; j < 3; ++j) {
          if (j == i) continue;
          // d(turn(v, R) n)_j / dv at v = 0: row j of -[m]x
          const Vec3 J = j == 0 ? Vec3(0, m[2], -m[1]) : j == 1 ? Vec3(-m[2], 0, m[0]) : Vec3(m[1], -m[0], 0);
          H += w * J * J.transpose();
          g += w * m[j] * J;
        }
      }
      if (!(H.trace() > 0)) return false;
      H.diagonal().array() += 1e-12 * H.trace();  // a single face leaves the turn about its normal free
      const Vec3 step = -H.ldlt().solve(g);
      if (!step.allFinite()) return false;
      R = turn(step, R);
      if (step.norm() < 1e-15) break;
    }
  }
  if (frame_distance_degrees(R, d.R) >= p.distinct_degrees || flat_area(tris, total, R) < p.flat_min_area) return false;
  d = {R, energy(tris, total, R)};
  return true;
}

/// Rows: the eigenvectors of the normals' second-moment tensor, a right-handed frame.
Eigen::Matrix3d principal_axes(const std::vector<Bin>& bins) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (const Bin& b : bins) M += b.w * b.n * b.n.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M);
  Eigen::Matrix3d R = es.eigenvectors().transpose();
  if (R.determinant() < 0) R.row(2) *= -1;
  return R;
}

/// A right-handed frame whose first axis is a and second is b made orthogonal to a.
Eigen::Matrix3d frame_of(const Vec3& a, const Vec3& b) {
  const Vec3 x = a.normalized(), y = (b - b.dot(x) * x).normalized();
  Eigen::Matrix3d R;
  R.row(0) = x.transpose();
  R.row(1) = y.transpose();
  R.row(2) = x.cross(y).transpose();
  return R;
}

void check(const OrientParams& p) {
  auto range = [](bool ok, const char* what) {
    if (!ok) throw ConfigError(std::string("orient: ") + what);
  };
  range(p.max_frames >= 1 && p.max_frames <= 8, "max_frames must be in [1, 8]");
  range(p.within >= 0 && p.within <= 10, "within must be in [0, 10]");
  range(p.distinct_degrees > 0 && p.distinct_degrees <= 45, "distinct_degrees must be in (0, 45]");
  range(p.histogram >= 2 && p.histogram <= 256, "histogram must be in [2, 256]");
  range(p.spread_starts >= 0 && p.spread_starts <= 1000, "spread_starts must be in [0, 1000]");
  range(p.flat_sigma_degrees >= 0 && p.flat_sigma_degrees <= 20, "flat_sigma_degrees must be in [0, 20]");
  range(p.flat_min_area >= 0 && p.flat_min_area <= 1, "flat_min_area must be in [0, 1]");
}

/// Every triangle of positive area as its own bin: the exact energy, the same in any frame.
std::vector<Bin> triangle_normals(const SurfaceMesh& s) {
  std::vector<Bin> out;
  out.reserve(size_t(s.F.rows()));
  for_each_normal(s, [&](const Vec3& cr, double len) { out.push_back({cr / len, 0.5 * len}); });
  return out;
}

/// cells > 0: the cube-map bins; 0: every triangle.
std::vector<Bin> bins_of(const SurfaceMesh& s, int cells, double& total) {
  if (!s.V.allFinite()) throw InvalidInput(s.source + ": a vertex coordinate is not finite");
  std::vector<Bin> bins = cells > 0 ? normal_bins(s, cells) : triangle_normals(s);
  total = 0;
  for (const Bin& b : bins) total += b.w;
  if (!(total > 0)) throw InvalidInput(s.source + ": no triangle of positive area, so no normal to orient by");
  return bins;
}

}  // namespace

double alignment_energy(const SurfaceMesh& s, const Eigen::Matrix3d& R) {
  double total = 0;
  const std::vector<Bin> tris = bins_of(s, 0, total);
  return energy(tris, total, R);
}

Frames input_frame_only(const SurfaceMesh& s) {
  Frames f;
  FrameCandidate c;
  c.energy = alignment_energy(s, Eigen::Matrix3d::Identity());
  c.source = "input";
  c.branch = 1;
  f.candidates.push_back(c);
  return f;
}

Frames orient_frames(const SurfaceMesh& s, const OrientParams& p, OrientStats* stats,
                     const Eigen::Matrix3d* input_axes) {
  check(p);
  // The descents run on the binned normals (cheap), and each minimum found is polished and scored on
  // every triangle's normal: bins depend on the frame, the triangles do not.
  double total = 0, total_exact = 0;
  const std::vector<Bin> bins = bins_of(s, p.histogram, total);
  const std::vector<Bin> tris = bins_of(s, 0, total_exact);

  struct Start {
    Eigen::Matrix3d R;
    std::string source;
  };
  std::vector<Start> starts{{Eigen::Matrix3d::Identity(), "from_input"}, {principal_axes(bins), "principal_axes"}};
  std::vector<size_t> heavy(bins.size());
  for (size_t k = 0; k < heavy.size(); ++k) heavy[k] = k;
  const size_t top = std::min<size_t>(6, heavy.size());
  std::partial_sort(heavy.begin(), heavy.begin() + long(top), heavy.end(),
                    [&](size_t a, size_t b) { return bins[a].w != bins[b].w ? bins[a].w > bins[b].w : a < b; });
  const double sin20 = std::sin(20 * M_PI / 180);
  int pairs = 0;
  for (size_t a = 0; a < top && pairs < 6; ++a)
    for (size_t b = a + 1; b < top && pairs < 6; ++b)
      if (std::abs(bins[heavy[a]].n.dot(bins[heavy[b]].n)) < sin20) {
        starts.push_back({frame_of(bins[heavy[a]].n, bins[heavy[b]].n), "normals"});
        ++pairs;
      }
  for (int i = 0; i < p.spread_starts; ++i) starts.push_back({spread_rotation(unsigned(i)), "spread"});

  Frames out;
  FrameCandidate input;
  if (input_axes) input.R = *input_axes;
  input.energy = energy(tris, total_exact, input.R);
  input.source = "input";
  input.branch = 1;
  std::vector<FrameCandidate> found;
  std::vector<std::set<std::string>> sources;
  // Merges a minimum into `found` (the lower energy of two within distinct_degrees is kept).
  auto merge = [&](const Descent& d, const std::set<std::string>& from) {
    const Eigen::Matrix3d R = canonical_frame(d.R);
    size_t same = found.size();
    for (size_t k = 0; k < found.size() && same == found.size(); ++k)
      if (frame_distance_degrees(found[k].R, R) < p.distinct_degrees) same = k;
    if (same == found.size()) {
      FrameCandidate c;
      c.R = R;
      c.energy = d.E;
      found.push_back(c);
      sources.emplace_back();
    } else if (d.E < found[same].energy) {
      found[same].R = R;
      found[same].energy = d.E;
    }
    sources[same].insert(from.begin(), from.end());
  };
  for (const Start& st : starts) merge(descend(bins, total, st.R), {st.source});
  std::vector<FrameCandidate> coarse;
  std::swap(coarse, found);
  std::vector<std::set<std::string>> coarse_sources;
  std::swap(coarse_sources, sources);
  int flattened = 0;
  for (size_t k = 0; k < coarse.size(); ++k) {
    Descent d = descend(tris, total_exact, coarse[k].R);
    std::set<std::string> from = coarse_sources[k];
    if (flat_faces(tris, total_exact, p, d)) {
      from.insert("flat_faces");
      ++flattened;
    }
    merge(d, from);
  }
  for (size_t k = 0; k < found.size(); ++k) {
    std::string names;
    for (const std::string& n : sources[k]) names += (names.empty() ? "" : "+") + n;
    found[k].source = names;
  }
  std::stable_sort(found.begin(), found.end(),
                   [](const FrameCandidate& a, const FrameCandidate& b) { return a.energy < b.energy; });
  // A minimum next to the input frame that is not clearly better is the input frame itself: the input
  // frame runs in its place and gives the mesh it gave before the search existed, bit for bit.
  // With input_axes it is the other way round: the minimum runs, found alike in every copy of the shape;
  // and the input's axes run only as the best frame (a turned copy's are another rotation, whose energy
  // on an organic model is often within `within` of the best: they would run there and not here).
  auto near_input = [&](const FrameCandidate& c) { return frame_distance_degrees(c.R, input.R) < p.distinct_degrees; };
  bool input_covered = false;
  if (input_axes)
    input_covered = std::any_of(found.begin(), found.end(), near_input) ||
                    (!found.empty() && input.energy > found.front().energy + kMinGain);
  else
    found.erase(
        std::remove_if(found.begin(), found.end(),
                       [&](const FrameCandidate& c) { return near_input(c) && input.energy - c.energy < kMinGain; }),
        found.end());
  // The branches: the lowest energy first (the input frame first among equals), then every candidate
  // within `within` of it, up to max_frames.
  std::vector<FrameCandidate*> ranked;
  if (!input_covered) ranked.push_back(&input);
  for (FrameCandidate& c : found) ranked.push_back(&c);
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const FrameCandidate* a, const FrameCandidate* b) { return a->energy < b->energy; });
  input.branch = 0;
  int branch = 1;
  const double limit = ranked.front()->energy * (1 + p.within) + kMinGain;
  for (FrameCandidate* c : ranked)
    if (branch <= p.max_frames && (branch == 1 || c->energy <= limit)) c->branch = branch++;
  out.candidates.push_back(input);
  out.candidates.insert(out.candidates.end(), found.begin(), found.end());
  if (stats) {
    stats->starts = int(starts.size());
    stats->bins = int(bins.size());
    stats->input_energy = input.energy;
    stats->best_energy = std::min(input.energy, found.empty() ? input.energy : found.front().energy);
    stats->branches = branch - 1;
    stats->flattened = flattened;
  }
  return out;
}

}  // namespace polyhex
