// Binary codecs of the five artefact types (nodes/artefacts/serialize.h): exact round trips through the
// registry's codecs, and malformed payloads rejected with a message.
#include "graph/node.h"
#include "nodes/artefacts/serialize.h"

#include <catch2/catch.hpp>

#include <cstring>
#include <sstream>

using namespace polyhex;
using Catch::Matchers::Contains;

namespace {

// Through the registered codec of T, as the cache does.
template <class T>
std::string encode(const T& value) {
  const ArtefactCodec* c = Registry::instance().codec(artefact_name<T>());
  REQUIRE(c);
  std::ostringstream out(std::ios::binary);
  c->write(make_artefact(T(value)), out);
  return out.str();
}
template <class T>
std::shared_ptr<const T> decode(const std::string& bytes) {
  const ArtefactCodec* c = Registry::instance().codec(artefact_name<T>());
  REQUIRE(c);
  std::istringstream in(bytes, std::ios::binary);
  Artefact a = c->read(in);
  REQUIRE(a.type == artefact_name<T>());
  return a.as<T>();
}

TetMesh two_tets() {
  TetMesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.1 / 3.0, -1e-300, 1e300;  // bit-exact values that do not print exactly
  m.T.resize(2, 4);
  m.T << 0, 1, 2, 3, 1, 2, 3, 4;
  m.source = "two tets ü";
  return m;
}

PolyCubeSegmentation segmentation() {
  PolyCubeSegmentation s;
  s.F.resize(3, 3);
  s.F << 0, 1, 2, 1, 3, 2, 0, 3, 1;
  s.chart.resize(3);
  s.chart << 0, 1, 1;
  s.label.resize(3);
  s.label << 4, 1, 1;
  s.charts = {{4, 1, 0.5, {1}, false}, {1, 2, 0.25, {0}, true}};
  s.edges = {{0, 1, {1, 2}, false}, {0, 1, {3, 0, 2}, true}};
  s.corners = {{2, 3, {0, 1}}};
  s.splits_multi_orientation = 1;
  s.splits_wedge = 2;
  s.splits_ramp = 3;
  s.splits_order_cycle = 7;
  s.order_cycles = 8;
  s.splits_island = 3;
  s.repaired_corners = 4;
  s.removed_small = 5;
  s.removed_narrow = 6;
  s.smoothing_iterations = 6;
  s.valid = true;
  s.problems = {"chart 0: too few neighbours", ""};
  s.failing_charts = {0};
  s.warnings = {"fallback"};
  s.source = "seg";
  return s;
}

void check_equal(const PolyCubeSegmentation& a, const PolyCubeSegmentation& b) {
  CHECK(a.F == b.F);
  CHECK(a.chart == b.chart);
  CHECK(a.label == b.label);
  REQUIRE(a.charts.size() == b.charts.size());
  for (size_t k = 0; k < a.charts.size(); ++k) {
    CHECK(a.charts[k].label == b.charts[k].label);
    CHECK(a.charts[k].triangles == b.charts[k].triangles);
    CHECK(a.charts[k].area == b.charts[k].area);
    CHECK(a.charts[k].neighbours == b.charts[k].neighbours);
    CHECK(a.charts[k].separating == b.charts[k].separating);
  }
  REQUIRE(a.edges.size() == b.edges.size());
  for (size_t k = 0; k < a.edges.size(); ++k) {
    CHECK(a.edges[k].chart_a == b.edges[k].chart_a);
    CHECK(a.edges[k].chart_b == b.edges[k].chart_b);
    CHECK(a.edges[k].vertices == b.edges[k].vertices);
    CHECK(a.edges[k].closed == b.edges[k].closed);
  }
  REQUIRE(a.corners.size() == b.corners.size());
  for (size_t k = 0; k < a.corners.size(); ++k) {
    CHECK(a.corners[k].vertex == b.corners[k].vertex);
    CHECK(a.corners[k].valence == b.corners[k].valence);
    CHECK(a.corners[k].charts == b.corners[k].charts);
  }
  CHECK(a.splits_multi_orientation == b.splits_multi_orientation);
  CHECK(a.splits_wedge == b.splits_wedge);
  CHECK(a.splits_ramp == b.splits_ramp);
  CHECK(a.splits_order_cycle == b.splits_order_cycle);
  CHECK(a.order_cycles == b.order_cycles);
  CHECK(a.splits_island == b.splits_island);
  CHECK(a.repaired_corners == b.repaired_corners);
  CHECK(a.removed_small == b.removed_small);
  CHECK(a.removed_narrow == b.removed_narrow);
  CHECK(a.smoothing_iterations == b.smoothing_iterations);
  CHECK(a.valid == b.valid);
  CHECK(a.problems == b.problems);
  CHECK(a.failing_charts == b.failing_charts);
  CHECK(a.warnings == b.warnings);
  CHECK(a.source == b.source);
}

}  // namespace

TEST_CASE("serialize: every artefact type has a codec of the current version", "[cache]") {
  for (auto t : {"SurfaceMesh", "TetMesh", "HexMesh", "PolyCubeSegmentation", "PolyCubeMap"}) {
    INFO(t);
    const ArtefactCodec* c = Registry::instance().codec(t);
    REQUIRE(c);
    CHECK(c->version == kCodecVersion);
  }
  CHECK(Registry::instance().codec("NoSuchType") == nullptr);
}

TEST_CASE("serialize: meshes round-trip exactly", "[cache]") {
  SurfaceMesh s;
  s.V = two_tets().V;
  s.F.resize(2, 3);
  s.F << 0, 1, 2, 4, 3, 2;
  s.source = "surf";
  auto s2 = decode<SurfaceMesh>(encode(s));
  CHECK(s2->V == s.V);
  CHECK(s2->F == s.F);
  CHECK(s2->source == s.source);

  TetMesh t = two_tets();
  const std::string bytes = encode(t);
  auto t2 = decode<TetMesh>(bytes);
  CHECK(t2->V == t.V);
  CHECK(t2->T == t.T);
  CHECK(t2->source == t.source);
  // layout: source (8 + 11 bytes), V (8 + 5*3*8), T (8 + 2*4*4)
  CHECK(bytes.size() == 8 + t.source.size() + 8 + 120 + 8 + 32);

  HexMesh h;
  h.V.resize(8, 3);
  for (int k = 0; k < 8; ++k) h.V.row(k) << double(k & 1), double((k >> 1) & 1), double((k >> 2) & 1);
  h.H.resize(1, 8);
  h.H << 0, 1, 3, 2, 4, 5, 7, 6;
  auto h2 = decode<HexMesh>(encode(h));
  CHECK(h2->V == h.V);
  CHECK(h2->H == h.H);

  HexMesh empty;
  auto e2 = decode<HexMesh>(encode(empty));
  CHECK(e2->V.rows() == 0);
  CHECK(e2->H.rows() == 0);
  CHECK(e2->source.empty());
}

TEST_CASE("serialize: segmentation and PolyCube map (with its inputs inline) round-trip exactly", "[cache]") {
  PolyCubeSegmentation s = segmentation();
  check_equal(*decode<PolyCubeSegmentation>(encode(s)), s);

  PolyCubeMap m;
  m.input = std::make_shared<const TetMesh>(two_tets());
  m.segmentation = std::make_shared<const PolyCubeSegmentation>(s);
  m.U = m.input->V * 2.0;
  m.edge_length = 0.0125;
  m.chart_plane.resize(2);
  m.chart_plane << 3, -2;
  auto m2 = decode<PolyCubeMap>(encode(m));
  REQUIRE(m2->input);
  REQUIRE(m2->segmentation);
  CHECK(m2->input->V == m.input->V);
  CHECK(m2->input->T == m.input->T);
  CHECK(m2->input->source == m.input->source);
  check_equal(*m2->segmentation, s);
  CHECK(m2->U == m.U);
  CHECK(m2->edge_length == m.edge_length);
  CHECK(m2->chart_plane == m.chart_plane);

  PolyCubeMap bare;  // no input, no segmentation
  bare.U = m.U;
  auto b2 = decode<PolyCubeMap>(encode(bare));
  CHECK_FALSE(b2->input);
  CHECK_FALSE(b2->segmentation);
  CHECK(b2->U == bare.U);
}

TEST_CASE("serialize: truncated, oversized and inconsistent payloads are rejected", "[cache]") {
  const std::string bytes = encode(two_tets());
  for (size_t cut : {size_t(0), size_t(5), size_t(8), bytes.size() / 2, bytes.size() - 1}) {
    INFO(cut);
    CHECK_THROWS_AS(decode<TetMesh>(bytes.substr(0, cut)), IOError);
  }
  CHECK_THROWS_WITH(decode<TetMesh>(bytes + "x"), Contains("TetMesh payload") && Contains("1 bytes left over"));
  // a vertex count far beyond the data: refused before allocating
  std::string huge = bytes;
  const std::uint64_t n = std::uint64_t(1) << 60;
  std::memcpy(&huge[8 + 11], &n, 8);
  CHECK_THROWS_WITH(decode<TetMesh>(huge), Contains("count 1152921504606846976 exceeds"));
  // a tet naming a vertex that does not exist
  TetMesh bad = two_tets();
  bad.T(1, 3) = 5;
  CHECK_THROWS_WITH(decode<TetMesh>(encode(bad)), Contains("vertex index out of range [0, 5)"));
  // a chart id beyond the charts, a label beyond 0..5
  PolyCubeSegmentation s = segmentation();
  s.chart(2) = 2;
  CHECK_THROWS_WITH(decode<PolyCubeSegmentation>(encode(s)), Contains("chart index out of range [0, 2)"));
  s = segmentation();
  s.label(0) = 6;
  CHECK_THROWS_WITH(decode<PolyCubeSegmentation>(encode(s)), Contains("label index out of range [0, 6)"));
  // a map whose U does not match its input
  PolyCubeMap m;
  m.input = std::make_shared<const TetMesh>(two_tets());
  m.U.resize(3, 3);
  m.U.setZero();
  CHECK_THROWS_WITH(decode<PolyCubeMap>(encode(m)), Contains("U has 3 rows for 5 vertices"));
}

namespace {
// One unit hex with two boundary groups of different families that share a face.
HexMesh hex_with_groups() {
  HexMesh h;
  h.V.resize(8, 3);
  h.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  h.H.resize(1, 8);
  h.H << 0, 1, 2, 3, 4, 5, 6, 7;
  h.source = "one hex";
  h.groups = {{"boundary", "boundary", 0, {{0, 0}, {0, 1}, {0, 2}, {0, 3}, {0, 4}, {0, 5}}},
              {"chart_7", "chart", 7, {{0, 1}, {0, 4}}}};
  return h;
}
}  // namespace

TEST_CASE("serialize: a hex mesh's boundary groups round-trip exactly; bad groups are refused", "[cache]") {
  const HexMesh h = hex_with_groups();
  const std::string bytes = encode(h);
  auto h2 = decode<HexMesh>(bytes);
  CHECK(h2->V == h.V);
  CHECK(h2->H == h.H);
  REQUIRE(h2->groups.size() == 2);
  for (size_t g = 0; g < 2; ++g) {
    CHECK(h2->groups[g].name == h.groups[g].name);
    CHECK(h2->groups[g].family == h.groups[g].family);
    CHECK(h2->groups[g].id == h.groups[g].id);
    CHECK(h2->groups[g].faces == h.groups[g].faces);
  }
  // layout: source, V, H, then the group count and per group name, family, id, faces (8 bytes each)
  const size_t mesh_bytes = 8 + 7 + 8 + 8 * 3 * 8 + 8 + 8 * 4;
  CHECK(bytes.size() == mesh_bytes + 8 + (8 + 8 + 8 + 8 + 4 + 8 + 6 * 8) + (8 + 7 + 8 + 5 + 4 + 8 + 2 * 8));
  // a mesh without groups still decodes to none
  HexMesh plain = h;
  plain.groups.clear();
  CHECK(decode<HexMesh>(encode(plain))->groups.empty());

  HexMesh bad = h;
  bad.groups[1].faces.push_back({0, 6});
  CHECK_THROWS_WITH(decode<HexMesh>(encode(bad)),
                    Contains("HexMesh payload") && Contains("`chart_7`") && Contains("face (0, 6) out of range"));
  bad = h;
  bad.groups[1].name = "boundary";
  CHECK_THROWS_WITH(decode<HexMesh>(encode(bad)), Contains("the name is used twice"));
  bad = h;
  bad.groups[1].faces = {{0, 4}, {0, 1}};
  CHECK_THROWS_WITH(decode<HexMesh>(encode(bad)), Contains("faces not sorted or repeated"));
  bad = h;
  bad.groups.push_back({"chart_8", "chart", 8, {{0, 4}}});
  CHECK_THROWS_WITH(decode<HexMesh>(encode(bad)), Contains("face (0, 4) is in another `chart` group too"));
  bad = h;
  bad.groups[1].name = "chart 7";
  CHECK_THROWS_WITH(decode<HexMesh>(encode(bad)), Contains("the name must be a letter"));
  // truncated inside the groups
  for (size_t cut : {mesh_bytes + 4, bytes.size() - 3}) CHECK_THROWS_AS(decode<HexMesh>(bytes.substr(0, cut)), IOError);
}
