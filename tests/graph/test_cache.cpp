// The artefact cache inside Pipeline::run: keys, hits and misses, downstream-only recompute, input
// files, bad entries (corrupt, truncated, old version) recovered with a warning, LRU prune, stats,
// and the variant swap that reuses every upstream node.
#include "graph/cache.h"
#include "graph/config.h"
#include "graph/pipeline.h"
#include "nodes/algorithms/shapes.h"
#include "nodes/artefacts/serialize.h"
#include "nodes/formats/surface_io.h"
#include "tests/helpers/cli.h"

#include <catch2/catch.hpp>

#include <atomic>
#include <cstring>
#include <fstream>
#include <functional>
#include <thread>
#include <unistd.h>

using namespace polyhex;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;
using polyhex::test::read_text;

namespace {

// An artefact type without a codec: nodes producing it are never cached.
struct CacheTestBlob {
  int value = 0;
};

}  // namespace

namespace polyhex {
template <>
struct ArtefactName<CacheTestBlob> {
  static constexpr const char* value = "CacheTestBlob";
};
}  // namespace polyhex

namespace {

std::atomic<int> g_src_calls{0}, g_scale_calls{0}, g_blob_calls{0}, g_sink_calls{0};

struct SrcParams {
  double size = 1.0;  ///< edge of the tetrahedron
  std::string tag;    ///< unused, changes the key
};
struct ScaleParams {
  double factor = 2.0;  ///< scale factor
};
struct NoParams {};

SurfaceMesh tetra(double s) {
  SurfaceMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, s, 0, 0, 0, s, 0, 0, 0, s;
  m.F.resize(4, 3);
  m.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  m.source = "tetra";
  return m;
}

// Test-only node types (prefixed test_cache_), registered in the test binary only. They count their calls.
const bool registered = [] {
  register_node(make_node<SrcParams>(
      "test_cache_src/default", "a tetrahedron surface",
      ParamSet<SrcParams>().add("size", &SrcParams::size, "edge", 0.0, 10.0).add("tag", &SrcParams::tag, "tag"), {},
      artefact_name<SurfaceMesh>(), [](const SrcParams& p, const Inputs&, NodeContext& ctx) {
        ++g_src_calls;
        ctx.metrics["size"] = p.size;
        ctx.metrics["list"] = {1, 2, 3};
        ctx.warn("source warning");
        return make_artefact(tetra(p.size));
      }));
  register_node(
      make_node<ScaleParams>("test_cache_scale/default", "scales a surface",
                             ParamSet<ScaleParams>().add("factor", &ScaleParams::factor, "factor", 0.0, 100.0),
                             {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<SurfaceMesh>(),
                             [](const ScaleParams& p, const Inputs& in, NodeContext& ctx) {
                               ++g_scale_calls;
                               SurfaceMesh m = *in.get<SurfaceMesh>(0);
                               m.V *= p.factor;
                               ctx.metrics["max"] = m.V.maxCoeff();
                               return make_artefact(std::move(m));
                             }));
  register_node(make_node<NoParams>("test_cache_blob/default", "an artefact without a codec", ParamSet<NoParams>(),
                                    {{"surface", artefact_name<SurfaceMesh>()}}, artefact_name<CacheTestBlob>(),
                                    [](const NoParams&, const Inputs& in, NodeContext&) {
                                      ++g_blob_calls;
                                      return make_artefact(CacheTestBlob{int(in.get<SurfaceMesh>(0)->V.rows())});
                                    }));
  register_node(make_node<NoParams>("test_cache_sink/default", "a sink", ParamSet<NoParams>(),
                                    {{"surface", artefact_name<SurfaceMesh>()}}, "",
                                    [](const NoParams&, const Inputs& in, NodeContext& ctx) {
                                      ++g_sink_calls;
                                      ctx.metrics["max"] = in.get<SurfaceMesh>(0)->V.maxCoeff();
                                      return Artefact{};
                                    }));
  return true;
}();

Pipeline build(const json& nodes) { return Pipeline::build(parse_config(json{{"nodes", nodes}}, "<test>")); }

json small_graph(double size, double factor) {
  return json::array({
      {{"id", "src"}, {"type", "test_cache_src"}, {"params", {{"size", size}}}},
      {{"id", "scale"},
       {"type", "test_cache_scale"},
       {"params", {{"factor", factor}}},
       {"inputs", {{"surface", "src"}}}},
      {{"id", "blob"}, {"type", "test_cache_blob"}, {"inputs", {{"surface", "scale"}}}},
      {{"id", "sink"}, {"type", "test_cache_sink"}, {"inputs", {{"surface", "scale"}}}},
  });
}

RunResult run(const Pipeline& p, const fs::path& dir, const std::string& out = "out", bool use_cache = true) {
  RunOptions opt;
  opt.out_dir = dir / out;
  opt.threads = 2;
  if (use_cache) opt.cache_dir = dir / "cache";
  RunResult r = p.run(opt);
  INFO(r.error);
  REQUIRE(r.error.empty());
  return r;
}

const NodeRecord& rec(const RunResult& r, const std::string& id) {
  for (auto& n : r.nodes)
    if (n.id == id) return n;
  FAIL("no node " + id);
  throw 0;
}

// A coarse built-in box (8 samples along its longest side).
json small_box() { return {{"id", "surface"}, {"type", "shapes"}, {"params", {{"name", "box"}, {"resolution", 8}}}}; }
json read_file(const fs::path& path) {
  return {{"id", "surface"}, {"type", "read_surface"}, {"params", {{"path", path.string()}}}};
}

// The baseline chain: surface -> TetGen -> 4 hexes per tet -> written file.
json box_chain(const json& surface, double tet_edge) {
  return json::array({
      surface,
      {{"id", "tets"},
       {"type", "tetrahedralize/tetgen"},
       {"params", {{"edge_length", tet_edge}}},
       {"inputs", {{"surface", "surface"}}}},
      {{"id", "hex"}, {"type", "hex_from_tets/split"}, {"inputs", {{"tets", "tets"}}}},
      {{"id", "write"}, {"type", "write_hex"}, {"params", {{"path", "hex.vtk"}}}, {"inputs", {{"mesh", "hex"}}}},
  });
}

void spit(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary | std::ios::trunc) << s; }

// The payload of an entry (layout in graph/cache.h): after the magic, two versions and the type and
// metadata blocks.
std::string payload_of(const std::string& entry) {
  size_t pos = 16;
  std::uint64_t n = 0;
  for (int block = 0; block < 3; ++block) {
    REQUIRE(pos + 8 <= entry.size());
    std::memcpy(&n, entry.data() + pos, 8);
    pos += 8;
    if (block < 2) pos += size_t(n);
  }
  REQUIRE(pos + n + 8 == entry.size());
  return entry.substr(pos, size_t(n));
}

json without_seconds(json metrics) {
  metrics.erase("seconds");
  return metrics;
}

}  // namespace

TEST_CASE("cache: canonical params, number normalisation and what goes into a key", "[cache]") {
  CHECK(canonical_json(json::parse(R"({"b": 2.0, "a": [1, -0.0, 0.1, 1e2], "c": "x"})")) ==
        R"({"a":[1,0,0.1,100],"b":2,"c":"x"})");
  CHECK(canonical_json(json::parse("0.30000000000000004")) == "0.30000000000000004");
  const NodeSpec* spec = Registry::instance().find("test_cache_src");
  REQUIRE(spec);
  const std::string k = node_key(*spec, {{"size", 2}, {"tag", ""}}, {});
  CHECK(k.size() == 32);
  CHECK(node_key(*spec, {{"tag", ""}, {"size", 2.0}}, {}) == k);  // key order and 2 vs 2.0 do not matter
  CHECK(node_key(*spec, {{"size", 2.5}, {"tag", ""}}, {}) != k);
  NodeSpec bumped = *spec;
  bumped.version = "2";
  CHECK(node_key(bumped, {{"size", 2}, {"tag", ""}}, {}) != k);  // a code version bump invalidates
  NodeSpec other = *spec;
  other.type = "test_cache_src/other";
  CHECK(node_key(other, {{"size", 2}, {"tag", ""}}, {}) != k);
  const NodeSpec* scale = Registry::instance().find("test_cache_scale");
  CHECK(node_key(*scale, {{"factor", 2}}, {"a"}) != node_key(*scale, {{"factor", 2}}, {"b"}));  // input keys
}

TEST_CASE("cache: sizes parse with binary units; bad sizes are config errors", "[cache]") {
  CHECK(parse_size("4096") == 4096);
  CHECK(parse_size("500M") == 500ull << 20);
  CHECK(parse_size("2G") == 2ull << 30);
  CHECK(parse_size("1.5k") == 1536);
  CHECK(parse_size("3MiB") == 3ull << 20);
  CHECK(parse_size("7MB") == 7ull << 20);
  CHECK_THROWS_WITH(parse_size("lots"), Contains("size `lots`") && Contains("500M"));
  CHECK_THROWS_AS(parse_size("5X"), ConfigError);
  CHECK_THROWS_AS(parse_size("-1M"), ConfigError);
  CHECK(format_size(1536) == "1.5 KB");
  CHECK(default_cache_dir("/a/b/out") == fs::path("/a/b/.polyhex-cache"));
  CHECK(default_cache_dir("/a/b/out/") == fs::path("/a/b/.polyhex-cache"));
  CHECK(default_cache_dir("rel") == fs::current_path() / ".polyhex-cache");
}

TEST_CASE("cache: a second run loads every cacheable node; metrics and warnings are restored; sinks run", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_hit");
  Pipeline p = build(small_graph(1.0, 3.0));
  g_src_calls = g_scale_calls = g_blob_calls = g_sink_calls = 0;
  RunResult a = run(p, dir);
  CHECK((g_src_calls == 1 && g_scale_calls == 1 && g_blob_calls == 1 && g_sink_calls == 1));
  for (auto& n : a.nodes) CHECK_FALSE(n.cache_hit);
  CHECK(ArtefactCache(dir / "cache").stats().entries == 2);  // src and scale; not the blob (no codec), not the sink

  RunResult b = run(p, dir, "out2");
  CHECK(g_src_calls == 1);
  CHECK(g_scale_calls == 1);
  CHECK(g_blob_calls == 2);  // no codec: always runs
  CHECK(g_sink_calls == 2);  // sinks always run
  CHECK(rec(b, "src").cache_hit);
  CHECK(rec(b, "scale").cache_hit);
  CHECK_FALSE(rec(b, "blob").cache_hit);
  CHECK_FALSE(rec(b, "sink").cache_hit);
  for (auto& n : b.nodes) CHECK(n.ran);
  CHECK(rec(b, "src").metrics == rec(a, "src").metrics);
  CHECK(rec(b, "src").metrics["list"] == json({1, 2, 3}));
  CHECK(rec(b, "src").warnings == std::vector<std::string>{"source warning"});
  CHECK(rec(b, "sink").metrics["max"] == 3.0);  // the sink saw the loaded artefact
  // the reports are the same but for timings, memory and cache_hit
  json ra = a.report(), rb = b.report();
  for (json* r : {&ra, &rb}) {
    r->erase("seconds");
    r->erase("peak_rss_mb");
    for (auto& [id, n] : r->at("nodes").items())
      for (const char* key : {"seconds", "cache_hit", "rss_mb", "peak_rss_mb"}) n.erase(key);
  }
  CHECK(ra == rb);

  // no cache folder: everything runs
  RunResult c = run(p, dir, "out3", /*use_cache=*/false);
  CHECK(g_src_calls == 2);
  for (auto& n : c.nodes) CHECK_FALSE(n.cache_hit);
  fs::remove_all(dir);
}

TEST_CASE("cache: a param change recomputes only the node and its downstream", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_downstream");
  g_src_calls = g_scale_calls = 0;
  run(build(small_graph(1.0, 3.0)), dir);
  RunResult r = run(build(small_graph(1.0, 5.0)), dir, "out2");
  CHECK(rec(r, "src").cache_hit);
  CHECK_FALSE(rec(r, "scale").cache_hit);
  CHECK(g_src_calls == 1);
  CHECK(g_scale_calls == 2);
  CHECK(rec(r, "sink").metrics["max"] == 5.0);
  // an upstream change recomputes everything below it
  RunResult u = run(build(small_graph(2.0, 5.0)), dir, "out3");
  CHECK_FALSE(rec(u, "src").cache_hit);
  CHECK_FALSE(rec(u, "scale").cache_hit);
  CHECK(rec(u, "sink").metrics["max"] == 10.0);
  // back to the first params: all hits
  RunResult back = run(build(small_graph(1.0, 3.0)), dir, "out4");
  CHECK(rec(back, "src").cache_hit);
  CHECK(rec(back, "scale").cache_hit);
  CHECK(rec(back, "sink").metrics["max"] == 3.0);
  CHECK(g_src_calls == 2);
  fs::remove_all(dir);
}

TEST_CASE("cache: a param change that leaves a node's output as it was recomputes that node only", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_same_output");
  json chain = box_chain(small_box(), 0.3);
  RunResult a = run(build(chain), dir, "a");
  REQUIRE(a.error.empty());
  // a refusal bound far above the tet count: another key for the tets, the same tets
  chain[1]["params"]["max_tets"] = 1000000;
  RunResult b = run(build(chain), dir, "b");
  REQUIRE(b.error.empty());
  CHECK(rec(b, "surface").cache_hit);
  CHECK_FALSE(rec(b, "tets").cache_hit);
  CHECK(rec(b, "tets").cache_key != rec(a, "tets").cache_key);
  CHECK(rec(b, "hex").cache_hit);  // keyed by the tets' content, not by the tets' params
  CHECK(rec(b, "hex").cache_key == rec(a, "hex").cache_key);
  CHECK(read_text(dir / "a" / "hex.vtk") == read_text(dir / "b" / "hex.vtk"));
  // a change that does change the tets recomputes the hexes
  chain[1]["params"]["edge_length"] = 0.15;
  RunResult c = run(build(chain), dir, "c");
  CHECK_FALSE(rec(c, "tets").cache_hit);
  CHECK_FALSE(rec(c, "hex").cache_hit);
  CHECK(read_text(dir / "a" / "hex.vtk") != read_text(dir / "c" / "hex.vtk"));
  fs::remove_all(dir);
}

TEST_CASE("cache: a changed input file invalidates its reader and everything downstream", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_file");
  ShapeParams sp;
  sp.name = "box";
  sp.resolution = 8;
  SurfaceMesh box = make_shape(sp);
  const fs::path surf = dir / "box.obj";
  write_surface(box, surf);
  Pipeline p = build(box_chain(read_file(surf), 0.3));
  RunResult a = run(p, dir, "a");
  RunResult b = run(p, dir, "b");
  CHECK(rec(b, "surface").cache_hit);
  CHECK(rec(b, "tets").cache_hit);
  CHECK(rec(b, "hex").cache_hit);
  CHECK(read_text(dir / "a" / "hex.vtk") == read_text(dir / "b" / "hex.vtk"));

  // the same bytes rewritten (new modification time): still a hit
  write_surface(box, surf);
  CHECK(rec(run(p, dir, "c"), "surface").cache_hit);

  // other bytes at the same path: recomputed from the reader down
  box.V *= 2.0;
  write_surface(box, surf);
  RunResult d = run(p, dir, "d");
  CHECK_FALSE(rec(d, "surface").cache_hit);
  CHECK_FALSE(rec(d, "tets").cache_hit);
  CHECK_FALSE(rec(d, "hex").cache_hit);
  CHECK(read_text(dir / "a" / "hex.vtk") != read_text(dir / "d" / "hex.vtk"));

  // an unreadable input file is not cached and fails in the reader with its own message
  fs::remove(surf);
  RunOptions opt;
  opt.out_dir = dir / "e";
  opt.cache_dir = dir / "cache";
  RunResult e = p.run(opt);
  CHECK_THAT(e.error, Contains("node `surface`") && Contains("box.obj"));
  fs::remove_all(dir);
}

TEST_CASE("cache: corrupt, truncated and old-version entries are ignored with a warning, recomputed and rewritten",
          "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_corrupt");
  Pipeline p = build(box_chain(small_box(), 0.3));
  RunResult first = run(p, dir, "first");
  const std::string reference = read_text(dir / "first" / "hex.vtk");
  REQUIRE(reference.size() > 1000);
  ArtefactCache cache(dir / "cache");
  CHECK(first.nodes[0].cache_key == p.cache_keys()[0]);  // no inputs: the two keys agree
  REQUIRE(!first.nodes[1].cache_key.empty());            // the tets: keyed by the surface's content
  const fs::path entry = cache.entry_path("tetrahedralize/tetgen", first.nodes[1].cache_key);
  REQUIRE(fs::exists(entry));
  const std::string good = read_text(entry);

  struct Damage {
    std::string name, expected;
    std::function<std::string(std::string)> apply;
  };
  auto set_u32 = [](std::string s, size_t at, std::uint32_t v) {
    std::memcpy(&s[at], &v, 4);
    return s;
  };
  std::vector<Damage> damages = {
      {"flipped payload byte", "checksum mismatch",
       [](std::string s) {
         s[s.size() / 2] ^= 0x5a;
         return s;
       }},
      {"truncated to half", "truncated", [](std::string s) { return s.substr(0, s.size() / 2); }},
      {"truncated to 5 bytes", "truncated (5 bytes)", [](std::string s) { return s.substr(0, 5); }},
      {"empty file", "truncated (0 bytes)", [](std::string) { return std::string(); }},
      {"not an entry", "bad magic",
       [](std::string s) {
         s[0] = 'X';
         return s;
       }},
      {"old entry format", "entry format version 0, expected 1", [&](std::string s) { return set_u32(s, 8, 0); }},
      {"old codec version", "TetMesh codec version 0, expected " + std::to_string(kCodecVersion),
       [&](std::string s) {
         s = set_u32(s, 12, 0);  // keep the checksum valid: the version check must catch it
         std::uint64_t sum = fnv1a64(s.data(), s.size() - 8);
         std::memcpy(&s[s.size() - 8], &sum, 8);
         return s;
       }},
  };
  for (const Damage& d : damages) {
    SECTION(d.name) {
      spit(entry, d.apply(good));
      RunResult r = run(p, dir, "damaged");
      CHECK(rec(r, "surface").cache_hit);
      CHECK_FALSE(rec(r, "tets").cache_hit);
      CHECK(rec(r, "hex").cache_hit);  // its key does not depend on how tets was obtained
      const auto& w = rec(r, "tets").warnings;
      REQUIRE(w.size() == 1);
      CHECK_THAT(w[0], Contains("cache: ignored entry " + entry.filename().string()) && Contains(d.expected) &&
                           Contains("recomputed"));
      CHECK(without_seconds(rec(r, "tets").metrics) == without_seconds(rec(first, "tets").metrics));
      CHECK(read_text(dir / "damaged" / "hex.vtk") == reference);
      CHECK(payload_of(read_text(entry)) == payload_of(good));  // rewritten with the same (recomputed) tets
      RunResult again = run(p, dir, "again");
      CHECK(rec(again, "tets").cache_hit);
      CHECK(rec(again, "tets").warnings.empty());
    }
  }
  fs::remove_all(dir);
}

TEST_CASE("cache: stats count entries per node type; prune removes the least recently used; clear empties", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_prune");
  ArtefactCache cache(dir / "cache");
  CHECK(cache.stats().entries == 0);  // missing folder = empty
  const Artefact a = make_artefact(tetra(1.0));
  for (int k = 0; k < 4; ++k) cache.store("test_cache_src/default", "key" + std::to_string(k), a, json::object(), {});
  cache.store("test_cache_scale/default", "other", a, json::object(), {});
  CacheStats s = cache.stats();
  CHECK(s.entries == 5);
  CHECK(s.by_type["test_cache_src/default"].first == 4);
  CHECK(s.by_type["test_cache_scale/default"].first == 1);
  auto size = [&](const std::string& type, const std::string& key) {
    return fs::file_size(cache.entry_path("test_cache_" + type + "/default", key));
  };
  const std::uintmax_t one = size("src", "key0");  // the entries of one node type have the same size
  CHECK(s.bytes == 4 * one + size("scale", "other"));
  // ages: key0 oldest ... other newest; a hit on key0 makes it the most recent
  auto now = fs::file_time_type::clock::now();
  int age = 10;
  for (auto key : {"key0", "key1", "key2", "key3"})
    fs::last_write_time(cache.entry_path("test_cache_src/default", key), now - std::chrono::minutes(age--));
  CHECK(cache.load("test_cache_src/default", "key0", "SurfaceMesh").status == CacheLookup::Status::hit);
  CHECK(cache.load("test_cache_src/default", "missing", "SurfaceMesh").status == CacheLookup::Status::miss);
  // a write in progress (temporary file) is not an entry and survives clear and prune
  spit(dir / "cache" / ("x.phc.tmp." + std::to_string(::getpid()) + ".0"), "partial");
  CHECK(cache.stats().temp_files == 1);

  const std::uintmax_t keep = 2 * one + size("scale", "other");
  ArtefactCache::PruneResult r = cache.prune(keep);
  CHECK(r.removed == 2);
  CHECK(r.freed == 2 * one);
  CHECK(r.remaining == keep);
  CHECK_FALSE(fs::exists(cache.entry_path("test_cache_src/default", "key1")));
  CHECK_FALSE(fs::exists(cache.entry_path("test_cache_src/default", "key2")));
  CHECK(fs::exists(cache.entry_path("test_cache_src/default", "key0")));  // used recently
  CHECK(fs::exists(cache.entry_path("test_cache_src/default", "key3")));
  CHECK(cache.prune(keep).removed == 0);
  CHECK(cache.prune(keep - 1).removed == 1);  // the oldest left: key3
  CHECK_FALSE(fs::exists(cache.entry_path("test_cache_src/default", "key3")));
  CHECK(cache.stats().entries == 2);
  CHECK(cache.clear() == 2);
  CHECK(cache.stats().entries == 0);
  CHECK(cache.stats().temp_files == 1);
  fs::remove_all(dir);
}

TEST_CASE("cache: concurrent runs of one pipeline in one process share a cache", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_threads");
  Pipeline p = build(box_chain(small_box(), 0.3));
  std::vector<RunResult> results(3);
  std::vector<std::thread> threads;
  for (int k = 0; k < 3; ++k)
    threads.emplace_back([&, k] {
      RunOptions opt;
      opt.out_dir = dir / ("out" + std::to_string(k));
      opt.cache_dir = dir / "cache";
      opt.threads = 1;
      results[k] = p.run(opt);
    });
  for (auto& t : threads) t.join();
  const std::string reference = read_text(dir / "out0" / "hex.vtk");
  for (int k = 0; k < 3; ++k) {
    INFO(results[k].error);
    CHECK(results[k].error.empty());
    for (auto& n : results[k].nodes) CHECK(n.warnings.empty());
    CHECK(read_text(dir / ("out" + std::to_string(k)) / "hex.vtk") == reference);
  }
  CHECK(ArtefactCache(dir / "cache").stats().entries == 3);
  CHECK(ArtefactCache(dir / "cache").stats().temp_files == 0);
  fs::remove_all(dir);
}

TEST_CASE("cache: swapping the hex stage variant reuses every upstream node", "[cache]") {
  fs::path dir = polyhex::test::fresh_dir("cache_variant");
  auto graph = [](const json& hex) {
    return json::array({
        small_box(),
        {{"id", "tets"},
         {"type", "tetrahedralize/tetgen"},
         {"params", {{"edge_length", 0.15}}},
         {"inputs", {{"surface", "surface"}}}},
        {{"id", "rotate"},
         {"type", "rotation_deform/quaternion_laplace"},
         {"params", {{"iterations", 2}}},
         {"inputs", {{"tets", "tets"}}}},
        {{"id", "segment"},
         {"type", "polycube_segment"},
         {"params", {{"hex_edge_length", 0.2}}},
         {"inputs", {{"deformed", "rotate"}}}},
        {{"id", "polycube"},
         {"type", "position_deform/chart_planes"},
         {"params", {{"edge_length", 0.2}}},
         {"inputs", {{"tets", "tets"}, {"deformed", "rotate"}, {"segmentation", "segment"}}}},
        hex,
        {{"id", "quality"}, {"type", "quality"}, {"inputs", {{"mesh", "hex"}, {"surface", "surface"}}}},
    });
  };
  Pipeline lattice = build(graph({{"id", "hex"}, {"type", "hex_extract/lattice"}, {"inputs", {{"map", "polycube"}}}}));
  Pipeline split = build(graph({{"id", "hex"}, {"type", "hex_from_tets/split"}, {"inputs", {{"tets", "tets"}}}}));
  RunResult a = run(lattice, dir, "lattice");
  for (auto& n : a.nodes) CHECK_FALSE(n.cache_hit);
  RunResult b = run(split, dir, "split");
  for (auto id : {"surface", "tets", "rotate", "segment", "polycube"}) {
    INFO(id);
    CHECK(rec(b, id).cache_hit);
  }
  CHECK_FALSE(rec(b, "hex").cache_hit);
  CHECK_FALSE(rec(b, "quality").cache_hit);
  CHECK(rec(b, "quality").metrics["hexes"] == 4 * rec(b, "tets").metrics["tets"].get<int>());
  // and back: the lattice variant is a hit too; the quality sink runs again on the loaded hexes
  RunResult c = run(lattice, dir, "lattice2");
  for (auto& n : c.nodes) CHECK(n.cache_hit == (n.id != "quality"));
  CHECK(without_seconds(rec(c, "quality").metrics) == without_seconds(rec(a, "quality").metrics));
  CHECK(rec(a, "quality").metrics["hexes"].get<int>() > 0);
  fs::remove_all(dir);
}
