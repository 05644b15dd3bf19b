#include "tools/commands.h"

#include <cstdio>
#include <iostream>

#include "nodes/io/hexmesh_io.h"
#include "nodes/io/surface_io.h"
#include "nodes/quality/quality_json.h"
#include "nodes/shapes/shapes.h"

namespace polyhex {

void add_extra_commands(CLI::App& app, CommandOptions& o) {
  o.check = app.add_subcommand("check", "quality of a hex mesh (.vtk/.mesh), optionally against its input surface");
  o.check->add_option("mesh", o.check_mesh, "hex mesh file (.vtk legacy ASCII/BINARY or Medit .mesh)")->required();
  o.check->add_option("--surface", o.check_surface, "input surface (.obj .off .stl .ply) for Hausdorff distances");
  o.check->add_option("--samples", o.check_samples, "surface samples per side for the distances")->check(CLI::Range(100, 10000000));
  o.check->add_flag("--json", o.check_json, "print the figures as JSON (keys as hexcheck.py --json)");

  std::string names;
  for (auto& n : shape_names()) names += (names.empty() ? "" : ", ") + n;
  o.shapes = app.add_subcommand("shapes", "write a built-in closed surface: " + names);
  o.shapes->add_option("name", o.shape_name, "shape name")->required();
  o.shapes->add_option("--out,-o", o.shape_out, "output surface file (.obj .off .vtk)")->required();
  o.shapes->add_option("--resolution", o.shape_resolution, "samples along the longest side")->check(CLI::Range(8, 512));
}

int run_extra_commands(const CLI::App& app, const CommandOptions& o) {
  if (*o.check) {
    HexMesh mesh = read_hexmesh(o.check_mesh);
    SurfaceMesh surface;
    if (!o.check_surface.empty()) surface = read_surface(o.check_surface);
    QualityParams qp;
    qp.samples = o.check_samples;
    HexQuality q = hex_quality(mesh, o.check_surface.empty() ? nullptr : &surface, qp);
    nlohmann::json j = to_json(q);
    if (o.check_json) {
      std::cout << j.dump() << "\n";
    } else {
      for (auto it = j.begin(); it != j.end(); ++it) std::printf("%-32s %s\n", it.key().c_str(), it.value().dump().c_str());
    }
    return q.inverted > 0 ? 3 : 0;
  }
  if (*o.shapes) {
    ShapeParams p;
    p.name = o.shape_name;
    p.resolution = o.shape_resolution;
    SurfaceMesh m = make_shape(p);
    write_surface(m, o.shape_out);
    std::fprintf(stderr, "polyhex: wrote %s (%ld vertices, %ld triangles)\n", o.shape_out.c_str(), long(m.V.rows()),
                 long(m.F.rows()));
    return 0;
  }
  return 2;
}

}  // namespace polyhex
