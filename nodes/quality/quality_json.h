/// @file quality_json.h
/// @brief The quality figures as the JSON object of `hexcheck.py --json` (same keys), used by the
/// quality node's metrics and by `polyhex check`.
#pragma once

#include "nodes/algorithms/hex_quality.h"

#include <nlohmann/json.hpp>

namespace polyhex {

/// Keys: hexes, vertices, inverted, sj_min, sj_avg, sj_corner_min, sj_corner_avg, sj_below_0_2, volume,
/// irregular_pct, irregular_interior_pct, irregular_boundary_pct, unused_vertices,
/// faces_shared_by_more_than_two, nonmanifold_boundary_edges, boundary_quads, and when q.has_surface
/// also bbox_diag, hausdorff_mean, hausdorff_max, volume_ratio. The per-hex vectors are not included.
inline nlohmann::json to_json(const HexQuality& q) {
  nlohmann::json j = {{"hexes", q.hexes},
                      {"vertices", q.vertices},
                      {"inverted", q.inverted},
                      {"sj_min", q.sj_min},
                      {"sj_avg", q.sj_avg},
                      {"sj_corner_min", q.sj_corner_min},
                      {"sj_corner_avg", q.sj_corner_avg},
                      {"sj_below_0_2", q.sj_below_0_2},
                      {"volume", q.volume},
                      {"irregular_pct", q.irregular_pct},
                      {"irregular_interior_pct", q.irregular_interior_pct},
                      {"irregular_boundary_pct", q.irregular_boundary_pct},
                      {"unused_vertices", q.unused_vertices},
                      {"faces_shared_by_more_than_two", q.faces_shared_by_more_than_two},
                      {"nonmanifold_boundary_edges", q.nonmanifold_boundary_edges},
                      {"boundary_quads", q.boundary_quads}};
  if (q.has_surface) {
    j["bbox_diag"] = q.bbox_diag;
    j["hausdorff_mean"] = q.hausdorff_mean;
    j["hausdorff_max"] = q.hausdorff_max;
    j["volume_ratio"] = q.volume_ratio;
  }
  return j;
}

/// Beyond hexcheck: the feature fidelity (feature_fidelity.h), relative to bbox_diag, when q.has_features:
/// hex_edge, feature_curves, feature_curve_length, feature_edges and, with a crease line,
/// feature_curve_to_mesh_max / _mean and feature_mesh_to_curve_max. Empty otherwise.
inline nlohmann::json feature_json(const HexQuality& q) {
  nlohmann::json j = nlohmann::json::object();
  if (!q.has_features) return j;
  j["hex_edge"] = q.hex_edge;
  j["feature_curves"] = q.features.curves;
  j["feature_curve_length"] = q.features.curve_length;
  j["feature_edges"] = q.features.mesh_feature_edges;
  if (q.features.curves > 0) {
    j["feature_curve_to_mesh_max"] = q.features.curve_to_mesh_max;
    j["feature_curve_to_mesh_mean"] = q.features.curve_to_mesh_mean;
    j["feature_mesh_to_curve_max"] = q.features.mesh_to_curve_max;
  }
  return j;
}

}  // namespace polyhex
