#include "report/report_html.h"

#include "nodes/algorithms/hex_quality.h"
#include "nodes/artefacts/hex_topology.h"
#include "nodes/formats/hexmesh_io.h"
#include "runtime/atomic_file.h"
#include "runtime/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <numeric>
#include <sstream>
#include <vector>

namespace polyhex {

const char* report_page_template();  // report/report_page.html, embedded by CMake (cmake/embed_text.cmake)

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string base64(const void* data, size_t bytes) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* b = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((bytes + 2) / 3 * 4);
  for (size_t i = 0; i < bytes; i += 3) {
    const std::uint32_t n = std::uint32_t(b[i]) << 16 | (i + 1 < bytes ? std::uint32_t(b[i + 1]) << 8 : 0) |
                            (i + 2 < bytes ? std::uint32_t(b[i + 2]) : 0);
    out += abc[n >> 18 & 63];
    out += abc[n >> 12 & 63];
    out += i + 1 < bytes ? abc[n >> 6 & 63] : '=';
    out += i + 2 < bytes ? abc[n & 63] : '=';
  }
  return out;
}
template <class T>
std::string base64(const std::vector<T>& v) {
  return base64(v.data(), v.size() * sizeof(T));
}

/// Counts of `values` in `bins` equal bins over [lo, hi]; a value above hi (or +inf) in the last bin, below
/// lo in the first.
json histogram(const Eigen::VectorXd& values, double lo, double hi, int bins) {
  std::vector<long> counts(size_t(bins), 0);
  long above = 0;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const double v = values[i];
    above += v > hi;
    const double t = (v - lo) / (hi - lo) * bins;
    const int k = !(t < bins) ? bins - 1 : t < 0 ? 0 : int(t);  // NaN and +inf: last bin
    ++counts[size_t(k)];
  }
  return {{"lo", lo}, {"hi", hi}, {"counts", counts}, {"above_hi", above}};
}

/// The quality node whose figures the page shows: the retry block's judge when it is a quality node,
/// else the first quality node by id.
std::string quality_node(const json& report) {
  auto is_quality = [&](const std::string& id) {
    const json& n = report["nodes"][id];
    if (!n.is_object() || !n.contains("type") || !n["type"].is_string()) return false;
    const std::string type = n["type"];
    return type.substr(0, type.find('/')) == "quality" && n.contains("metrics") && n["metrics"].is_object();
  };
  if (report.contains("retry") && report["retry"].is_object() && report["retry"].contains("node") &&
      report["retry"]["node"].is_string()) {
    const std::string id = report["retry"]["node"];
    if (report["nodes"].contains(id) && is_quality(id)) return id;
  }
  for (auto it = report["nodes"].begin(); it != report["nodes"].end(); ++it)
    if (is_quality(it.key())) return it.key();
  throw InvalidInput("report.json: no quality node with metrics (the page shows the quality node's figures)");
}

struct FigureSpec {
  const char* key;
  const char* label;
};
// In page order; keys of the quality node's metrics not listed here follow in their own order.
constexpr FigureSpec kFigures[] = {{"hexes", "hexes"},
                                   {"vertices", "vertices"},
                                   {"inverted", "inverted hexes"},
                                   {"sj_min", "minimum SJ"},
                                   {"sj_avg", "average SJ"},
                                   {"sj_below_0_2", "hexes with SJ < 0.2"},
                                   {"sj_corner_min", "minimum corner SJ"},
                                   {"sj_corner_avg", "average corner SJ"},
                                   {"irregular_pct", "irregular vertices (%)"},
                                   {"irregular_interior_pct", "irregular interior (%)"},
                                   {"irregular_boundary_pct", "irregular boundary (%)"},
                                   {"hausdorff_mean", "mean distance to surface / diag."},
                                   {"hausdorff_max", "Hausdorff distance / diag."},
                                   {"volume_ratio", "volume / surface's volume"},
                                   {"volume", "volume"},
                                   {"bbox_diag", "surface bbox diagonal"},
                                   {"boundary_quads", "boundary quads"},
                                   {"unused_vertices", "unused vertices"},
                                   {"faces_shared_by_more_than_two", "faces in > 2 hexes"},
                                   {"nonmanifold_boundary_edges", "non-manifold boundary edges"}};

json figures(const json& metrics, double min_sj, const std::string& min_sj_from) {
  json out = json::array();
  auto add = [&](const std::string& key, const std::string& label) {
    json f{{"key", key}, {"label", label}, {"value", metrics[key]}};
    auto threshold = [&](const char* op, double limit, const std::string& from) {
      f["threshold"] = {{"op", op}, {"value", limit}, {"from", from}};
      if (metrics[key].is_number()) {
        const double v = metrics[key].get<double>();
        f["pass"] = std::string(op) == ">=" ? v >= limit : v == limit;
      }
    };
    if (key == "inverted" || key == "sj_below_0_2" || key == "unused_vertices" ||
        key == "faces_shared_by_more_than_two" || key == "nonmanifold_boundary_edges")
      threshold("==", 0, "a valid mesh");
    if (key == "sj_min") threshold(">=", min_sj, min_sj_from);
    out.push_back(f);
  };
  for (const FigureSpec& s : kFigures)
    if (metrics.contains(s.key)) add(s.key, s.label);
  for (auto it = metrics.begin(); it != metrics.end(); ++it) {
    bool listed = false;
    for (const FigureSpec& s : kFigures) listed = listed || it.key() == s.key;
    if (!listed) add(it.key(), it.key());
  }
  return out;
}

/// `n` of the indices 0..size-1 when size > n: the `worst` ones by `score` (lowest first) and an even sample
/// of the rest, in increasing order. All of them when size <= n.
std::vector<int> capped_selection(const std::vector<double>& score, size_t n, size_t worst) {
  std::vector<int> all(score.size());
  std::iota(all.begin(), all.end(), 0);
  if (score.size() <= n) return all;
  worst = std::min(worst, n);
  std::vector<int> by_score = all;
  std::stable_sort(by_score.begin(), by_score.end(), [&](int a, int b) { return score[size_t(a)] < score[size_t(b)]; });
  std::vector<char> taken(score.size(), 0);
  for (size_t i = 0; i < worst; ++i) taken[size_t(by_score[i])] = 1;
  const size_t rest = score.size() - worst, want = n - worst;
  for (size_t k = 0; k < want; ++k) taken[size_t(by_score[worst + k * rest / want])] = 1;
  std::vector<int> out;
  for (size_t i = 0; i < score.size(); ++i)
    if (taken[i]) out.push_back(int(i));
  return out;
}

/// {positions, quads, sj} of quads given as 4 vertex ids of the mesh each, vertices compacted.
json quad_set(const HexMesh& mesh, const std::vector<std::array<int, 4>>& quads, const std::vector<float>& sj) {
  std::vector<int> index(size_t(mesh.V.rows()), -1);
  std::vector<float> positions;
  std::vector<std::uint32_t> q;
  q.reserve(quads.size() * 4);
  for (const auto& quad : quads)
    for (int v : quad) {
      if (index[size_t(v)] < 0) {
        index[size_t(v)] = int(positions.size() / 3);
        for (int c = 0; c < 3; ++c) positions.push_back(float(mesh.V(v, c)));
      }
      q.push_back(std::uint32_t(index[size_t(v)]));
    }
  return {{"count", quads.size()}, {"positions", base64(positions)}, {"quads", base64(q)}, {"sj", base64(sj)}};
}

std::string read_file(const fs::path& p, const std::string& what) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw IOError(p.string() + ": cannot read " + what);
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (s.empty()) throw IOError(p.string() + ": " + what + " is empty");
  return s;
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
}

}  // namespace

json report_page_data(const json& report, const HexMesh& mesh, const ReportHtmlParams& p) {
  if (!report.is_object() || !report.contains("nodes") || !report["nodes"].is_object())
    throw InvalidInput("report.json: no `nodes` object");
  check_hex_mesh(mesh);
  json d;
  d["polyhex_version"] = report.value("polyhex_version", "");
  d["status"] = report.value("status", "");
  d["seconds"] = report.value("seconds", 0.0);
  d["mesh"] = {{"source", mesh.source}, {"hexes", mesh.H.rows()}, {"vertices", mesh.V.rows()}};
  json warnings = json::array();

  const std::string qid = quality_node(report);
  const json& metrics = report["nodes"][qid]["metrics"];
  const json& retry = report.contains("retry") ? report["retry"] : json();
  const bool retry_sj = retry.is_object() && retry.contains("min_sj") && retry["min_sj"].is_number();
  const double min_sj = retry_sj ? retry["min_sj"].get<double>() : p.default_min_sj;
  d["quality_node"] = qid;
  d["figures"] =
      figures(metrics, min_sj, retry_sj ? "the config's retry.min_sj" : "polyhex's default (no retry block)");
  if (metrics.contains("hexes") && metrics["hexes"].is_number() && metrics["hexes"].get<long>() != long(mesh.H.rows()))
    warnings.push_back("the mesh file has " + std::to_string(mesh.H.rows()) + " hexes, node `" + qid + "` measured " +
                       metrics["hexes"].dump() + ": the histograms and the view are of the file");

  // Per hex: the quality code's scaled Jacobian and edge ratio.
  Eigen::VectorXd sj, corner_min;
  hex_scaled_jacobians(mesh, sj, corner_min);
  const Eigen::VectorXd ratio = hex_edge_ratios(mesh);
  const double sj_lo = std::min(0.0, std::floor(sj.minCoeff() * 10) / 10);
  d["sj_histogram"] = histogram(sj, sj_lo, 1.0, p.histogram_bins);
  double ratio_max = 1;
  for (Eigen::Index h = 0; h < ratio.size(); ++h)
    if (std::isfinite(ratio[h])) ratio_max = std::max(ratio_max, ratio[h]);
  const double ratio_hi = std::min(p.edge_ratio_cap, std::max(1.5, std::ceil(ratio_max * 2) / 2));
  d["edge_ratio_histogram"] = histogram(ratio, 1.0, ratio_hi, p.histogram_bins);

  // Irregular vertices: the quality code's flags, an even sample of them drawn.
  const std::vector<char> irregular = irregular_vertices(mesh);
  std::vector<char> used(size_t(mesh.V.rows()), 0);
  for (Eigen::Index i = 0; i < mesh.H.size(); ++i) used[size_t(mesh.H.data()[i])] = 1;
  std::vector<int> irregular_ids;
  for (size_t v = 0; v < irregular.size(); ++v)
    if (irregular[v]) irregular_ids.push_back(int(v));
  const long n_used = long(std::count(used.begin(), used.end(), 1));
  const std::vector<int> drawn_irregular =
      capped_selection(std::vector<double>(irregular_ids.size(), 0.0), size_t(p.max_irregular_points), 0);
  std::vector<float> irregular_xyz;
  for (int k : drawn_irregular)
    for (int c = 0; c < 3; ++c) irregular_xyz.push_back(float(mesh.V(irregular_ids[size_t(k)], c)));
  d["irregular"] = {{"count", irregular_ids.size()},
                    {"used_vertices", n_used},
                    {"pct", 100.0 * double(irregular_ids.size()) / double(std::max(n_used, 1L))},
                    {"drawn", drawn_irregular.size()},
                    {"positions", base64(irregular_xyz)}};

  // Boundary quads coloured by their hex's scaled Jacobian, capped.
  std::vector<int> hex_of_quad;
  const auto Q = hex_boundary_quads(mesh, &hex_of_quad);
  std::vector<double> quad_sj(hex_of_quad.size());
  for (size_t i = 0; i < hex_of_quad.size(); ++i) quad_sj[i] = sj[hex_of_quad[i]];
  const size_t cap = size_t(std::max(1L, p.max_boundary_quads));
  const std::vector<int> drawn = capped_selection(quad_sj, cap, cap / 4);
  std::vector<std::array<int, 4>> quads;
  std::vector<float> drawn_sj;
  for (int i : drawn) {
    quads.push_back({Q(i, 0), Q(i, 1), Q(i, 2), Q(i, 3)});
    drawn_sj.push_back(float(quad_sj[size_t(i)]));
  }
  d["boundary"] = quad_set(mesh, quads, drawn_sj);
  d["boundary"]["total"] = Q.rows();
  if (drawn.size() < size_t(Q.rows()))
    warnings.push_back("the view shows " + std::to_string(drawn.size()) + " of the " + std::to_string(Q.rows()) +
                       " boundary quads (the worst quarter and an even sample of the rest), to keep the page small");

  // The worst hexes whole: 6 outward quads each (hex_topology's faces).
  std::vector<int> order(size_t(sj.size()));
  std::iota(order.begin(), order.end(), 0);
  const size_t worst = std::min(order.size(), size_t(std::max(0, p.worst_hexes)));
  std::partial_sort(order.begin(), order.begin() + std::ptrdiff_t(worst), order.end(),
                    [&](int a, int b) { return sj[a] < sj[b] || (sj[a] == sj[b] && a < b); });
  std::vector<std::array<int, 4>> worst_quads;
  std::vector<float> worst_sj;
  for (size_t k = 0; k < worst; ++k)
    for (const auto& f : hex_topology::kFaces) {
      const int h = order[k];
      worst_quads.push_back({mesh.H(h, f[0]), mesh.H(h, f[1]), mesh.H(h, f[2]), mesh.H(h, f[3])});
      worst_sj.push_back(float(sj[h]));
    }
  d["worst_hexes"] = quad_set(mesh, worst_quads, worst_sj);
  d["worst_hexes"]["hexes"] = worst;
  d["worst_hexes"]["sj_max"] = worst > 0 ? sj[order[worst - 1]] : 0.0;

  // Stages, slowest first, and the retry attempts.
  json stages = json::array();
  for (auto it = report["nodes"].begin(); it != report["nodes"].end(); ++it) {
    const json& n = it.value();
    if (!n.is_object()) continue;
    stages.push_back({{"id", it.key()},
                      {"type", n.value("type", "")},
                      {"seconds", n.contains("seconds") && n["seconds"].is_number() ? n["seconds"].get<double>() : 0.0},
                      {"cache_hit", n.value("cache_hit", false)},
                      {"warnings", n.contains("warnings") ? n["warnings"] : json::array()}});
  }
  std::stable_sort(stages.begin(), stages.end(), [](const json& a, const json& b) {
    return a["seconds"].get<double>() > b["seconds"].get<double>();
  });
  d["stages"] = stages;
  d["retry"] = retry.is_object() ? retry : json();
  d["warnings"] = warnings;
  return d;
}

std::string report_page_html(const json& data, const std::string& three_js) {
  std::string page = report_page_template();
  std::string js = three_js;
  replace_all(js, "</script", "<\\/script");
  replace_all(js, "<!--", "<\\!--");
  std::string d = data.dump();
  replace_all(d, "<", "\\u003c");  // '<' only occurs inside JSON strings
  const std::string js_mark = "/*@THREE_JS@*/", data_mark = "@REPORT_DATA@";
  const size_t at_js = page.find(js_mark);
  if (at_js == std::string::npos) throw Error("report page template: no " + js_mark);
  page.replace(at_js, js_mark.size(), js);
  const size_t at_data = page.find(data_mark, at_js + js.size());
  if (at_data == std::string::npos) throw Error("report page template: no " + data_mark);
  page.replace(at_data, data_mark.size(), d);
  return page;
}

std::string read_three_js(const fs::path& dir) {
  std::string js;
  for (const char* f : {"three.min.js", "examples/js/controls/OrbitControls.js"}) {
    const fs::path p = dir / f;
    if (!fs::is_regular_file(p))
      throw IOError(p.string() +
                    ": missing; the HTML report inlines three.js from Debian's libjs-three "
                    "(apt-get install libjs-three, or tools/setup.sh)");
    js += read_file(p, "three.js") + "\n;\n";
  }
  return js;
}

fs::path report_mesh_path(const json& report, const fs::path& run_dir) {
  const fs::path where = run_dir / "report.json";
  if (report.is_object() && report.contains("nodes") && report["nodes"].is_object())
    for (auto it = report["nodes"].begin(); it != report["nodes"].end(); ++it) {
      const json& n = it.value();
      const std::string type = n.is_object() ? n.value("type", "") : "";
      if (type.substr(0, type.find('/')) != "write_hex" || !n.contains("metrics") || !n["metrics"].is_object() ||
          !n["metrics"].contains("path") || !n["metrics"]["path"].is_string())
        continue;
      const fs::path written = n["metrics"]["path"].get<std::string>();
      const fs::path here = run_dir / written.filename();
      if (fs::is_regular_file(here)) return here;
      const fs::path as_written = written.is_absolute() ? written : run_dir / written;
      if (fs::is_regular_file(as_written)) return as_written;
      throw IOError(here.string() + ": missing: the hex mesh that node `" + it.key() + "` wrote (" + written.string() +
                    ", as " + where.string() + " says)");
    }
  throw IOError(where.string() + ": no write_hex node with a `path` metric: the run wrote no hex mesh to show");
}

fs::path write_report_html(const fs::path& run_dir, const ReportHtmlParams& p, const fs::path& three_dir) {
  const fs::path report_path = run_dir / "report.json";
  if (!fs::is_regular_file(report_path))
    throw IOError(report_path.string() + ": missing (run `polyhex run CONFIG --out " + run_dir.string() + "` first)");
  json report;
  try {
    report = json::parse(read_file(report_path, "report.json"));
  } catch (const json::exception& e) {
    throw IOError(report_path.string() + ": not valid JSON: " + e.what());
  }
  const fs::path mesh_path = report_mesh_path(report, run_dir);
  const std::string three = read_three_js(three_dir);  // before reading the mesh: a missing package fails fast
  const HexMesh mesh = read_hexmesh(mesh_path);
  json data;
  try {
    data = report_page_data(report, mesh, p);
  } catch (const InvalidInput& e) {
    throw InvalidInput(report_path.string() + " and " + mesh.source + ": " + e.what());
  } catch (const json::exception& e) {  // a value of another type than polyhex writes
    throw IOError(report_path.string() + ": not a report.json of polyhex run: " + e.what());
  }
  data["run_dir"] = fs::absolute(run_dir).lexically_normal().string();
  const fs::path out = run_dir / "report.html";
  write_file_atomic(out, [&](std::ostream& os) { os << report_page_html(data, three); });
  return out;
}

}  // namespace polyhex
