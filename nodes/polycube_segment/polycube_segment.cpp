#include "nodes/polycube_segment/polycube_segment.h"

#include "nodes/algorithms/chart_order.h"
#include "nodes/algorithms/reference_length.h"
#include "nodes/polycube_segment/segment_internal.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace polyhex {

using namespace segment_detail;  // the steps of segment_internal.h

namespace {

/// One full §5.1 run with a given number of normal-smoothing passes.
/// `graph`: the deformed mesh's tet edges (for the order cycles; only used with p.split_order_cycles).
PolyCubeSegmentation segment_once(const Surface& s, const PolyCubeSegmentParams& p, int smoothing,
                                  const TetEdgeGraph* graph, const InputCreases* creases) {
  throw_if_interrupted();
  std::vector<Vec3> normal = smoothed_normals(s, smoothing, creases ? &creases->edge : nullptr);
  State st;
  st.label.resize(s.nf());
  st.band.assign(s.nf(), 0);
  for (int t = 0; t < s.nf(); ++t) st.label[t] = closest_label(normal[t]);
  if (creases) label_planar_patches(s, normal, *creases, st);
  clean_up(s, normal, p, st);
  const double h = p.hex_edge_length * s.diag;
  if (p.split_multi_orientation) split_multi_orientation(s, normal, h, p.max_splits, st);
  if (p.split_wedges) split_wedges(s, normal, p, st);
  if (p.split_ramps) split_ramps(s, normal, p, creases, st);
  const std::vector<char>* on_crease = creases ? &creases->vertex : nullptr;
  if (p.split_order_cycles) split_order_cycles(s, normal, p, *graph, on_crease, st);
  if (p.final_cleanup) remove_small_invalid(s, normal, p, st);
  repair(s, normal, p, st);
  remove_narrow_charts(s, normal, p, st);
  PolyCubeSegmentation r = make_result(s, st);
  r.order_cycles = p.split_order_cycles
                       ? order_cycles(s, analyse(s, st.label), *graph, p.hex_edge_length * s.diag, on_crease, nullptr)
                       : -1;
  r.smoothing_iterations = smoothing;
  return r;
}

void check_labels(const RowMatrixX3i& F, const Eigen::VectorXi& label) {
  if (label.size() != F.rows())
    throw InvalidInput("labelling has " + std::to_string(label.size()) + " labels for " + std::to_string(F.rows()) +
                       " triangles");
  for (int t = 0; t < label.size(); ++t)
    if (label[t] < 0 || label[t] > 5)
      throw InvalidInput("triangle " + std::to_string(t) + " has label " + std::to_string(label[t]) +
                         ", expected 0..5");
}

/// Refuses a mesh without tets or with a vertex index out of range (before anything reads the tets).
void check_tets(const TetMesh& mesh) {
  const int nt = int(mesh.T.rows()), nv = int(mesh.V.rows());
  if (nt == 0) throw InvalidInput("tet mesh has no tetrahedra");
  for (int t = 0; t < nt; ++t)
    for (int k = 0; k < 4; ++k)
      if (mesh.T(t, k) < 0 || mesh.T(t, k) >= nv)
        throw InvalidInput("tet " + std::to_string(t) + " has vertex index " + std::to_string(mesh.T(t, k)) +
                           " out of range (" + std::to_string(nv) + " vertices)");
}

/// boundary_triangles of a mesh check_tets has passed.
RowMatrixX3i checked_boundary_triangles(const TetMesh& mesh) {
  const int nt = int(mesh.T.rows());
  // outward faces of a positively oriented tet (v1-v0)x(v2-v0).(v3-v0) > 0
  static const int face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Face {
    std::array<int, 3> key;
    std::array<int, 3> tri;
  };
  // Every tet's four faces, then sorted by their vertex sets (in parallel): a face seen once is on the
  // boundary. Equal keys are the copies of one face, all dropped, so the order among them does not matter
  // and the boundary comes out in key order whatever the threads.
  std::vector<Face> faces(4 * size_t(nt));
  tbb::parallel_for(tbb::blocked_range<int>(0, nt, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int t = r.begin(); t < r.end(); ++t)
      for (int k = 0; k < 4; ++k) {
        Face& x = faces[4 * size_t(t) + size_t(k)];
        x.tri = {mesh.T(t, face[k][0]), mesh.T(t, face[k][1]), mesh.T(t, face[k][2])};
        x.key = x.tri;
        std::sort(x.key.begin(), x.key.end());
      }
  });
  tbb::parallel_sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  std::vector<std::array<int, 3>> out;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) out.push_back(faces[i].tri);
    i = j;
  }
  RowMatrixX3i F(out.size(), 3);
  for (size_t i = 0; i < out.size(); ++i) F.row(i) << out[i][0], out[i][1], out[i][2];
  return F;
}

}  // namespace

RowMatrixX3i boundary_triangles(const TetMesh& mesh) {
  check_tets(mesh);
  return checked_boundary_triangles(mesh);
}

PolyCubeSegmentation segment_polycube(const TetMesh& deformed, const PolyCubeSegmentParams& p, const TetMesh* input) {
  check_tets(deformed);  // before the two branches below read the tets
  const bool follow = input && p.follow_creases;
  if (follow && (input->V.rows() != deformed.V.rows() || input->T.rows() != deformed.T.rows()))
    throw InvalidInput(deformed.source + ": the input tets (" + std::to_string(input->V.rows()) +
                       " vertices) are not the deformed mesh's (" + std::to_string(deformed.V.rows()) + ")");
  // The tet edges (for the order cycles' evidence; not built when off) need only the tets: built beside the
  // boundary surface and the input's creases.
  RowMatrixX3i F;
  Surface s;
  std::unique_ptr<TetEdgeGraph> graph;
  std::unique_ptr<InputCreases> creases;
  tbb::parallel_invoke(
      [&] {
        F = checked_boundary_triangles(deformed);
        s = build_surface(deformed.V, F);
        if (follow)
          creases = std::make_unique<InputCreases>(
              input_creases(s, input->V, p.hex_edge_length * reference_length(input->V)));
      },
      [&] {
        if (p.split_order_cycles) graph = std::make_unique<TetEdgeGraph>(deformed.T, int(deformed.V.rows()));
      });
  PolyCubeSegmentation best = segment_once(s, p, p.smoothing_iterations, graph.get(), creases.get());
  int smoothing = p.smoothing_iterations;
  for (int retry = 0; retry < p.fallback_retries && !best.valid; ++retry) {
    smoothing = std::max(1, 2 * smoothing);
    PolyCubeSegmentation r = segment_once(s, p, smoothing, graph.get(), creases.get());
    if (r.valid) {
      r.warnings.push_back("PolyCube structure invalid with " + std::to_string(p.smoothing_iterations) +
                           " normal smoothing passes (" + std::to_string(best.problems.size()) +
                           " problem(s), charts " + id_list(best.failing_charts) + "); fallback: valid with " +
                           std::to_string(smoothing) + " passes");
      best = std::move(r);
    }
  }
  best.source = deformed.source;
  return best;
}

int count_order_cycles(const TetMesh& deformed, const PolyCubeSegmentation& seg, double hex_edge_length) {
  if (seg.F.rows() == 0 || seg.label.size() != seg.F.rows())
    throw InvalidInput("count_order_cycles: the segmentation has no labelled triangles");
  Surface s = build_surface(deformed.V, seg.F);
  std::vector<int> label(seg.label.data(), seg.label.data() + seg.label.size());
  const TetEdgeGraph graph(deformed.T, int(deformed.V.rows()));
  return order_cycles(s, analyse(s, label), graph, hex_edge_length * s.diag, nullptr, nullptr);
}

PolyCubeSegmentation analyse_polycube_labels(const RowMatrixX3d& V, const RowMatrixX3i& F,
                                             const Eigen::VectorXi& label) {
  check_labels(F, label);
  Surface s = build_surface(V, F);
  State st;
  st.label.assign(label.data(), label.data() + label.size());
  st.band.assign(s.nf(), 0);
  return make_result(s, st);
}

int clean_up_labels(const RowMatrixX3d& V, const RowMatrixX3i& F, Eigen::VectorXi& label,
                    const PolyCubeSegmentParams& p) {
  check_labels(F, label);
  Surface s = build_surface(V, F);
  State st;
  st.label.assign(label.data(), label.data() + label.size());
  clean_up(s, s.normal, p, st);
  label = Eigen::Map<const Eigen::VectorXi>(st.label.data(), s.nf());
  return st.removed_small;
}

std::pair<int, int> repair_polycube_labels(const RowMatrixX3d& V, const RowMatrixX3i& F, Eigen::VectorXi& label,
                                           const PolyCubeSegmentParams& p) {
  check_labels(F, label);
  Surface s = build_surface(V, F);
  State st;
  st.label.assign(label.data(), label.data() + label.size());
  st.band.assign(s.nf(), 0);
  repair(s, s.normal, p, st);
  label = Eigen::Map<const Eigen::VectorXi>(st.label.data(), s.nf());
  return {st.splits_island, st.repaired_corners};
}

void require_valid_polycube(const PolyCubeSegmentation& s) {
  if (s.valid) return;
  std::string msg = "invalid PolyCube structure (" + std::to_string(s.charts.size()) + " charts; failing charts " +
                    id_list(s.failing_charts) + "):";
  for (auto& p : s.problems) msg += "\n  " + p;
  throw InvalidInput(msg);
}

}  // namespace polyhex
