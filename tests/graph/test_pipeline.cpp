// Graph builder and runtime: config validation errors, variable substitution, overrides, concurrent
// execution, error propagation and report.json.
#include "graph/config.h"
#include "graph/pipeline.h"

#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>
#include <unistd.h>

using namespace polyhex;
using Catch::Matchers::Contains;

namespace {

struct SourceParams {
  double size = 1.0;  ///< edge of the box
  int copies = 1;     ///< unused count, to test integer params
  bool flag = false;
  std::string mode = "a";
};

std::atomic<int> g_running{0};
std::atomic<int> g_max_running{0};

SurfaceMesh box(double s) {
  SurfaceMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, s, 0, 0, 0, s, 0, 0, 0, s;
  m.F.resize(4, 3);
  m.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return m;
}

// Test-only node types (prefixed test_), registered in the test binary only.
const bool registered = [] {
  register_node(make_node<SourceParams>("test_source/box", "a tetrahedron surface",
                                        ParamSet<SourceParams>()
                                            .add("size", &SourceParams::size, "edge", 0.0, 10.0)
                                            .add("copies", &SourceParams::copies, "count", 1, 5)
                                            .add("flag", &SourceParams::flag, "flag")
                                            .add_choice("mode", &SourceParams::mode, {"a", "b"}, "mode"),
                                        {}, artefact_name<SurfaceMesh>(),
                                        [](const SourceParams& p, const Inputs&, NodeContext& ctx) {
                                          ctx.metrics["size"] = p.size;
                                          return make_artefact(box(p.size));
                                        }));
  struct Empty {};
  register_node(make_node<Empty>("test_scale/default", "doubles coordinates, waits for a concurrent sibling",
                                 ParamSet<Empty>(), {{"surface", artefact_name<SurfaceMesh>()}},
                                 artefact_name<SurfaceMesh>(), [](const Empty&, const Inputs& in, NodeContext& ctx) {
                                   int now = ++g_running;
                                   int prev = g_max_running.load();
                                   while (now > prev && !g_max_running.compare_exchange_weak(prev, now)) {
                                   }
                                   // give a sibling up to 3 s to start, so concurrency is observable
                                   for (int k = 0; k < 300 && g_max_running.load() < 2; ++k)
                                     std::this_thread::sleep_for(std::chrono::milliseconds(10));
                                   SurfaceMesh m = *in.get<SurfaceMesh>(0);
                                   m.V *= 2.0;
                                   --g_running;
                                   return make_artefact(std::move(m));
                                 }));
  register_node(make_node<Empty>("test_merge/default", "counts vertices of two surfaces", ParamSet<Empty>(),
                                 {{"a", artefact_name<SurfaceMesh>()}, {"b", artefact_name<SurfaceMesh>(), true}}, "",
                                 [](const Empty&, const Inputs& in, NodeContext& ctx) {
                                   ctx.metrics["vertices"] = in.get<SurfaceMesh>(0)->V.rows() +
                                                             (in.has(1) ? in.get<SurfaceMesh>(1)->V.rows() : 0);
                                   ctx.warn("merged");
                                   return Artefact{};
                                 }));
  struct Keep {
    double below = 1;
  };
  register_node(make_node<Keep>("test_keep/default",
                                "passes a box on when its size is below `below`, else produces nothing",
                                ParamSet<Keep>().add("below", &Keep::below, "size bound", 0.0, 10.0),
                                {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<SurfaceMesh>(),
                                [](const Keep& p, const Inputs& in, NodeContext&) {
                                  return in.get<SurfaceMesh>(0)->V.maxCoeff() < p.below ? in.items[0] : Artefact{};
                                })
                    .with_may_skip());
  register_node(make_node<Empty>("test_fail/default", "always throws", ParamSet<Empty>(),
                                 {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<TetMesh>(),
                                 [](const Empty&, const Inputs&, NodeContext&) -> Artefact {
                                   throw InvalidInput("the surface is not good enough");
                                 }));
  return true;
}();

Pipeline build(const std::string& text) { return Pipeline::build(parse_config(json::parse(text), "test.json")); }

std::filesystem::path temp_dir(const std::string& name) {
  auto d = std::filesystem::temp_directory_path() / ("polyhex_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace

TEST_CASE("config errors name the node and list valid choices", "[graph]") {
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"s","type":"nope/x"}]})"),
                      Contains("node `s` (`nope/x`): unknown node type `nope/x`") && Contains("test_source/box"));
  REQUIRE_THROWS_WITH(
      build(R"({"nodes":[{"id":"s","type":"test_source/box","params":{"sise":2}}]})"),
      Contains("node `s`") && Contains("unknown param `sise`") && Contains("valid params: size, copies, flag, mode"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"s","type":"test_source/box","params":{"size":"big"}}]})"),
                      Contains("param `size` must be a number"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"s","type":"test_source/box","params":{"copies":1.5}}]})"),
                      Contains("param `copies` must be an integer"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"s","type":"test_source/box","params":{"size":11}}]})"),
                      Contains("param `size` = 11 is out of range [0.0, 10.0]"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"s","type":"test_source/box","params":{"flag":1}}]})"),
                      Contains("param `flag` must be true or false"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"s","type":"test_source/box","params":{"mode":"c"}}]})"),
                      Contains("param `mode` = \"c\" is not one of: a, b"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"m","type":"test_merge"}]})"),
                      Contains("node `m`") && Contains("required input `a` (SurfaceMesh) is not connected"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"m","type":"test_merge","inputs":{"a":"ghost"}}]})"),
                      Contains("input `a` names unknown node `ghost`"));
  REQUIRE_THROWS_WITH(
      build(R"({"nodes":[{"id":"s","type":"test_source/box"},{"id":"m","type":"test_merge","inputs":{"c":"s"}}]})"),
      Contains("unknown input port `c`; ports: a (SurfaceMesh), b (SurfaceMesh, optional)"));
  REQUIRE_THROWS_WITH(
      build(R"({"nodes":[{"id":"s","type":"test_source/box"},{"id":"f","type":"test_fail","inputs":["s"]},
                               {"id":"m","type":"test_merge","inputs":{"a":"f"}}]})"),
      Contains("node `m`") && Contains("expects SurfaceMesh but node `f` (`test_fail/default`) produces TetMesh"));
  REQUIRE_THROWS_WITH(
      build(
          R"({"nodes":[{"id":"a","type":"test_scale","inputs":["b"]},{"id":"b","type":"test_scale","inputs":["a"]}]})"),
      Contains("the inputs form a cycle"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"a","type":"test_source/box"},{"id":"a","type":"test_source/box"}]})"),
                      Contains("node `a`: duplicate id"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"a","type":"test_source/box","param":{}}]})"),
                      Contains("unknown key `param`; valid keys: id, type, params, inputs"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[]})"), Contains("`nodes` must be a non-empty array"));
  REQUIRE_THROWS_WITH(build(R"({"node":[]})"), Contains("unknown top-level key `node`"));
  REQUIRE_THROWS_WITH(build(R"({"nodes":[{"id":"a b","type":"test_source/box"}]})"), Contains("an id uses only"));
}

TEST_CASE("malformed config files are rejected with the file name", "[graph]") {
  auto dir = temp_dir("cfg");
  std::ofstream(dir / "bad.json") << "{\"nodes\": [ {\"id\": \"a\", ";
  REQUIRE_THROWS_WITH(load_config_json(dir / "bad.json", {}), Contains("bad.json: not valid JSON"));
  REQUIRE_THROWS_WITH(load_config_json(dir / "missing.json", {}), Contains("missing.json: cannot open config file"));
}

TEST_CASE("variables and --set overrides", "[graph]") {
  json j = json::parse(R"({"nodes":[{"id":"s","type":"test_source/box","params":{"mode":"${m:-b}"}},
                                    {"id":"t","type":"test_source/box","params":{"mode":"${input}"}}]})");
  REQUIRE_THROWS_WITH(substitute_vars(j, {}, "x.json"), Contains("x.json: `${input}` has no value (pass --input)"));
  json k = substitute_vars(j, {{"input", "a"}}, "x.json");
  CHECK(k["nodes"][0]["params"]["mode"] == "b");
  CHECK(k["nodes"][1]["params"]["mode"] == "a");
  apply_override(k, "s.size=2.5");
  apply_override(k, "s.mode=a");
  apply_override(k, "t.flag=true");
  CHECK(k["nodes"][0]["params"]["size"] == 2.5);
  CHECK(k["nodes"][0]["params"]["mode"] == "a");
  CHECK(k["nodes"][1]["params"]["flag"] == true);
  REQUIRE_THROWS_WITH(apply_override(k, "zz.size=1"), Contains("no node with id `zz`; ids: s, t"));
  REQUIRE_THROWS_WITH(apply_override(k, "size=1"), Contains("expected id.param=value"));
  // an override of an unknown param is caught by the builder like any other
  apply_override(k, "s.colour=1");
  REQUIRE_THROWS_WITH(Pipeline::build(parse_config(k, "x.json")), Contains("unknown param `colour`"));
}

TEST_CASE("config vars: one value that several params follow", "[graph]") {
  json j = json::parse(R"({"vars":{"size":3,"mode":"b"},
      "nodes":[{"id":"s","type":"test_source/box","params":{"size":"${size}","mode":"${mode}"}},
               {"id":"t","type":"test_source/box","params":{"size":"${size}","mode":"x${mode}y"}}]})");
  // the command-line substitution leaves the config's own vars alone
  json k = substitute_vars(j, {}, "x.json");
  PipelineConfig c = parse_config(k, "x.json");
  CHECK(c.nodes[0].params["size"] == 3);  // typed: a number, not the string "3"
  CHECK(c.nodes[0].params["mode"] == "b");
  CHECK(c.nodes[1].params["size"] == 3);
  CHECK(c.nodes[1].params["mode"] == "xby");
  apply_override(k, "vars.size=5");
  c = parse_config(k, "x.json");
  CHECK(c.nodes[0].params["size"] == 5);
  CHECK(c.nodes[1].params["size"] == 5);
  apply_override(k, "t.size=7");  // one param alone still works
  c = parse_config(k, "x.json");
  CHECK(c.nodes[0].params["size"] == 5);
  CHECK(c.nodes[1].params["size"] == 7);
  REQUIRE_THROWS_WITH(apply_override(k, "vars.colour=1"), Contains("the config has no var `colour`; vars: mode, size"));
  json bad = json::parse(R"({"vars":{"a":1},"nodes":[{"id":"s","type":"test_source/box","params":{"size":"${b}"}}]})");
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("`${b}` is not a var of the config; vars: a"));
  bad = json::parse(R"({"vars":{"a":[1]},"nodes":[{"id":"s","type":"test_source/box"}]})");
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("vars.a: a number, string or boolean"));
  bad = json::parse(R"({"nodes":[{"id":"vars","type":"test_source/box"}]})");
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("`vars` is reserved"));
}

TEST_CASE("config vars: a product of vars is one number that follows them", "[graph]") {
  json j = json::parse(R"({"vars":{"h":0.5,"t":"2 * ${h}","u":"${t}*1.5"},
      "nodes":[{"id":"s","type":"test_source/box","params":{"size":"${t}"}},
               {"id":"r","type":"test_source/box","params":{"size":"${u}"}}]})");
  PipelineConfig c = parse_config(j, "x.json");
  CHECK(c.nodes[0].params["size"] == 1.0);
  CHECK(c.nodes[1].params["size"] == 1.5);
  apply_override(j, "vars.h=2");
  c = parse_config(j, "x.json");
  CHECK(c.nodes[0].params["size"] == 4.0);
  CHECK(c.nodes[1].params["size"] == 6.0);
  json bad = json::parse(R"({"vars":{"a":"2 * ${b}","b":"${a}"},"nodes":[{"id":"s","type":"test_source/box"}]})");
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("cycle"));
  bad = json::parse(R"({"vars":{"a":"2 + ${b}","b":1},"nodes":[{"id":"s","type":"test_source/box"}]})");
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("not a product"));
}

TEST_CASE("config branches: copies side by side, ${branch}, skipped copies", "[graph]") {
  const std::string text = R"({"branches":{"count":3,"nodes":["keep","scaled"]},
      "nodes":[{"id":"src","type":"test_source/box","params":{"size":2}},
               {"id":"keep","type":"test_keep","params":{"below":"${branch}"},"inputs":{"surface":"src"}},
               {"id":"scaled","type":"test_scale","inputs":{"surface":"keep"}},
               {"id":"sum","type":"test_merge","inputs":{"a":"scaled#3","b":"scaled#1"}}]})";
  json j = json::parse(text);
  PipelineConfig c = parse_config(j, "x.json");
  REQUIRE(c.nodes.size() == 8);
  CHECK(c.nodes[1].id == "keep#1");
  CHECK(c.nodes[2].id == "scaled#1");
  CHECK(c.nodes[2].inputs["surface"] == "keep#1");
  CHECK(c.nodes[5].id == "keep#3");
  CHECK(c.nodes[5].params["below"] == 3);
  CHECK(c.nodes[5].branch == 3);
  CHECK(c.nodes[7].branch == 0);
  apply_override(j, "keep.below=9");  // every copy
  c = parse_config(j, "x.json");
  CHECK(c.nodes[1].params["below"] == 9);
  CHECK(c.nodes[5].params["below"] == 9);
  // Run: the box's coordinates reach 2, so keep#1 (below 1) and keep#2 (below 2) produce nothing and
  // their scaled copies are skipped; sum's optional port from scaled#1 is left unconnected.
  Pipeline p = build(text);
  RunOptions opt;
  opt.out_dir = temp_dir("branches");
  g_max_running = 2;  // test_scale waits for a sibling otherwise
  RunResult r = p.run(opt);
  REQUIRE(r.error.empty());
  const json rep = r.report();
  CHECK(rep["nodes"]["keep#1"]["skipped"] == true);
  CHECK(rep["nodes"]["scaled#1"]["skipped"] == true);
  CHECK(rep["nodes"]["scaled#2"]["skipped"] == true);
  CHECK_FALSE(rep["nodes"]["scaled#3"].contains("skipped"));
  CHECK(rep["nodes"]["sum"]["metrics"]["vertices"] == 4);
  // resident memory at each node's end (runtime/memory.h): the run's high-water mark holds every node's
  CHECK(rep["nodes"]["sum"]["rss_mb"].get<double>() > 0);
  for (const auto& [id, n] : rep["nodes"].items())
    if (n["ran"] == true) {
      CHECK(n["peak_rss_mb"].get<double>() >= n["rss_mb"].get<double>());
      CHECK(rep["peak_rss_mb"].get<double>() >= n["peak_rss_mb"].get<double>());
    }
  json bad = json::parse(R"({"branches":{"count":2,"nodes":["keep"]},
      "nodes":[{"id":"src","type":"test_source/box"},
               {"id":"keep","type":"test_keep","inputs":{"surface":"src"}},
               {"id":"sum","type":"test_merge","inputs":{"a":"keep"}}]})");
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("name one copy, `keep#1` to `keep#2`"));
  // A node of a branch that throws drops its branch, not the run; outside the branches it fails the run.
  Pipeline failing = build(R"({"branches":{"count":3,"nodes":["keep","bad"]},
      "nodes":[{"id":"src","type":"test_source/box","params":{"size":2}},
               {"id":"keep","type":"test_keep","params":{"below":"${branch}"},"inputs":{"surface":"src"}},
               {"id":"bad","type":"test_fail","inputs":["keep"]},
               {"id":"after","type":"test_merge","inputs":{"a":"src"}}]})");
  RunResult f = failing.run(opt);
  CHECK(f.error.empty());
  CHECK_THAT(f.report()["nodes"]["bad#3"]["branch_error"].get<std::string>(), Contains("not good enough"));
  CHECK(f.report()["nodes"]["bad#1"]["skipped"] == true);
  CHECK(f.report()["nodes"]["after"]["metrics"]["vertices"] == 4);
  bad["branches"]["nodes"] = json::array({"nothing"});
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("no node with id `nothing`"));
  bad = json::parse(R"({"nodes":[{"id":"a#1","type":"test_source/box"}]})");
  REQUIRE_THROWS_WITH(parse_config(bad, "x.json"), Contains("an id uses only letters"));
}

TEST_CASE("a pipeline runs, independent nodes concurrently, and writes report.json", "[graph]") {
  Pipeline p = build(R"({"nodes":[
      {"id":"src","type":"test_source/box","params":{"size":2}},
      {"id":"left","type":"test_scale","inputs":{"surface":"src"}},
      {"id":"right","type":"test_scale","inputs":{"surface":"src"}},
      {"id":"sum","type":"test_merge","inputs":{"a":"left","b":"right"}}]})");
  CHECK(p.nodes()[0].params == json::parse(R"({"size":2.0,"copies":1,"flag":false,"mode":"a"})"));
  std::string dot = p.dot();
  CHECK_THAT(dot, Contains("\"src\" -> \"left\" [label=\"surface: SurfaceMesh\"]"));
  g_max_running = 0;
  RunOptions opt;
  opt.out_dir = temp_dir("run");
  opt.threads = 2;
  RunResult r = p.run(opt);
  REQUIRE(r.error.empty());
  CHECK(g_max_running.load() == 2);  // left and right overlapped
  REQUIRE(r.nodes.size() == 4);
  CHECK(r.nodes[3].metrics["vertices"] == 8);
  write_report(r, opt.out_dir);
  std::ifstream in(opt.out_dir / "report.json");
  json rep = json::parse(in);
  CHECK(rep["status"] == "ok");
  CHECK(rep["nodes"]["src"]["type"] == "test_source/box");
  CHECK(rep["nodes"]["src"]["metrics"]["size"] == 2.0);
  CHECK(rep["nodes"]["sum"]["warnings"][0] == "merged");
  CHECK(rep["nodes"]["left"]["seconds"].get<double>() >= 0.0);
}

TEST_CASE("an exception in a node cancels the graph and names the node", "[graph]") {
  Pipeline p = build(R"({"nodes":[
      {"id":"src","type":"test_source/box"},
      {"id":"bad","type":"test_fail","inputs":["src"]},
      {"id":"after","type":"test_merge","inputs":{"a":"src"}}]})");
  // `after` depends only on src and may or may not run; nothing downstream of `bad` may.
  Pipeline q = build(R"({"nodes":[
      {"id":"src","type":"test_source/box"},
      {"id":"bad","type":"test_fail","inputs":["src"]}]})");
  RunOptions opt;
  opt.out_dir = temp_dir("fail");
  RunResult r = q.run(opt);
  CHECK_THAT(r.error, Contains("node `bad` (`test_fail/default`): the surface is not good enough"));
  CHECK(r.nodes[0].ran);
  CHECK_FALSE(r.nodes[1].ran);
  CHECK(r.report()["status"] == "error");
}

TEST_CASE("every config in configs/ parses and validates", "[graph][configs]") {
  int count = 0;
  for (auto& e : std::filesystem::directory_iterator(std::filesystem::path(POLYHEX_SOURCE_DIR) / "configs")) {
    if (e.path().extension() != ".json") continue;
    INFO(e.path());
    json j = load_config_json(e.path(), {{"input", "shape:box"}});
    REQUIRE_NOTHROW(Pipeline::build(parse_config(j, e.path().string())));
    ++count;
  }
  CHECK(count >= 1);
}

TEST_CASE("save-all never replaces a file the config writes: a clashing artefact goes to <id>.node<ext>", "[graph]") {
  // node `tets` saved under --save-all would be OUT/tets.vtk, which is the writer's output
  Pipeline p = build(R"({"nodes":[
      {"id":"surface","type":"shapes","params":{"name":"box","resolution":8}},
      {"id":"tets","type":"tetrahedralize/tetgen","params":{"edge_length":0.5},"inputs":{"surface":"surface"}},
      {"id":"write","type":"write_tetmesh","params":{"path":"tets.vtk"},"inputs":{"mesh":"tets"}}]})");
  RunOptions opt;
  opt.out_dir = temp_dir("saveall");
  opt.save_all = true;
  RunResult r = p.run(opt);
  REQUIRE(r.error.empty());
  CHECK(std::filesystem::exists(opt.out_dir / "tets.vtk"));       // the writer's
  CHECK(std::filesystem::exists(opt.out_dir / "tets.node.vtk"));  // --save-all's
  CHECK(std::filesystem::exists(opt.out_dir / "surface.obj"));    // no clash: the plain name
  CHECK_FALSE(std::filesystem::exists(opt.out_dir / "surface.node.obj"));
}

TEST_CASE("inverted hexes fail a run only in the mesh it kept, not in a branch it dropped", "[graph]") {
  // the default config: three frame branches (optimize#1..3) feeding select_hexes `best`, then `quality`
  std::ifstream in(std::filesystem::path(POLYHEX_SOURCE_DIR) / "configs" / "polycube.json");
  json config = json::parse(in);
  config["vars"]["input"] = "part.stl";  // what `polyhex run --input` sets; the pipeline is built, not run
  const Pipeline p = Pipeline::build(parse_config(config, "polycube.json"));
  auto record = [](const std::string& id, const std::string& type, json metrics) {
    NodeRecord n;
    n.id = id, n.type = type, n.ran = true, n.metrics = std::move(metrics);
    return n;
  };
  RunResult r;
  r.nodes = {record("optimize#1", "optimize/default", {{"inverted", 0}}),
             record("optimize#2", "optimize/default", {{"inverted", 2}}),
             record("best", "select_hexes/default", {{"chosen", 1}}),
             record("quality", "quality/default", {{"inverted", 0}})};
  CHECK(inverted_mesh_reports(p, r).empty());  // branch 2 folded, branch 1 was kept and written
  r.nodes[2].metrics["chosen"] = 2;
  auto reports = inverted_mesh_reports(p, r);
  REQUIRE(reports.size() == 1);
  CHECK(reports[0]->id == "optimize#2");
  r.nodes[2].metrics = json::object();  // no choice made: every branch counts
  CHECK(inverted_mesh_reports(p, r).size() == 1);
  r.nodes[2].metrics["chosen"] = 1;
  r.nodes[3].metrics["inverted"] = 1;  // the kept mesh itself
  reports = inverted_mesh_reports(p, r);
  REQUIRE(reports.size() == 1);
  CHECK(reports[0]->id == "quality");
}
