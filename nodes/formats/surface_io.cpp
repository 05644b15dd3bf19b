#include "nodes/formats/surface_io.h"

#include "nodes/algorithms/shapes.h"
#include "nodes/formats/text_cursor.h"
#include "runtime/errors.h"
#include "runtime/union_find.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

namespace polyhex {

using io_detail::BinaryCursor;
using io_detail::TextCursor;

namespace {

/// A surface as parsed: flat arrays, polygons already fan-triangulated.
struct RawSurface {
  std::vector<double> V;  // 3 per vertex
  std::vector<int> F;     // 3 per triangle
  std::vector<int> line;  // file line of each triangle (text formats)
  int polygons = 0;       // polygons with more than 3 vertices
};

std::string vertex_count(size_t nv) { return std::to_string(nv) + (nv == 1 ? " vertex" : " vertices"); }

// Fan-triangulates a polygon of already range-checked indices.
void add_polygon(RawSurface& s, const std::vector<int>& idx, int line) {
  if (idx.size() > 3) ++s.polygons;
  for (size_t j = 1; j + 1 < idx.size(); ++j) {
    s.F.insert(s.F.end(), {idx[0], idx[j], idx[j + 1]});
    s.line.push_back(line);
  }
}

// ---------------------------------------------------------------------------------------------
// OBJ: `v x y z [w | r g b]`, `f i i/t i//n i/t/n ...` (1-based, negative = relative to the end).

RawSurface parse_obj(std::string_view text, const std::string& file) {
  RawSurface s;
  TextCursor c(text, file, '#');
  std::string_view l;
  std::vector<std::string_view> w;
  std::vector<int> idx;
  std::vector<long long> pending;  // positive indices may refer to vertices defined later
  std::vector<int> pending_line;
  while (c.next_line(l)) {
    io_detail::split_blanks(l, w);
    if (w[0] == "v") {
      if (w.size() < 4) c.fail("vertex needs 3 coordinates");
      for (int k = 1; k <= 3; ++k) {
        double x;
        if (!io_detail::parse_double(w[k], x)) c.fail("expected a vertex coordinate, got `" + std::string(w[k]) + "`");
        if (!std::isfinite(x))
          c.fail("vertex " + std::to_string(s.V.size() / 3 + 1) + " has a non-finite coordinate (`" +
                 std::string(w[k]) + "`)");
        s.V.push_back(x);
      }
    } else if (w[0] == "f") {
      if (w.size() < 4) c.fail("face needs at least 3 vertices, has " + std::to_string(w.size() - 1));
      idx.clear();
      for (size_t k = 1; k < w.size(); ++k) {
        std::string_view t = w[k].substr(0, w[k].find('/'));
        long long i;
        if (!io_detail::parse_int(t, i)) c.fail("expected a vertex index, got `" + std::string(w[k]) + "`");
        const long long nv = (long long)(s.V.size() / 3);
        if (i == 0) c.fail("vertex index 0 (OBJ indices start at 1)");
        if (i < 0) {
          if (nv + i < 0)
            c.fail("relative vertex index " + std::to_string(i) + " out of range (" + vertex_count(nv) + " so far)");
          idx.push_back(int(nv + i));
        } else {
          if (i > (long long)INT32_MAX) c.fail("vertex index " + std::to_string(i) + " out of range");
          idx.push_back(int(i - 1));
        }
      }
      add_polygon(s, idx, c.line_no());
    }
    // vn, vt, g, o, s, usemtl, mtllib, l, ...: not needed
  }
  if (s.F.empty())
    throw IOError(file + ": no faces (`f` lines)" +
                  (s.V.empty() ? std::string(" and no vertices (`v` lines): not an OBJ file?") : std::string()));
  const size_t nv = s.V.size() / 3;
  for (size_t f = 0; f < s.F.size(); ++f)
    if (size_t(s.F[f]) >= nv)
      throw IOError(file + ": line " + std::to_string(s.line[f / 3]) + ": vertex index " + std::to_string(s.F[f] + 1) +
                    " out of range (" + vertex_count(nv) + ")");
  return s;
}

// ---------------------------------------------------------------------------------------------
// OFF: `[C][N][ST]OFF`, counts, one vertex per line (extra values such as colours ignored), one
// polygon per line `n i1 .. in [colour]` (0-based).

RawSurface parse_off(std::string_view text, const std::string& file) {
  RawSurface s;
  TextCursor c(text, file, '#');
  std::string_view l;
  std::vector<std::string_view> w;
  if (!c.next_line(l)) throw IOError(file + ": empty file");
  io_detail::split_blanks(l, w);
  const std::string_view head = w[0];
  if (head.size() < 3 || head.substr(head.size() - 3) != "OFF" || head.find_first_of("n4") != std::string_view::npos)
    c.fail("not an OFF file (expected the header `OFF`, got `" + std::string(head) + "`)");
  std::vector<std::string_view> counts(w.begin() + 1, w.end());
  if (counts.empty()) {
    if (!c.next_line(l)) c.fail("truncated: expected the counts `vertices faces edges`");
    io_detail::split_blanks(l, w);
    counts = w;
  }
  long long nv, nf;
  if (counts.size() < 2 || !io_detail::parse_int(counts[0], nv) || !io_detail::parse_int(counts[1], nf) || nv < 0 ||
      nf < 0)
    c.fail("expected the counts `vertices faces edges`");
  s.V.reserve(3 * c.reserve_hint(nv, 6));
  for (long long i = 0; i < nv; ++i) {
    if (!c.next_line(l))
      c.fail("truncated: the header announces " + vertex_count(size_t(nv)) + ", the file ends after " +
             std::to_string(i));
    io_detail::split_blanks(l, w);
    if (w.size() < 3) c.fail("vertex " + std::to_string(i) + " needs 3 coordinates, has " + std::to_string(w.size()));
    for (int k = 0; k < 3; ++k) {
      double x;
      if (!io_detail::parse_double(w[k], x)) c.fail("expected a vertex coordinate, got `" + std::string(w[k]) + "`");
      if (!std::isfinite(x))
        c.fail("vertex " + std::to_string(i) + " has a non-finite coordinate (`" + std::string(w[k]) + "`)");
      s.V.push_back(x);
    }
  }
  std::vector<int> idx;
  s.F.reserve(3 * c.reserve_hint(nf, 8));
  for (long long f = 0; f < nf; ++f) {
    if (!c.next_line(l))
      c.fail("truncated: the header announces " + std::to_string(nf) + " faces, the file ends after " +
             std::to_string(f));
    io_detail::split_blanks(l, w);
    long long n;
    if (!io_detail::parse_int(w[0], n))
      c.fail("face " + std::to_string(f) + ": expected the vertex count of the face, got `" + std::string(w[0]) +
             "` (wrong counts in the header?)");
    if (n < 3) c.fail("face " + std::to_string(f) + " has " + std::to_string(n) + " vertices (at least 3 needed)");
    if ((long long)w.size() < n + 1)
      c.fail("face " + std::to_string(f) + " announces " + std::to_string(n) + " vertices but lists " +
             std::to_string(w.size() - 1));
    idx.clear();
    for (long long k = 1; k <= n; ++k) {
      long long i;
      if (!io_detail::parse_int(w[size_t(k)], i))
        c.fail("expected a vertex index, got `" + std::string(w[size_t(k)]) + "`");
      if (i < 0 || i >= nv)
        c.fail("face " + std::to_string(f) + ": vertex index " + std::to_string(i) + " out of range (" +
               vertex_count(size_t(nv)) + ")");
      idx.push_back(int(i));
    }
    add_polygon(s, idx, c.line_no());
  }
  if (c.next_line(l))
    c.fail("more data after the " + std::to_string(nf) + " faces the header announces (wrong counts?)");
  return s;
}

// ---------------------------------------------------------------------------------------------
// STL: binary when the size is exactly 84 + 50 n (n = the count at byte 80), else ASCII.

RawSurface parse_stl_binary(std::string_view data, const std::string& file, uint32_t n) {
  RawSurface s;
  s.V.reserve(size_t(n) * 9);
  s.F.reserve(size_t(n) * 3);
  BinaryCursor b(data, 84, false, file);
  for (uint32_t t = 0; t < n; ++t) {
    b.skip(12, "triangle normal");
    for (int k = 0; k < 9; ++k) {
      float x = b.get<float>("a triangle record");
      if (!std::isfinite(x)) throw IOError(file + ": triangle " + std::to_string(t) + " has a non-finite coordinate");
      s.V.push_back(x);
    }
    b.skip(2, "attribute");
    const int v0 = int(3 * t);
    s.F.insert(s.F.end(), {v0, v0 + 1, v0 + 2});
  }
  return s;
}

RawSurface parse_stl_ascii(std::string_view text, const std::string& file) {
  RawSurface s;
  TextCursor c(text, file);
  std::string_view l;
  std::vector<std::string_view> w;
  std::vector<int> loop;
  bool in_solid = false, in_loop = false, in_facet = false, ended = false;
  int loop_line = 0;
  while (c.next_line(l)) {
    io_detail::split_blanks(l, w);
    const std::string_view k = w[0];
    if (k == "solid") {
      in_solid = true;
      ended = false;
    } else if (!in_solid) {
      c.fail("expected `solid` (not an ASCII STL)");
    } else if (k == "facet") {
      if (in_facet) c.fail("`facet` inside a facet");
      in_facet = true;
    } else if (k == "outer") {
      if (!in_facet) c.fail("`outer loop` outside a facet");
      in_loop = true;
      loop.clear();
      loop_line = c.line_no();
    } else if (k == "vertex") {
      if (!in_loop) c.fail("`vertex` outside a loop");
      if (w.size() < 4) c.fail("vertex needs 3 coordinates");
      for (int j = 1; j <= 3; ++j) {
        double x;
        if (!io_detail::parse_double(w[size_t(j)], x))
          c.fail("expected a vertex coordinate, got `" + std::string(w[size_t(j)]) + "`");
        if (!std::isfinite(x)) c.fail("vertex has a non-finite coordinate (`" + std::string(w[size_t(j)]) + "`)");
        s.V.push_back(x);
      }
      loop.push_back(int(s.V.size() / 3 - 1));
    } else if (k == "endloop") {
      if (!in_loop) c.fail("`endloop` without `outer loop`");
      if (loop.size() < 3) c.fail("facet has " + std::to_string(loop.size()) + " vertices (at least 3 needed)");
      add_polygon(s, loop, loop_line);
      in_loop = false;
    } else if (k == "endfacet") {
      if (!in_facet || in_loop) c.fail("`endfacet` without a complete loop");
      in_facet = false;
    } else if (k == "endsolid") {
      if (in_facet) c.fail("`endsolid` inside a facet");
      in_solid = false;
      ended = true;
    } else {
      c.fail("unexpected `" + std::string(k) + "` in an ASCII STL");
    }
  }
  if (in_facet || in_loop) c.fail("truncated: the file ends inside a facet");
  if (!ended) c.fail("truncated: no `endsolid`");
  return s;
}

RawSurface parse_stl(std::string_view data, const std::string& file) {
  if (data.size() >= 84) {
    uint32_t n = BinaryCursor(data, 80, false, file).get<uint32_t>("triangle count");
    if (uint64_t(data.size()) == 84 + 50 * uint64_t(n)) return parse_stl_binary(data, file, n);
  }
  size_t a = data.find_first_not_of(" \t\r\n");
  if (a != std::string_view::npos && data.substr(a, 5) == "solid") {
    try {
      return parse_stl_ascii(data, file);
    } catch (const IOError&) {
      // A binary file whose header starts with "solid" but has a wrong size: say both.
      if (data.size() >= 84 && data.find('\0') != std::string_view::npos) {
        uint32_t n = BinaryCursor(data, 80, false, file).get<uint32_t>("triangle count");
        throw IOError(file + ": truncated or corrupt binary STL: size " + std::to_string(data.size()) + " bytes, but " +
                      std::to_string(n) + " triangles need 84 + 50 * " + std::to_string(n) + " = " +
                      std::to_string(84 + 50 * uint64_t(n)));
      }
      throw;
    }
  }
  if (data.size() < 84)
    throw IOError(file + ": truncated: " + std::to_string(data.size()) +
                  " bytes is too short for a binary STL and it is not ASCII (no `solid`)");
  uint32_t n = BinaryCursor(data, 80, false, file).get<uint32_t>("triangle count");
  throw IOError(file + ": truncated or corrupt binary STL: size " + std::to_string(data.size()) + " bytes, but " +
                std::to_string(n) + " triangles need 84 + 50 * " + std::to_string(n) + " = " +
                std::to_string(84 + 50 * uint64_t(n)));
}

// ---------------------------------------------------------------------------------------------
// PLY: ASCII, binary little/big endian; element vertex (x, y, z), element face (a list of indices);
// every other property and element is skipped with its own type.

struct PlyProperty {
  std::string name, type;  // scalar type, or the item type of a list
  std::string count_type;  // list count type, "" for a scalar
};
struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> props;
};

bool ply_type_known(const std::string& t) {
  static const char* known[] = {"char", "int8",  "uchar", "uint8",  "short", "int16",   "ushort", "uint16",
                                "int",  "int32", "uint",  "uint32", "float", "float32", "double", "float64"};
  for (auto k : known)
    if (t == k) return true;
  return false;
}

class PlyValues {
 public:
  PlyValues(TextCursor* text, BinaryCursor* bin) : text_(text), bin_(bin) {}
  double get(const std::string& type, const std::string& what) {
    if (text_) {
      std::string_view t = text_->token(what);
      double x;
      if (!io_detail::parse_double(t, x)) text_->fail("expected " + what + ", got `" + std::string(t) + "`");
      return x;
    }
    if (type == "char" || type == "int8") return bin_->get<int8_t>(what);
    if (type == "uchar" || type == "uint8") return bin_->get<uint8_t>(what);
    if (type == "short" || type == "int16") return bin_->get<int16_t>(what);
    if (type == "ushort" || type == "uint16") return bin_->get<uint16_t>(what);
    if (type == "int" || type == "int32") return bin_->get<int32_t>(what);
    if (type == "uint" || type == "uint32") return bin_->get<uint32_t>(what);
    if (type == "float" || type == "float32") return bin_->get<float>(what);
    return bin_->get<double>(what);
  }

 private:
  TextCursor* text_;
  BinaryCursor* bin_;
};

struct PlyHeader {
  std::string format;
  std::vector<PlyElement> elements;
  size_t body = 0;    ///< offset of the first byte after `end_header`
  int body_line = 1;  ///< its line
};

PlyProperty parse_ply_property(TextCursor& h, const std::vector<std::string_view>& w) {
  PlyProperty p;
  if (w.size() >= 5 && w[1] == "list") {
    p.count_type = std::string(w[2]);
    p.type = std::string(w[3]);
    p.name = std::string(w[4]);
    if (!ply_type_known(p.count_type)) h.fail("unknown PLY type `" + p.count_type + "`");
  } else if (w.size() >= 3) {
    p.type = std::string(w[1]);
    p.name = std::string(w[2]);
  } else {
    h.fail("expected `property TYPE NAME` or `property list COUNT_TYPE TYPE NAME`");
  }
  if (!ply_type_known(p.type)) h.fail("unknown PLY type `" + p.type + "`");
  return p;
}

PlyHeader parse_ply_header(TextCursor& h, const std::string& file) {
  std::string_view l;
  std::vector<std::string_view> w;
  if (!h.line(l) || l != "ply") throw IOError(file + ": not a PLY file (the first line must be `ply`)");
  PlyHeader hd;
  bool header_done = false;
  while (h.line(l)) {
    io_detail::split_blanks(l, w);
    if (w.empty()) continue;
    if (w[0] == "end_header") {
      header_done = true;
      break;
    }
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "format") {
      if (w.size() < 2) h.fail("format needs a name");
      hd.format = std::string(w[1]);
      if (hd.format != "ascii" && hd.format != "binary_little_endian" && hd.format != "binary_big_endian")
        h.fail("unknown PLY format `" + hd.format + "`");
    } else if (w[0] == "element") {
      long long n;
      if (w.size() < 3 || !io_detail::parse_int(w[2], n) || n < 0) h.fail("expected `element NAME COUNT`");
      hd.elements.push_back({std::string(w[1]), n, {}});
    } else if (w[0] == "property") {
      if (hd.elements.empty()) h.fail("property before any element");
      hd.elements.back().props.push_back(parse_ply_property(h, w));
    } else {
      h.fail("unexpected `" + std::string(w[0]) + "` in the PLY header");
    }
  }
  if (!header_done) throw IOError(file + ": truncated: no `end_header`");
  if (hd.format.empty()) throw IOError(file + ": no `format` line in the PLY header");
  hd.body = h.pos();
  hd.body_line = h.current_line();
  return hd;
}

/// The body of a PLY file after its header: the vertex element's x, y, z and the face element's index
/// list into a RawSurface; every other property and element read by its type and dropped.
class PlyBodyReader {
 public:
  PlyBodyReader(std::string_view data, const std::string& file, const PlyHeader& hd)
      : file_(file),
        ascii_(hd.format == "ascii"),
        text_(data, file),
        bin_(data, hd.body, hd.format == "binary_big_endian", file),
        values_(ascii_ ? &text_ : nullptr, ascii_ ? nullptr : &bin_) {
    text_.seek(hd.body, hd.body_line);
  }

  RawSurface read(const std::vector<PlyElement>& elements) {
    for (const PlyElement& e : elements) read_element(e);
    if (!have_vertex_) throw IOError(file_ + ": no PLY vertex element");
    if (!have_face_) throw IOError(file_ + ": no PLY face element");
    if (ascii_) {
      std::string_view extra;
      if (text_.next(extra)) text_.fail("more data after the elements the header announces (wrong counts?)");
    }
    for (size_t f = 0; f < s_.F.size(); ++f)
      if (s_.F[f] >= nv_) {
        const std::string where = s_.line[f / 3] > 0 ? "line " + std::to_string(s_.line[f / 3]) + ": " : "";
        throw IOError(file_ + ": " + where + "triangle " + std::to_string(f / 3) + ": vertex index " +
                      std::to_string(s_.F[f]) + " out of range (" + vertex_count(size_t(nv_)) + ")");
      }
    if (!ascii_) s_.line.clear();
    return std::move(s_);
  }

 private:
  void read_element(const PlyElement& e) {
    // An element without properties takes no bytes, so its count cannot be checked against the file: a
    // forged one (`element x 1000000000000`, fuzzing found it) would spin here for hours.
    if (e.props.empty() && e.count > 0)
      throw IOError(file_ + ": PLY element `" + e.name + "` has " + std::to_string(e.count) +
                    " entries but no properties");
    int xyz[3] = {-1, -1, -1};
    int list = -1;
    if (e.name == "vertex") {
      for (size_t p = 0; p < e.props.size(); ++p)
        for (int k = 0; k < 3; ++k)
          if (e.props[p].count_type.empty() && e.props[p].name == std::string(1, char('x' + k))) xyz[k] = int(p);
      if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0)
        throw IOError(file_ + ": PLY vertex element has no x, y, z properties");
      have_vertex_ = true;
      nv_ = e.count;
      s_.V.reserve(3 * text_.reserve_hint(e.count, e.props.size()));
    } else if (e.name == "face") {
      for (size_t p = 0; p < e.props.size() && list < 0; ++p)
        if (!e.props[p].count_type.empty() &&
            (e.props[p].name == "vertex_indices" || e.props[p].name == "vertex_index"))
          list = int(p);
      for (size_t p = 0; p < e.props.size() && list < 0; ++p)
        if (!e.props[p].count_type.empty()) list = int(p);
      if (list < 0) throw IOError(file_ + ": PLY face element has no vertex index list");
      have_face_ = true;
    }
    for (long long i = 0; i < e.count; ++i) read_entry(e, i, xyz, list);
  }

  /// Entry i of element e; `xyz` are the columns of the coordinates, `list` that of the face's indices.
  void read_entry(const PlyElement& e, long long i, const int xyz[3], int list) {
    const std::string what = e.name + " " + std::to_string(i);
    int line = ascii_ ? -1 : 0;
    for (size_t p = 0; p < e.props.size(); ++p) {
      const PlyProperty& pr = e.props[p];
      if (pr.count_type.empty()) {
        double x = values_.get(pr.type, what);
        if (ascii_ && p == 0) line = text_.line_no();
        for (int k = 0; k < 3; ++k)
          if (xyz[k] == int(p)) {
            if (!std::isfinite(x))
              throw IOError(file_ + ": vertex " + std::to_string(i) + " has a non-finite coordinate");
            if (s_.V.size() < size_t(3 * (i + 1))) s_.V.resize(size_t(3 * (i + 1)));  // grows as read
            s_.V[size_t(3 * i + k)] = x;
          }
        continue;
      }
      double n = values_.get(pr.count_type, what + " list count");
      if (ascii_ && p == 0) line = text_.line_no();
      // (bounded before any int conversion: a forged count like 1e16 is not representable)
      if (n < 0 || n != std::floor(n) || n > double(INT32_MAX)) throw IOError(file_ + ": " + what + ": bad list count");
      if (int(p) == list) {
        if (n < 3)
          throw IOError(file_ + ": face " + std::to_string(i) + " has " + std::to_string(int(n)) +
                        " vertices (at least 3 needed)");
        idx_.clear();
        for (int k = 0; k < int(n); ++k) {
          double v = values_.get(pr.type, what);
          if (v < 0 || v != std::floor(v) || v > double(INT32_MAX))
            throw IOError(file_ + ": face " + std::to_string(i) + ": bad vertex index");
          idx_.push_back(int(v));
        }
        add_polygon(s_, idx_, line);
      } else {
        for (int k = 0; k < int(n); ++k) values_.get(pr.type, what);
      }
    }
  }

  const std::string& file_;
  const bool ascii_;
  TextCursor text_;
  BinaryCursor bin_;
  PlyValues values_;
  RawSurface s_;
  bool have_vertex_ = false, have_face_ = false;
  long long nv_ = 0;
  std::vector<int> idx_;
};

RawSurface parse_ply(std::string_view data, const std::string& file) {
  TextCursor h(data, file);
  const PlyHeader hd = parse_ply_header(h, file);
  return PlyBodyReader(data, file, hd).read(hd.elements);
}

// ---------------------------------------------------------------------------------------------
// Checks and repairs

class SurfaceChecker {
 public:
  SurfaceChecker(SurfaceMesh& m, const std::string& name, SurfaceReadReport& r, const std::vector<int>& lines)
      : m_(m), name_(name), r_(r), lines_(lines) {}

  /// Welds exactly duplicate vertices and drops unused ones, checking nothing (a surface passed on
  /// with its defects).
  void weld_only() {
    lenient_ = true;
    weld("the surface has defects");
    drop_unused();
  }

  void run(bool always_weld) {
    if (m_.F.rows() == 0) throw InvalidInput(name_ + ": no triangles");
    check_repeated();
    if (always_weld) weld("STL stores every triangle corner separately");
    drop_unused();
    check_zero_area();
    analyse_edges();
    if (boundary_ > 0 && !welded_ && has_duplicates()) {
      weld("the surface is open without it");
      drop_unused();
      analyse_edges();
    }
    check_closed_manifold();
    check_vertex_manifold();
    orient();
    const Eigen::Index nv = m_.V.rows(), nf = m_.F.rows(), ne = 3 * nf / 2;
    const long long chi = nv - ne + nf;
    r_.vertices = int(nv);
    r_.faces = int(nf);
    r_.genus = int((2 * r_.components - chi) / 2);
  }

 private:
  std::string face(Eigen::Index f) const {
    std::string s = "face " + std::to_string(f);
    if (!lines_.empty()) s += " (line " + std::to_string(lines_[size_t(f)]) + ")";
    return s;
  }
  std::string point(int v) const {
    return "(" + std::to_string(m_.V(v, 0)) + ", " + std::to_string(m_.V(v, 1)) + ", " + std::to_string(m_.V(v, 2)) +
           ")";
  }

  void check_repeated() const {
    if (lenient_) return;
    for (Eigen::Index f = 0; f < m_.F.rows(); ++f) {
      const int a = m_.F(f, 0), b = m_.F(f, 1), c = m_.F(f, 2);
      if (a == b || b == c || a == c)
        throw InvalidInput(name_ + ": " + face(f) + " is degenerate: repeated vertex" +
                           (welded_ ? " after welding duplicate positions" : " index"));
    }
  }

  void check_zero_area() const {
    for (Eigen::Index f = 0; f < m_.F.rows(); ++f) {
      Eigen::Vector3d p0 = m_.V.row(m_.F(f, 0)), p1 = m_.V.row(m_.F(f, 1)), p2 = m_.V.row(m_.F(f, 2));
      const double e = std::max({(p1 - p0).squaredNorm(), (p2 - p1).squaredNorm(), (p0 - p2).squaredNorm()});
      // Zero area up to rounding: sin of the largest angle's complement below 1e-12.
      if ((p1 - p0).cross(p2 - p0).norm() <= 1e-12 * e)
        throw InvalidInput(name_ + ": " + face(f) + " is degenerate: zero area");
    }
  }

  bool has_duplicates() const {
    std::vector<int> order = sorted_vertices();
    for (size_t i = 1; i < order.size(); ++i)
      if (m_.V.row(order[i]) == m_.V.row(order[i - 1])) return true;
    return false;
  }

  std::vector<int> sorted_vertices() const {
    std::vector<int> order(size_t(m_.V.rows()));
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      for (int k = 0; k < 3; ++k)
        if (m_.V(a, k) != m_.V(b, k)) return m_.V(a, k) < m_.V(b, k);
      return a < b;
    });
    return order;
  }

  // Welds vertices at exactly the same position (keeps the first of each group).
  void weld(const std::string& why) {
    std::vector<int> order = sorted_vertices();
    std::vector<int> rep(order.size());
    for (size_t i = 0; i < order.size(); ++i)
      rep[size_t(order[i])] =
          (i > 0 && m_.V.row(order[i]) == m_.V.row(order[i - 1])) ? rep[size_t(order[i - 1])] : order[i];
    int merged = 0;
    for (size_t v = 0; v < rep.size(); ++v) merged += rep[v] != int(v);
    welded_ = true;
    if (merged == 0) return;
    for (Eigen::Index i = 0; i < m_.F.size(); ++i) m_.F.data()[i] = rep[size_t(m_.F.data()[i])];
    r_.welded += merged;
    r_.warnings.push_back(name_ + ": welded " + std::to_string(merged) + " duplicate vertices (" + why + ")");
    check_repeated();
  }

  void drop_unused() {
    std::vector<int> map(size_t(m_.V.rows()), -1);
    for (Eigen::Index i = 0; i < m_.F.size(); ++i) map[size_t(m_.F.data()[i])] = 0;
    int n = 0;
    for (auto& x : map)
      if (x == 0) x = n++;
    const int unused = int(map.size()) - n;
    if (unused == 0) return;
    RowMatrixX3d V(n, 3);
    for (size_t v = 0; v < map.size(); ++v)
      if (map[v] >= 0) V.row(map[v]) = m_.V.row(Eigen::Index(v));
    m_.V = std::move(V);
    for (Eigen::Index i = 0; i < m_.F.size(); ++i) m_.F.data()[i] = map[size_t(m_.F.data()[i])];
    // Welding leaves the merged copies unused; those are counted as welded, not as dropped.
    const int dropped = unused - (r_.welded - welded_counted_);
    welded_counted_ = r_.welded;
    if (dropped > 0) r_.warnings.push_back(name_ + ": dropped " + std::to_string(dropped) + " unused vertices");
  }

  // Sorted undirected edges: boundary / non-manifold counts and the face adjacency.
  void analyse_edges() {
    const Eigen::Index nf = m_.F.rows();
    struct HalfEdge {
      uint64_t key;
      int face;
      int k;
    };
    std::vector<HalfEdge> h(size_t(3 * nf));
    for (Eigen::Index f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        uint32_t a = uint32_t(m_.F(f, k)), b = uint32_t(m_.F(f, (k + 1) % 3));
        h[size_t(3 * f + k)] = {(uint64_t(std::min(a, b)) << 32) | std::max(a, b), int(f), k};
      }
    std::sort(h.begin(), h.end(),
              [](const HalfEdge& x, const HalfEdge& y) { return x.key != y.key ? x.key < y.key : x.face < y.face; });
    nb_.assign(size_t(3 * nf), -1);
    boundary_ = nonmanifold_ = 0;
    example_boundary_ = example_nonmanifold_ = -1;
    for (size_t i = 0; i < h.size();) {
      size_t j = i;
      while (j < h.size() && h[j].key == h[i].key) ++j;
      if (j - i == 1) {
        if (boundary_++ == 0) example_boundary_ = 3 * h[i].face + h[i].k;
      } else if (j - i > 2) {
        if (nonmanifold_++ == 0) example_nonmanifold_ = 3 * h[i].face + h[i].k;
      } else {
        nb_[size_t(3 * h[i].face + h[i].k)] = 3 * h[i + 1].face + h[i + 1].k;
        nb_[size_t(3 * h[i + 1].face + h[i + 1].k)] = 3 * h[i].face + h[i].k;
      }
      i = j;
    }
  }

  std::string edge_at(int he) const {
    const int f = he / 3, k = he % 3;
    return "the edge " + point(m_.F(f, k)) + " - " + point(m_.F(f, (k + 1) % 3)) + " of " + face(f);
  }

  void check_closed_manifold() const {
    if (nonmanifold_ > 0)
      throw InvalidInput(name_ + ": non-manifold: " + std::to_string(nonmanifold_) +
                         " edges are used by more than 2 triangles, e.g. " + edge_at(example_nonmanifold_));
    if (boundary_ > 0)
      throw InvalidInput(name_ + ": surface is not closed: " + std::to_string(boundary_) +
                         " boundary edges (used by only one triangle), e.g. " + edge_at(example_boundary_));
  }

  // The triangles around a vertex must form one fan (its link a single cycle). Corners of two
  // triangles that share an edge are joined at both edge ends; a vertex whose corners end up in more
  // than one set is a pinch point.
  void check_vertex_manifold() const {
    const Eigen::Index nf = m_.F.rows();
    UnionFind uf(size_t(3 * nf));
    for (Eigen::Index he = 0; he < 3 * nf; ++he) {
      const int o = nb_[size_t(he)];
      if (o < he) continue;
      const int f1 = int(he / 3), k1 = int(he % 3), f2 = o / 3, k2 = o % 3;
      // Edge (u, w) at corners k1, k1+1 of f1; in f2 at k2, k2+1 in either direction (the faces
      // are not oriented yet).
      const bool same = m_.F(f1, k1) == m_.F(f2, k2);
      uf.unite(3 * f1 + k1, 3 * f2 + (same ? k2 : (k2 + 1) % 3));
      uf.unite(3 * f1 + (k1 + 1) % 3, 3 * f2 + (same ? (k2 + 1) % 3 : k2));
    }
    std::vector<int> root(size_t(m_.V.rows()), -1);
    for (Eigen::Index c = 0; c < 3 * nf; ++c) {
      const int v = m_.F.data()[c];
      const int r = uf.find(int(c));
      if (root[size_t(v)] < 0)
        root[size_t(v)] = r;
      else if (root[size_t(v)] != r)
        throw InvalidInput(name_ + ": non-manifold vertex " + point(v) +
                           ": its triangles form more than one fan (pinch point), e.g. at " + face(c / 3));
    }
  }

  // Orients every component consistently by BFS over shared edges (keeping the orientation most of
  // its triangles already have), then flips everything if the enclosed signed volume is negative.
  void orient() {
    const Eigen::Index nf = m_.F.rows();
    std::vector<int> comp(size_t(nf), -1);
    std::vector<char> flip(size_t(nf), 0);
    std::vector<int> queue;
    int ncomp = 0;
    long long flipped = 0;
    for (Eigen::Index seed = 0; seed < nf; ++seed) {
      if (comp[size_t(seed)] >= 0) continue;
      queue.assign(1, int(seed));
      comp[size_t(seed)] = ncomp;
      std::vector<int> members;
      for (size_t q = 0; q < queue.size(); ++q) {
        const int f = queue[q];
        members.push_back(f);
        for (int k = 0; k < 3; ++k) {
          const int o = nb_[size_t(3 * f + k)];
          const int g = o / 3, kg = o % 3;
          // Same direction in both triangles = inconsistent: their flips must differ.
          const bool same = m_.F(f, k) == m_.F(g, kg);
          const char want = char(flip[size_t(f)] ^ (same ? 1 : 0));
          if (comp[size_t(g)] < 0) {
            comp[size_t(g)] = ncomp;
            flip[size_t(g)] = want;
            queue.push_back(g);
          } else if (flip[size_t(g)] != want) {
            throw InvalidInput(name_ + ": surface is not orientable (no consistent orientation exists), e.g. at " +
                               face(g));
          }
        }
      }
      size_t n = 0;
      for (int f : members) n += size_t(flip[size_t(f)]);
      if (2 * n > members.size()) {
        for (int f : members) flip[size_t(f)] ^= 1;
        n = members.size() - n;
      }
      flipped += (long long)n;
      ++ncomp;
    }
    for (Eigen::Index f = 0; f < nf; ++f)
      if (flip[size_t(f)]) std::swap(m_.F(f, 1), m_.F(f, 2));
    if (flipped > 0)
      r_.warnings.push_back(name_ + ": oriented consistently: flipped " + std::to_string(flipped) + " of " +
                            std::to_string(nf) + " triangles");
    r_.components = ncomp;
    if (ncomp > 1)
      r_.warnings.push_back(name_ + ": " + std::to_string(ncomp) +
                            " connected components: all are meshed, with edge lengths relative to the whole "
                            "model's bounding box");

    // Signed volume (divergence theorem), about the centroid for accuracy.
    const Eigen::RowVector3d c = m_.V.colwise().mean();
    double vol = 0;
    for (Eigen::Index f = 0; f < nf; ++f) {
      Eigen::Vector3d a = m_.V.row(m_.F(f, 0)) - c, b = m_.V.row(m_.F(f, 1)) - c, d = m_.V.row(m_.F(f, 2)) - c;
      vol += a.dot(b.cross(d)) / 6.0;
    }
    if (vol < 0) {
      for (Eigen::Index f = 0; f < nf; ++f) std::swap(m_.F(f, 1), m_.F(f, 2));
      flipped = nf - flipped;
      r_.warnings.push_back(name_ + ": inward oriented (signed volume " + std::to_string(vol) +
                            "): flipped all triangles to face outward");
    }
    r_.flipped = int(flipped);
  }

  SurfaceMesh& m_;
  const std::string& name_;
  SurfaceReadReport& r_;
  const std::vector<int>& lines_;
  bool welded_ = false, lenient_ = false;
  int welded_counted_ = 0;
  std::vector<int> nb_;  // opposite half-edge (3 f + k) of every half-edge
  int boundary_ = 0, nonmanifold_ = 0, example_boundary_ = -1, example_nonmanifold_ = -1;
};

SurfaceMesh to_mesh(const RawSurface& s, const std::string& source) {
  SurfaceMesh m;
  m.V.resize(Eigen::Index(s.V.size() / 3), 3);
  std::copy(s.V.begin(), s.V.end(), m.V.data());
  m.F.resize(Eigen::Index(s.F.size() / 3), 3);
  std::copy(s.F.begin(), s.F.end(), m.F.data());
  m.source = source;
  return m;
}

}  // namespace

void check_and_repair_surface(SurfaceMesh& mesh, const std::string& name, SurfaceReadReport& report,
                              const std::vector<int>& face_line, bool always_weld) {
  SurfaceChecker(mesh, name, report, face_line).run(always_weld);
}

SurfaceMesh read_surface(const std::filesystem::path& path, SurfaceReadReport* report, bool keep_defects) {
  SurfaceReadReport local;
  SurfaceReadReport& r = report ? *report : local;
  r = SurfaceReadReport{};
  const std::string file = path.string();
  if (file.rfind("shape:", 0) == 0) {
    SurfaceMesh m = make_shape(ShapeParams{file.substr(6)});
    check_and_repair_surface(m, file, r);
    return m;
  }
  const std::string ext = io_detail::lower_extension(path);
  if (ext != ".obj" && ext != ".off" && ext != ".stl" && ext != ".ply")
    throw IOError(file + ": unknown surface extension `" + ext + "` (expected .obj, .off, .stl or .ply)");
  const std::string data = io_detail::load_file(path);
  if (data.find_first_not_of(" \t\r\n") == std::string::npos) throw IOError(file + ": empty file");
  RawSurface raw = ext == ".obj"   ? parse_obj(data, file)
                   : ext == ".off" ? parse_off(data, file)
                   : ext == ".stl" ? parse_stl(data, file)
                                   : parse_ply(data, file);
  if (raw.polygons > 0)
    r.warnings.push_back(file + ": fan-triangulated " + std::to_string(raw.polygons) +
                         " polygons with more than 3 vertices");
  SurfaceMesh m = to_mesh(raw, file);
  if (raw.line.size() * 3 != raw.F.size()) raw.line.clear();
  if (!keep_defects) {
    check_and_repair_surface(m, file, r, raw.line, ext == ".stl");
    return m;
  }
  SurfaceMesh checked = m;
  SurfaceReadReport checked_report = r;
  try {
    check_and_repair_surface(checked, file, checked_report, raw.line, ext == ".stl");
    r = std::move(checked_report);
    return checked;
  } catch (const InvalidInput& e) {
    SurfaceChecker(m, file, r, {}).weld_only();
    r.defects.push_back(e.what());
    r.vertices = int(m.V.rows());
    r.faces = int(m.F.rows());
    return m;
  }
}

void write_surface(const SurfaceMesh& mesh, const std::filesystem::path& path, const CellData& cell_data) {
  const std::string ext = io_detail::lower_extension(path);
  const Eigen::Index nv = mesh.V.rows(), nf = mesh.F.rows();
  std::string out;
  out.reserve(size_t(nv) * 60 + size_t(nf) * 30 + 256);
  auto append_xyz = [&](Eigen::Index v) {
    for (int k = 0; k < 3; ++k) {
      out += ' ';
      io_detail::append_double(out, mesh.V(v, k));
    }
  };
  // One line per triangle: `head a b c` with indices from `base`.
  auto append_faces = [&](char head, int base) {
    for (Eigen::Index f = 0; f < nf; ++f) {
      out += head;
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        io_detail::append_int(out, mesh.F(f, k) + base);
      }
      out += '\n';
    }
  };
  if (ext == ".obj") {
    out += "# polyhex surface: " + std::to_string(nv) + " vertices, " + std::to_string(nf) + " triangles\n";
    for (Eigen::Index v = 0; v < nv; ++v) {
      out += 'v';
      append_xyz(v);
      out += '\n';
    }
    append_faces('f', 1);
  } else if (ext == ".off") {
    out += "OFF\n" + std::to_string(nv) + " " + std::to_string(nf) + " 0\n";
    for (Eigen::Index v = 0; v < nv; ++v) {
      append_xyz(v);
      out += '\n';
    }
    append_faces('3', 0);
  } else if (ext == ".vtk") {
    io_detail::append_vtk_header(out, "polyhex surface", false, "POLYDATA");
    io_detail::append_vtk_points(out, mesh.V, false);
    out += "POLYGONS " + std::to_string(nf) + " " + std::to_string(4 * nf) + "\n";
    append_faces('3', 0);
    io_detail::append_vtk_cell_data(out, cell_data, nf, false, path.string());
  } else {
    throw IOError(path.string() + ": unknown surface extension `" + ext + "` (expected .obj, .off or .vtk)");
  }
  io_detail::write_buffer(path, out, false);
}

}  // namespace polyhex
