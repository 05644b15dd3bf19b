/// @file report_html.h
/// @brief `report.html`: one self-contained page about a run, written by `polyhex report RUN_DIR` and
/// `polyhex run --html`. It works offline: three.js (Debian `libjs-three`, read at run time) and the data
/// are inlined; nothing is fetched.
///
/// The page shows
/// - the quality node's figures (verbatim from report.json) against their thresholds: inverted = 0,
///   sj_min >= the retry block's `min_sj` (ReportHtmlParams::default_min_sj when the run had no retry),
///   sj_below_0_2 = 0 and the topology counts (unused vertices, faces in more than two hexes,
///   non-manifold boundary edges) = 0; the other figures without a threshold;
/// - histograms of the per-hex scaled Jacobian and edge ratio (both from nodes/algorithms/hex_quality.h, computed
///   on the mesh the run wrote) and the irregular vertices (count and share);
/// - per-node times as bars (slowest first: report.json keeps no node order) and the retry attempts;
/// - a 3D view (three.js, orbit controls) of the boundary quads coloured by their hex's scaled Jacobian,
///   the worst hexes drawn whole inside it and the irregular vertices as points, with a clipping plane.
///
/// Size: the geometry goes as base64 of little-endian float32 / uint32 arrays, at most
/// ReportHtmlParams::max_boundary_quads boundary quads (about 32 bytes each, 43 as base64): a larger
/// boundary is shown as its worst quarter plus an even sample of the rest, and the page says so. The
/// irregular vertices are capped the same way (an even sample).
///
/// The page reports its own state for tests: `<pre id="status" data-state="loading|ready|error">`, every
/// error (window.onerror, console.error, a missing WebGL) in `<ul id="errors">`, each figure as
/// `<tr data-key="KEY"><td class="value" data-value="VALUE as JSON">`, and the canvas rectangle as the
/// view's `data-rect="x y width height"` (CSS pixels) and `data-clip="AXIS SHARE"`. `report.html#clip=z,0.4` opens
/// the view clipped (the share of the bounding box kept below the plane along the axis).
#pragma once

#include "nodes/artefacts/meshes.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace polyhex {

struct ReportHtmlParams {
  double default_min_sj = 0.3;       ///< sj_min threshold when report.json has no retry.min_sj (configs/default.json's)
  long max_boundary_quads = 100000;  ///< boundary quads drawn at most (about 4.3 MB of page)
  long max_irregular_points = 20000;  ///< irregular vertices drawn at most
  int worst_hexes = 400;              ///< the hexes of lowest scaled Jacobian drawn whole (seen through the clip)
  int histogram_bins = 20;            ///< bins of each histogram
  double edge_ratio_cap = 10;         ///< the edge-ratio histogram ends here; larger ratios go into its last bin
};

/// The data of the page (the JSON object the page's script reads), from a run's report.json and the hex
/// mesh it wrote: figures, thresholds, histograms, irregular vertices, stage times, retry attempts and the
/// capped geometry. Pure: no file is read.
/// \param report  the parsed report.json  \param mesh  the run's hex mesh
/// \pre p.histogram_bins >= 1, p.max_boundary_quads >= 1, p.edge_ratio_cap > 1
/// \throw InvalidInput when report.json has no `nodes` object or no quality node with metrics, or the
///        mesh cannot be measured (check_hex_mesh)
nlohmann::json report_page_data(const nlohmann::json& report, const HexMesh& mesh, const ReportHtmlParams& p = {});

/// The page: its template with `three_js` and `data` inlined (`</` escaped in both so that neither ends
/// its script element). Pure.
/// \param three_js  the source of three.min.js and examples/js/controls/OrbitControls.js (read_three_js)
std::string report_page_html(const nlohmann::json& data, const std::string& three_js);

/// three.min.js then examples/js/controls/OrbitControls.js from `dir` (Debian libjs-three).
/// \throw IOError naming the missing file and the package to install
std::string read_three_js(const std::filesystem::path& dir = "/usr/share/javascript/three");

/// The hex mesh of a run: the `path` metric of its first `write_hex` node (by id); the file of that name
/// in `run_dir` when it is there (a moved folder, or a retry attempt's files moved in), else the path as
/// written (relative to `run_dir` when relative).
/// \throw IOError naming report.json when no write_hex node has a path, or naming the mesh file when it
///        is missing
std::filesystem::path report_mesh_path(const nlohmann::json& report, const std::filesystem::path& run_dir);

/// Reads RUN_DIR/report.json, the mesh (report_mesh_path, read_hexmesh) and three.js, writes
/// RUN_DIR/report.html atomically (runtime/atomic_file.h): on any error no report.html is written and an
/// existing one is kept.
/// \return the path written
/// \throw IOError naming the file that is missing or malformed (report.json, also when a value has another
///        type than `polyhex run` writes; the mesh; three.js) or cannot be written; InvalidInput from
///        report_page_data
std::filesystem::path write_report_html(const std::filesystem::path& run_dir, const ReportHtmlParams& p = {},
                                        const std::filesystem::path& three_dir = "/usr/share/javascript/three");

}  // namespace polyhex
