#include "tools/commands.h"

#include "nodes/algorithms/shapes.h"
#include "nodes/formats/hexmesh_io.h"
#include "nodes/formats/surface_io.h"
#include "nodes/quality/quality_json.h"

#include <cstdio>
#include <iostream>
#include <memory>

namespace polyhex {

CommandEnv& command_env() {
  static CommandEnv env;
  return env;
}

namespace {
std::vector<CommandModule>& modules() {
  static std::vector<CommandModule> m;
  return m;
}
}  // namespace

bool register_commands(CommandModule module) {
  modules().push_back(std::move(module));
  return true;
}

const std::vector<CommandModule>& command_modules() { return modules(); }

namespace {

// `polyhex check` (the quality node alone on a mesh file) and `polyhex shapes` (a built-in shape).
struct CheckOptions {
  std::string mesh, surface;
  bool json = false;
  int samples = 100000;
};
struct ShapeOptions {
  std::string name, out;
  int resolution = 64;
};

int run_check(const CheckOptions& o) {
  HexMesh mesh = read_hexmesh(o.mesh);
  SurfaceMesh surface;
  // The original as the user has it, defects and all (an open input: one-sided distances).
  if (!o.surface.empty()) surface = read_surface(o.surface, nullptr, /*keep_defects=*/true);
  QualityParams qp;
  qp.samples = o.samples;
  HexQuality q = hex_quality(mesh, o.surface.empty() ? nullptr : &surface, qp);
  nlohmann::json j = to_json(q);
  j.update(feature_json(q));  // beyond hexcheck's keys, as the quality node reports them
  if (o.json) {
    std::cout << j.dump() << "\n";
  } else {
    for (auto it = j.begin(); it != j.end(); ++it)
      std::printf("%-32s %s\n", it.key().c_str(), it.value().dump().c_str());
  }
  return q.inverted > 0 ? 3 : 0;
}

int run_shapes(const ShapeOptions& o) {
  ShapeParams p;
  p.name = o.name;
  p.resolution = o.resolution;
  SurfaceMesh m = make_shape(p);
  write_surface(m, o.out);
  std::fprintf(stderr, "polyhex: wrote %s (%ld vertices, %ld triangles)\n", o.out.c_str(), long(m.V.rows()),
               long(m.F.rows()));
  return 0;
}

const bool registered = register_commands([](CLI::App& app, std::vector<Command>& out) {
  auto c = std::make_shared<CheckOptions>();
  CLI::App* check =
      app.add_subcommand("check", "quality of a hex mesh (.vtk/.mesh), optionally against its input surface");
  check->add_option("mesh", c->mesh, "hex mesh file (.vtk legacy ASCII/BINARY or Medit .mesh)")->required();
  check->add_option("--surface", c->surface, "input surface (.obj .off .stl .ply) for Hausdorff distances");
  check->add_option("--samples", c->samples, "surface samples per side for the distances")
      ->check(CLI::Range(100, 10000000));
  check->add_flag("--json", c->json, "print the figures as JSON (keys as hexcheck.py --json)");
  out.push_back({check, [c] { return run_check(*c); }});

  auto s = std::make_shared<ShapeOptions>();
  std::string names;
  for (auto& n : shape_names()) names += (names.empty() ? "" : ", ") + n;
  CLI::App* shapes = app.add_subcommand("shapes", "write a built-in closed surface: " + names);
  shapes->add_option("name", s->name, "shape name")->required();
  shapes->add_option("--out,-o", s->out, "output surface file (.obj .off .vtk)")->required();
  shapes->add_option("--resolution", s->resolution, "samples along the longest side")->check(CLI::Range(8, 512));
  out.push_back({shapes, [s] { return run_shapes(*s); }});
});

}  // namespace
}  // namespace polyhex
