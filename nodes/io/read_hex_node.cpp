/// @file read_hex_node.cpp
/// @brief Binding of `read_hex`: reads a hex mesh file (to rerun the late stages, e.g. optimize, on a saved mesh).
#include "graph/node.h"
#include "nodes/formats/hexmesh_io.h"

#include <filesystem>

namespace polyhex {
namespace {

struct ReadHexParams {
  std::string path;  ///< .vtk .mesh .msh hex mesh file
};

const bool registered = register_node(
    make_node<ReadHexParams>(
        "read_hex", "Reads a hex mesh (legacy VTK cell type 12, Medit .mesh Hexahedra, Gmsh .msh type 5)",
        ParamSet<ReadHexParams>().add("path", &ReadHexParams::path, "hex mesh file"), {}, artefact_name<HexMesh>(),
        [](const ReadHexParams& p, const Inputs&, NodeContext& ctx) {
          if (p.path.empty()) throw InvalidInput("param `path` is empty: give a hex mesh file");
          HexReadReport r;
          HexMesh m = read_hexmesh(p.path, &r);
          ctx.metrics["vertices"] = r.vertices;
          ctx.metrics["hexes"] = r.hexes;
          for (auto& w : r.warnings) ctx.warn(w);
          return make_artefact(std::move(m));
        })
        .with_input_files([](const json& params) -> std::vector<std::filesystem::path> {
          const std::string path = params.value("path", "");
          if (path.empty()) return {};
          return {std::filesystem::path(path)};
        }));

}  // namespace
}  // namespace polyhex
