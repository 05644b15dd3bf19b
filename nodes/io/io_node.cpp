/// @file io_node.cpp
/// @brief Bindings of the mesh readers and writers (`read_surface`, `read_tetmesh`, `write_hex`,
/// `write_tetmesh`) and the --save-all savers of SurfaceMesh, TetMesh and HexMesh.
#include "graph/node.h"
#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/surface_io.h"
#include "nodes/formats/tetmesh_io.h"

#include <filesystem>
#include <memory>
#include <type_traits>

namespace polyhex {
namespace {

struct ReadSurfaceParams {
  std::string path;  ///< .obj .off .stl .ply file, or `shape:NAME` for a built-in shape
};
struct ReadTetmeshParams {
  std::string path;  ///< .mesh .vtk .msh .node/.ele file
};
struct WriteHexParams {
  std::string path = "hex.vtk";  ///< output file; a relative path is relative to the output folder
  std::string format = "auto";   ///< auto (by extension) | vtk | vtk_binary | mesh | msh | exodus | abaqus
};
struct WriteTetmeshParams {
  std::string path = "tets.vtk";  ///< output file; a relative path is relative to the output folder
  std::string format = "auto";    ///< auto (by extension) | vtk | vtk_binary | mesh | msh
};

const std::vector<std::string> kFormats = {"auto", "vtk", "vtk_binary", "mesh", "msh"};
const std::vector<std::string> kHexFormats = {"auto", "vtk", "vtk_binary", "mesh", "msh", "exodus", "abaqus"};

void require_path(const std::string& path) {
  if (path.empty()) throw InvalidInput("param `path` is empty: give a mesh file (or shape:NAME for a surface)");
}

// Resolves an output path against the run's output folder and creates its folder.
std::filesystem::path output_path(const std::string& path, const NodeContext& ctx) {
  require_path(path);
  std::filesystem::path p(path);
  if (p.is_relative()) p = ctx.out_dir / p;
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
  return p;
}

// The files a reader reads, for the cache key: `path` (none for shape:NAME); a TetGen .node/.ele pair both.
std::vector<std::filesystem::path> reader_files(const json& params) {
  std::string path = params.value("path", "");
  if (path.empty() || path.rfind("shape:", 0) == 0) return {};
  std::filesystem::path p(path);
  if (p.extension() == ".node" || p.extension() == ".ele")
    return {std::filesystem::path(p).replace_extension(".node"), std::filesystem::path(p).replace_extension(".ele")};
  return {p};
}

const bool registered_read_surface = register_node(
    make_node<ReadSurfaceParams>(
        "read_surface",
        "Reads a triangle surface (OBJ, OFF, STL, PLY, or shape:NAME); checks it, makes the safe repairs, and passes "
        "a defective one on to the conditioning with a warning",
        ParamSet<ReadSurfaceParams>().add("path", &ReadSurfaceParams::path, "surface file, or shape:NAME"), {},
        artefact_name<SurfaceMesh>(),
        [](const ReadSurfaceParams& p, const Inputs&, NodeContext& ctx) {
          require_path(p.path);
          SurfaceReadReport r;
          SurfaceMesh m = read_surface(p.path, &r, /*keep_defects=*/true);
          ctx.metrics["vertices"] = r.vertices;
          ctx.metrics["faces"] = r.faces;
          ctx.metrics["welded"] = r.welded;
          ctx.metrics["flipped"] = r.flipped;
          ctx.metrics["genus"] = r.genus;
          ctx.metrics["components"] = r.components;
          ctx.metrics["defects"] = r.defects;
          for (auto& w : r.warnings) ctx.warn(w);
          for (auto& d : r.defects)
            ctx.warn(d + "; passed on as read (a condition_surface node repairs it; tetrahedralize refuses it)");
          return make_artefact(std::move(m));
        })
        .with_input_files(reader_files)
        .with_version("2"));  // 2: defective surfaces passed on

const bool registered_read_tetmesh = register_node(
    make_node<ReadTetmeshParams>("read_tetmesh",
                                 "Reads a tet mesh (Medit .mesh, legacy VTK, Gmsh .msh 2.2/4.1, TetGen .node/.ele)",
                                 ParamSet<ReadTetmeshParams>().add("path", &ReadTetmeshParams::path, "tet mesh file"),
                                 {}, artefact_name<TetMesh>(),
                                 [](const ReadTetmeshParams& p, const Inputs&, NodeContext& ctx) {
                                   require_path(p.path);
                                   TetReadReport r;
                                   TetMesh m = read_tetmesh(p.path, &r);
                                   ctx.metrics["vertices"] = r.vertices;
                                   ctx.metrics["tets"] = r.tets;
                                   ctx.metrics["reoriented"] = r.reoriented;
                                   for (auto& w : r.warnings) ctx.warn(w);
                                   return make_artefact(std::move(m));
                                 })
        .with_input_files(reader_files));

// write_hex and write_tetmesh: the same sink for a mesh type M written by `write`.
template <class M, class P>
NodeSpec writer_node(const std::string& type, const std::string& what, const std::vector<std::string>& formats,
                     const std::string& formats_text,
                     void (*write)(const M&, const std::filesystem::path&, const std::string&, const CellData&)) {
  std::string choices;
  for (const auto& f : formats) choices += (choices.empty() ? "" : ", ") + (f == "auto" ? "auto (by extension)" : f);
  return make_node<P>(type, "Writes the " + what + " mesh (" + formats_text + ")",
                      ParamSet<P>()
                          .add("path", &P::path, "output file, relative to the output folder")
                          .add_choice("format", &P::format, formats, choices),
                      {{"mesh", artefact_name<M>()}}, "", [write](const P& p, const Inputs& in, NodeContext& ctx) {
                        const auto out = output_path(p.path, ctx);
                        const auto mesh = in.get<M>(0);
                        write(*mesh, out, p.format, CellData{});
                        ctx.metrics["path"] = out.string();
                        ctx.metrics["bytes"] = std::filesystem::file_size(out);
                        if constexpr (std::is_same_v<M, HexMesh>) ctx.metrics["groups"] = mesh->groups.size();
                        return Artefact{};
                      });
}

const bool registered_write_hex = register_node(writer_node<HexMesh, WriteHexParams>(
    "write_hex", "hex", kHexFormats,
    "legacy VTK ASCII/binary, Medit .mesh, Gmsh .msh 4.1, Exodus II .e/.exo, Abaqus .inp; with its boundary groups",
    &write_hexmesh));
const bool registered_write_tetmesh = register_node(writer_node<TetMesh, WriteTetmeshParams>(
    "write_tetmesh", "tet", kFormats, "legacy VTK ASCII/binary, Medit .mesh, Gmsh .msh 4.1", &write_tetmesh));

const bool registered_savers = [] {
  auto& reg = Registry::instance();
  reg.add_saver(artefact_name<SurfaceMesh>(), ".obj",
                [](const Artefact& a, const std::filesystem::path& p) { write_surface(*a.as<SurfaceMesh>(), p); });
  reg.add_saver(artefact_name<TetMesh>(), ".vtk",
                [](const Artefact& a, const std::filesystem::path& p) { write_tetmesh(*a.as<TetMesh>(), p, "vtk"); });
  reg.add_saver(artefact_name<HexMesh>(), ".vtk",
                [](const Artefact& a, const std::filesystem::path& p) { write_hexmesh(*a.as<HexMesh>(), p, "vtk"); });
  auto add_turner = [&reg](auto tag) {
    using M = decltype(tag);
    reg.add_turner(artefact_name<M>(), [](const Artefact& a, const RigidFrame& f) {
      M m = *a.as<M>();
      m.V = f.apply(m.V);
      return make_artefact(std::move(m));
    });
  };
  add_turner(SurfaceMesh{});
  add_turner(TetMesh{});
  add_turner(HexMesh{});
  return true;
}();

}  // namespace
}  // namespace polyhex
