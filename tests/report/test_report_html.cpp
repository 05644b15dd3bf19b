// The HTML report's data and page (report/report_html.h), on generated meshes and reports; the end-to-end
// run in headless Chromium is tests/tools/test_report.cpp.
#include "nodes/algorithms/hex_quality.h"
#include "nodes/formats/hexmesh_io.h"
#include "nodes/quality/quality_json.h"
#include "report/report_html.h"
#include "runtime/errors.h"
#include "tests/helpers/cli.h"
#include "tests/helpers/hex_fixtures.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cstring>
#include <fstream>
#include <numeric>
#include <set>

using namespace polyhex;
using json = nlohmann::json;
using Catch::Matchers::Contains;

namespace {

/// The bytes of a base64 text, as an array of T.
template <class T>
std::vector<T> unbase64(const std::string& s) {
  std::string bytes;
  int bits = 0, acc = 0;
  for (char ch : s) {
    if (ch == '=') break;
    acc = acc << 6 | int(std::strchr("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/", ch) -
                         "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/");
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      bytes += char((acc >> bits) & 0xff);
    }
  }
  REQUIRE(bytes.size() % sizeof(T) == 0);
  std::vector<T> out(bytes.size() / sizeof(T));
  std::memcpy(out.data(), bytes.data(), bytes.size());
  return out;
}

/// A report.json as `polyhex run` writes it for `mesh`: a quality node measuring it, a writer, two others.
json report_of(const HexMesh& mesh) {
  json q = to_json(hex_quality(mesh, nullptr));
  return {
      {"polyhex_version", "0.1.0"},
      {"status", "ok"},
      {"seconds", 3.5},
      {"nodes",
       {{"hex", {{"type", "hex_extract/lattice"}, {"seconds", 2.0}, {"cache_hit", false}, {"metrics", json::object()}}},
        {"quality", {{"type", "quality/default"}, {"seconds", 0.25}, {"cache_hit", false}, {"metrics", q}}},
        {"tets",
         {{"type", "tetrahedralize/tetgen"}, {"seconds", 1.0}, {"cache_hit", true}, {"metrics", json::object()}}},
        {"write", {{"type", "write_hex/default"}, {"seconds", 0.1}, {"metrics", {{"path", "hex.vtk"}}}}}}}};
}

const json& figure(const json& data, const std::string& key) {
  for (const json& f : data["figures"])
    if (f["key"] == key) return f;
  FAIL("no figure " << key);
  static json none;
  return none;
}

long sum(const json& counts) {
  long s = 0;
  for (const json& c : counts) s += c.get<long>();
  return s;
}

}  // namespace

TEST_CASE("report html: figures verbatim, thresholds, histograms and irregular vertices of a grid", "[report]") {
  HexMesh m = test::grid_hex_mesh(3, 3, 3);
  m.V.row(21) += Eigen::RowVector3d(0.3, 0.2, 0.1);  // an interior vertex moved: 8 hexes below 1
  const json rep = report_of(m);
  const json d = report_page_data(rep, m);
  const json& metrics = rep["nodes"]["quality"]["metrics"];
  CHECK(d["quality_node"] == "quality");
  REQUIRE(d["figures"].size() == metrics.size());
  for (const json& f : d["figures"]) CHECK(f["value"] == metrics[f["key"].get<std::string>()]);
  CHECK(figure(d, "inverted")["threshold"]["op"] == "==");
  CHECK(figure(d, "inverted")["pass"] == true);
  CHECK(figure(d, "sj_min")["threshold"]["value"] == 0.3);  // no retry block: the documented default
  CHECK(figure(d, "sj_min")["pass"] == (metrics["sj_min"].get<double>() >= 0.3));
  CHECK_FALSE(figure(d, "sj_avg").contains("threshold"));

  // Every hex in one bin of each histogram; the moved vertex's 8 hexes are not in the last SJ bin.
  CHECK(sum(d["sj_histogram"]["counts"]) == 27);
  CHECK(sum(d["edge_ratio_histogram"]["counts"]) == 27);
  CHECK(d["sj_histogram"]["hi"] == 1.0);
  CHECK(d["sj_histogram"]["counts"].back() == 19);
  CHECK(d["edge_ratio_histogram"]["lo"] == 1.0);

  CHECK(d["irregular"]["count"] == 8);
  CHECK(d["irregular"]["used_vertices"] == 64);
  CHECK(d["irregular"]["pct"].get<double>() == Approx(metrics["irregular_pct"].get<double>()));
  CHECK(unbase64<float>(d["irregular"]["positions"]).size() == 8 * 3);

  // Stages slowest first, with every node.
  REQUIRE(d["stages"].size() == 4);
  CHECK(d["stages"][0]["id"] == "hex");
  CHECK(d["stages"][1]["id"] == "tets");
  CHECK(d["stages"][1]["cache_hit"] == true);
  CHECK(d["warnings"].empty());
}

TEST_CASE("report html: the retry block's min_sj is the threshold, and a figure below it fails", "[report]") {
  const HexMesh m = test::grid_hex_mesh(2, 2, 2);
  json rep = report_of(m);
  rep["retry"] = {
      {"node", "quality"}, {"max_inverted", 0}, {"min_sj", 0.5}, {"chosen", 0}, {"attempts", json::array()}};
  CHECK(figure(report_page_data(rep, m), "sj_min")["threshold"]["value"] == 0.5);
  CHECK(figure(report_page_data(rep, m), "sj_min")["pass"] == true);
  rep["nodes"]["quality"]["metrics"]["sj_min"] = 0.4;
  rep["nodes"]["quality"]["metrics"]["inverted"] = 2;
  const json d = report_page_data(rep, m);
  CHECK(figure(d, "sj_min")["pass"] == false);
  CHECK(figure(d, "inverted")["pass"] == false);
  CHECK(d["retry"]["min_sj"] == 0.5);
  // The quality node measured another mesh than the file: said, not hidden.
  rep["nodes"]["quality"]["metrics"]["hexes"] = 9;
  CHECK_THAT(report_page_data(rep, m)["warnings"][0].get<std::string>(), Contains("8 hexes") && Contains("measured 9"));
}

TEST_CASE("report html: the boundary geometry decodes to the mesh's boundary quads and their hexes' SJ", "[report]") {
  HexMesh m = test::grid_hex_mesh(3, 3, 3);
  m.V.row(0) += Eigen::RowVector3d(0.4, 0.4, 0.4);  // the corner hex 0 becomes the worst
  Eigen::VectorXd sj, corner;
  hex_scaled_jacobians(m, sj, corner);
  SECTION("uncapped: every quad, vertices compacted, float32 positions equal to the mesh's") {
    const json d = report_page_data(report_of(m), m);
    CHECK(d["boundary"]["count"] == 54);
    CHECK(d["boundary"]["total"] == 54);
    const auto P = unbase64<float>(d["boundary"]["positions"]);
    const auto Q = unbase64<std::uint32_t>(d["boundary"]["quads"]);
    const auto S = unbase64<float>(d["boundary"]["sj"]);
    REQUIRE(Q.size() == 54 * 4);
    REQUIRE(S.size() == 54);
    CHECK(P.size() == 56 * 3);  // the 56 boundary vertices of the 64
    std::vector<int> hex_of_quad;
    const auto B = hex_boundary_quads(m, &hex_of_quad);
    for (int q = 0; q < 54; ++q) {
      CHECK(S[size_t(q)] == float(sj[hex_of_quad[size_t(q)]]));
      for (int k = 0; k < 4; ++k)
        for (int c = 0; c < 3; ++c) CHECK(P[3 * Q[size_t(4 * q + k)] + size_t(c)] == float(m.V(B(q, k), c)));
    }
  }
  SECTION("capped: the page says so, and the worst hex's quads are among those drawn") {
    ReportHtmlParams p;
    p.max_boundary_quads = 12;
    p.worst_hexes = 1;
    const json d = report_page_data(report_of(m), m, p);
    CHECK(d["boundary"]["count"] == 12);
    CHECK(d["boundary"]["total"] == 54);
    CHECK_THAT(d["warnings"][0].get<std::string>(), Contains("12 of the 54 boundary quads"));
    const auto S = unbase64<float>(d["boundary"]["sj"]);
    REQUIRE(S.size() == 12);
    CHECK(*std::min_element(S.begin(), S.end()) == float(sj.minCoeff()));
    CHECK(d["worst_hexes"]["hexes"] == 1);
    CHECK(d["worst_hexes"]["sj_max"] == sj.minCoeff());
    CHECK(unbase64<float>(d["worst_hexes"]["sj"]).size() == 6);
    CHECK(unbase64<float>(d["worst_hexes"]["positions"]).size() == 8 * 3);
  }
}

TEST_CASE("report html: bad reports are refused with the reason", "[report]") {
  const HexMesh m = test::grid_hex_mesh(1, 1, 1);
  CHECK_THROWS_WITH(report_page_data(json::object(), m), Contains("no `nodes` object"));
  json rep = report_of(m);
  rep["nodes"].erase("quality");
  CHECK_THROWS_AS(report_page_data(rep, m), InvalidInput);
  CHECK_THROWS_WITH(report_page_data(rep, m), Contains("no quality node"));
  CHECK_THROWS_AS(report_page_data(report_of(m), HexMesh{}), InvalidInput);
}

TEST_CASE("report html: the page inlines three.js and the data, and neither can end its script", "[report]") {
  json d = {{"note", "</script><script>alert(1)</script>"}};
  const std::string page = report_page_html(d, "var THREE = {}; /* </script> <!-- */");
  CHECK(page.find("@REPORT_DATA@") == std::string::npos);
  CHECK(page.find("/*@THREE_JS@*/") == std::string::npos);
  CHECK(page.find("alert(1)") != std::string::npos);
  CHECK(page.find("<script>alert") == std::string::npos);
  CHECK(page.find("var THREE = {}; /* <\\/script> <\\!-- */") != std::string::npos);
  // The data is still the same JSON once the page's script reads it.
  const size_t at = page.find("id=\"report-data\">") + std::strlen("id=\"report-data\">");
  CHECK(json::parse(page.substr(at, page.find("</script>", at) - at)) == d);
}

TEST_CASE("report html: three.js, report.json and the mesh are found or named", "[report]") {
  test::TempDir dir("report_html");
  CHECK_THROWS_AS(read_three_js(dir.path), IOError);
  CHECK_THROWS_WITH(read_three_js(dir.path), Contains("three.min.js") && Contains("libjs-three"));

  const HexMesh m = test::grid_hex_mesh(1, 1, 1);
  json rep = report_of(m);
  CHECK_THROWS_WITH(report_mesh_path(rep, dir.path), Contains((dir.path / "hex.vtk").string()) && Contains("missing"));
  std::ofstream(dir / "hex.vtk") << "x";
  CHECK(report_mesh_path(rep, dir.path) == dir.path / "hex.vtk");
  // An absolute path of a folder since moved: the file of that name in the run folder.
  rep["nodes"]["write"]["metrics"]["path"] = "/nowhere/else/hex.vtk";
  CHECK(report_mesh_path(rep, dir.path) == dir.path / "hex.vtk");
  rep["nodes"].erase("write");
  CHECK_THROWS_WITH(report_mesh_path(rep, dir.path), Contains("report.json") && Contains("no write_hex node"));

  // write_report_html: no report.json, and a run folder whose mesh is missing; no page either time.
  CHECK_THROWS_WITH(write_report_html(dir / "empty"), Contains("report.json") && Contains("missing"));
  std::ofstream(dir / "report.json") << report_of(m).dump();
  std::filesystem::remove(dir / "hex.vtk");
  CHECK_THROWS_WITH(write_report_html(dir.path), Contains("hex.vtk"));
  CHECK_FALSE(std::filesystem::exists(dir / "report.html"));
  json odd = report_of(m);
  odd["seconds"] = "soon";  // valid JSON, not polyhex's
  std::ofstream(dir / "report.json") << odd.dump();
  write_hexmesh(m, dir / "hex.vtk");
  CHECK_THROWS_AS(write_report_html(dir.path), IOError);
  CHECK_THROWS_WITH(write_report_html(dir.path),
                    Contains("report.json") && Contains("not a report.json of polyhex run"));
  CHECK_FALSE(std::filesystem::exists(dir / "report.html"));
  std::ofstream(dir / "report.json") << "{ not json";
  CHECK_THROWS_WITH(write_report_html(dir.path), Contains("report.json") && Contains("not valid JSON"));
  CHECK_FALSE(std::filesystem::exists(dir / "report.html"));
}
