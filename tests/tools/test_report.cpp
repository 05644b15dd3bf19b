// `polyhex run --html` and `polyhex report` end to end: the page in headless Chromium (tools/headless_page.sh,
// the command that made docs/report.png) loads offline without an error, its screenshot shows the mesh, and
// its numbers are report.json's. Without Chromium the test fails under CI=true and is skipped elsewhere.
#include "tests/helpers/cli.h"
#include "tests/helpers/png.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using json = nlohmann::json;
using polyhex::test::CliRun;
using polyhex::test::run_polyhex;

namespace {

std::string source(const std::string& rel) { return std::string(POLYHEX_SOURCE_DIR) + "/" + rel; }

/// tools/headless_page.sh MODE PAGE [OUT]: stdout in `out`, Chromium's log in `err`.
CliRun headless(const std::string& mode, const fs::path& page, const fs::path& dir, const std::string& extra = "") {
  return polyhex::test::run_command_to_files(
      source("tools/headless_page.sh") + " " + mode + " '" + page.string() + "' " + extra, dir / (mode + ".out"),
      dir / (mode + ".err"));
}

/// Whether Chromium can run here; false (with a warning) outside CI when it is missing, a failure in CI.
bool have_chromium() {
  if (std::system("command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1") == 0)
    return true;
  const char* ci = std::getenv("CI");
  if (ci && std::string(ci) == "true") FAIL("chromium is missing (tools/setup.sh installs it; CI=true)");
  WARN("chromium is missing: the report's browser test is skipped (install chromium, or tools/setup.sh)");
  return false;
}

/// The attribute values of every `<tag ... data-A="..." ... data-B="...">` match of `re` in the DOM.
std::map<std::string, std::string> pairs(const std::string& dom, const std::regex& re) {
  std::map<std::string, std::string> out;
  for (auto it = std::sregex_iterator(dom.begin(), dom.end(), re); it != std::sregex_iterator(); ++it)
    out[(*it)[1].str()] = (*it)[2].str();
  return out;
}

long sum_counts(const std::string& svg) {
  static const std::regex count(R"re(data-count="(\d+)")re");
  long s = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), count); it != std::sregex_iterator(); ++it)
    s += std::stol((*it)[1].str());
  return s;
}

}  // namespace

TEST_CASE("report: the page in headless Chromium shows the mesh and report.json's numbers, offline",
          "[report][chromium]") {
  fs::path out = polyhex::test::fresh_dir("report_page");
  // The default (PolyCube) config at small sizes, so that report.json has a retry block and the view a real mesh.
  CliRun r = run_polyhex("run " + source("configs/default.json") + " --out " + out.string() +
                         " --set vars.tet_edge=0.05 --set vars.hex_edge=0.04"
                         " --threads 2 --html");
  INFO(r.out);
  REQUIRE(r.code == 0);
  CHECK_THAT(r.out, Contains("wrote " + (out / "report.html").string()));
  const fs::path page = out / "report.html";
  REQUIRE(fs::exists(page));
  std::ifstream in(out / "report.json");
  const json rep = json::parse(in);
  const json& q = rep["nodes"]["quality"]["metrics"];

  // Self-contained: nothing to fetch, three.js inlined.
  const std::string html = polyhex::test::read_text(page);
  CHECK_FALSE(std::regex_search(html, std::regex(R"(<(script|img|link|iframe)[^>]*\s(src|href)=)", std::regex::icase)));
  CHECK_THAT(html, Contains("REVISION=") && Contains("OrbitControls"));
  CHECK(fs::file_size(page) < 4'000'000);

  if (!have_chromium()) return;

  // The DOM after the page's scripts ran: ready, no error of any kind.
  CliRun dom = headless("dom", page, out);
  INFO(dom.err.substr(0, 3000));
  REQUIRE(dom.code == 0);
  CHECK_THAT(dom.out, Contains("<pre id=\"status\" data-state=\"ready\">ready:"));
  CHECK_THAT(dom.out, Contains("<ul id=\"errors\"></ul>"));
  CHECK_THAT(dom.err, !Contains("Uncaught"));

  // Every figure of the quality node, with its value exactly and its text to the 4 digits shown.
  const std::regex figure_re(
      R"re(<tr data-key="([^"]+)"><td>[^<]*</td><td class="value" data-value="([^"]*)">([^<]*)</td>)re");
  int figures = 0;
  for (auto it = std::sregex_iterator(dom.out.begin(), dom.out.end(), figure_re); it != std::sregex_iterator(); ++it) {
    const std::string key = (*it)[1].str();
    INFO(key);
    REQUIRE(q.contains(key));
    ++figures;
    // the value as JSON, HTML-escaped in the attribute (a string figure, hausdorff_sides, has quotes)
    const std::string value = std::regex_replace((*it)[2].str(), std::regex("&quot;"), "\"");
    CHECK(json::parse(value) == q[key]);
    if (q[key].is_number()) {
      const double shown = std::stod((*it)[3].str()), v = q[key].get<double>();
      CHECK(std::abs(shown - v) <= 5e-4 * std::abs(v) + 1e-300);
    }
  }
  CHECK(figures == int(q.size()));
  CHECK_THAT(dom.out, Contains("<tr data-key=\"inverted\">") && Contains("<td class=\"pass\">pass</td>"));

  // Per-node times: every node, exactly report.json's seconds.
  const auto seconds = pairs(dom.out, std::regex(R"re(data-id="([^"]+)" data-seconds="([^"]+)")re"));
  CHECK(seconds.size() == rep["nodes"].size());
  for (const auto& [id, s] : seconds) CHECK(json::parse(s) == rep["nodes"][id]["seconds"]);

  // Histograms: each counts every hex once; the irregular vertices' share is the quality node's.
  const size_t sj_at = dom.out.find("id=\"sj-histogram\""), er_at = dom.out.find("id=\"edge-ratio-histogram\"");
  REQUIRE(sj_at != std::string::npos);
  REQUIRE(er_at != std::string::npos);
  CHECK(sum_counts(dom.out.substr(sj_at, er_at - sj_at)) == q["hexes"].get<long>());
  CHECK(sum_counts(dom.out.substr(er_at, dom.out.find("</svg>", er_at) - er_at)) == q["hexes"].get<long>());
  std::smatch irr;
  REQUIRE(std::regex_search(dom.out, irr,
                            std::regex(R"re(id="irregular" data-count="(\d+)" data-used-vertices="(\d+)")re")));
  CHECK(100.0 * std::stod(irr[1].str()) / std::stod(irr[2].str()) ==
        Approx(q["irregular_pct"].get<double>()).epsilon(1e-12));

  // Retry attempts: one row each, with the attempt's figures; the rule's thresholds.
  REQUIRE(rep.contains("retry"));
  const json& attempts = rep["retry"]["attempts"];
  const std::regex attempt_re(
      R"re(<tr data-attempt="(\d+)" class="[^"]*" data-inverted="([^"]*)" data-sj-min="([^"]*)")re");
  size_t rows = 0;
  for (auto it = std::sregex_iterator(dom.out.begin(), dom.out.end(), attempt_re); it != std::sregex_iterator();
       ++it, ++rows) {
    const json& a = attempts.at(std::stoul((*it)[1].str()));
    CHECK(json::parse((*it)[2].str()) == a["inverted"]);
    CHECK(json::parse((*it)[3].str()) == a["sj_min"]);
  }
  CHECK(rows == attempts.size());
  CHECK_THAT(dom.out, Contains("minimum scaled Jacobian ≥ " + rep["retry"]["min_sj"].dump()));

  // The screenshot: the view's rectangle (as the page reports it) is mostly mesh, coloured by SJ (green is
  // near 1), not a blank canvas.
  std::smatch rect;
  REQUIRE(std::regex_search(dom.out, rect, std::regex(R"re(id="view" data-rect="(\d+) (\d+) (\d+) (\d+)")re")));
  const int x0 = std::stoi(rect[1].str()), y0 = std::stoi(rect[2].str()), w = std::stoi(rect[3].str()),
            h = std::stoi(rect[4].str());
  CliRun shot = headless("screenshot", page, out, "'" + (out / "report.png").string() + "'");
  INFO(shot.err.substr(0, 3000));
  REQUIRE(shot.code == 0);
  const polyhex::test::Image img = polyhex::test::decode_png(polyhex::test::read_text(out / "report.png"));
  REQUIRE(img.width >= x0 + w);
  REQUIRE(img.height >= y0 + h);
  const std::uint8_t background[3] = {0xee, 0xf1, 0xf4};
  long drawn = 0, green = 0;
  for (int y = y0; y < y0 + h; ++y)
    for (int x = x0; x < x0 + w; ++x) {
      const std::uint8_t* p = img.at(x, y);
      int diff = 0;
      for (int k = 0; k < 3; ++k) diff = std::max(diff, std::abs(int(p[k]) - int(background[k])));
      drawn += diff > 24;
      green += int(p[1]) > int(p[0]) + 30 && int(p[1]) > int(p[2]) + 30;
    }
  const double area = double(w) * double(h);
  INFO("drawn " << drawn / area << ", green " << green / area);
  CHECK(drawn > 0.15 * area);
  CHECK(green > 0.10 * area);

  // The clipping plane: opened at #clip=z,0.5 the view keeps the lower half, so the upper part of the mesh is
  // gone (background where the top was) and the picture changes.
  CliRun clipped_dom = headless("dom", page.string() + "#clip=z,0.5", out);
  CHECK_THAT(clipped_dom.out, Contains("data-clip=\"z 0.5\"") && Contains("data-state=\"ready\""));
  CliRun clipped =
      headless("screenshot", page.string() + "#clip=z,0.5", out, "'" + (out / "clipped.png").string() + "'");
  REQUIRE(clipped.code == 0);
  const polyhex::test::Image cut = polyhex::test::decode_png(polyhex::test::read_text(out / "clipped.png"));
  REQUIRE(cut.width == img.width);
  long changed = 0, drawn_cut = 0;
  for (int y = y0; y < y0 + h; ++y)
    for (int x = x0; x < x0 + w; ++x) {
      const std::uint8_t *a = img.at(x, y), *b = cut.at(x, y);
      int diff = 0, bg = 0;
      for (int k = 0; k < 3; ++k) {
        diff = std::max(diff, std::abs(int(a[k]) - int(b[k])));
        bg = std::max(bg, std::abs(int(b[k]) - int(background[k])));
      }
      changed += diff > 24;
      drawn_cut += bg > 24;
    }
  INFO("changed " << changed / area << ", drawn when clipped " << drawn_cut / area);
  CHECK(changed > 0.05 * area);
  CHECK(drawn_cut < drawn);
  CHECK(drawn_cut > 0.05 * area);  // the lower half is still there
}

TEST_CASE("report: a folder without report.json or without the mesh is refused, naming the file", "[report]") {
  fs::path out = polyhex::test::fresh_dir("report_bad");
  CliRun none = run_polyhex("report " + out.string());
  INFO(none.out);
  CHECK(none.code == 1);
  CHECK_THAT(none.out, Contains((out / "report.json").string()) && Contains("missing"));
  CHECK_FALSE(fs::exists(out / "report.html"));

  CliRun r = run_polyhex("run " + source("configs/baseline.json") + " --out " + out.string() +
                         " --set tets.edge_length=0.12 --threads 2");
  REQUIRE(r.code == 0);
  fs::rename(out / "hex.vtk", out / "moved.vtk");
  CliRun nomesh = run_polyhex("report " + out.string());
  INFO(nomesh.out);
  CHECK(nomesh.code == 1);
  CHECK_THAT(nomesh.out, Contains((out / "hex.vtk").string()) && Contains("missing"));
  CHECK_FALSE(fs::exists(out / "report.html"));
  for (auto& e : fs::directory_iterator(out)) CHECK(e.path().string().find(".tmp.") == std::string::npos);

  fs::rename(out / "moved.vtk", out / "hex.vtk");
  // A failed run with --html: no page, and the message says why.
  CliRun failed = run_polyhex("run " + source("configs/baseline.json") + " --input " + (out / "missing.stl").string() +
                              " --out " + (out / "failed").string() + " --html");
  INFO(failed.out);
  CHECK(failed.code == 1);
  CHECK_THAT(failed.out, Contains("no report.html"));
  CHECK_FALSE(fs::exists(out / "failed" / "report.html"));

  CliRun ok = run_polyhex("report " + out.string());
  INFO(ok.out);
  CHECK(ok.code == 0);
  CHECK(fs::file_size(out / "report.html") > 100000);  // three.js is in it
}
