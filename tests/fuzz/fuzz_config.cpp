// libFuzzer target: the config path of `polyhex run`: load_config_json (JSON parse + ${var}
// substitution), parse_config, Pipeline::build (node types, params, ports, cycles). The registry holds
// the reader/writer and shape nodes linked into this target plus `fuzz/params`, a node with one param
// of every kind and two ports, so params and port checks are reached with every type.
#include "graph/config.h"
#include "graph/node.h"
#include "graph/pipeline.h"
#include "runtime/errors.h"
#include "tests/fuzz/fuzz_common.h"

#include <cstddef>
#include <cstdint>

namespace {

struct FuzzParams {
  double x = 1;              ///< a number in [0, 10]
  int n = 3;                 ///< an integer in [1, 100]
  bool flag = false;         ///< a boolean
  std::string name = "a";    ///< any string
  std::string mode = "one";  ///< one of: one, two
};

const bool registered = polyhex::register_node(polyhex::make_node<FuzzParams>(
    "fuzz/params", "every param kind and two ports (fuzzing only)",
    polyhex::ParamSet<FuzzParams>()
        .add("x", &FuzzParams::x, "number", 0.0, 10.0)
        .add("n", &FuzzParams::n, "integer", 1, 100)
        .add("flag", &FuzzParams::flag, "boolean")
        .add("name", &FuzzParams::name, "string")
        .add_choice("mode", &FuzzParams::mode, {"one", "two"}, "choice"),
    {{"surface", polyhex::artefact_name<polyhex::SurfaceMesh>()},
     {"tets", polyhex::artefact_name<polyhex::TetMesh>(), true}},
    polyhex::artefact_name<polyhex::HexMesh>(),
    [](const FuzzParams&, const polyhex::Inputs&, polyhex::NodeContext&) -> polyhex::Artefact {
      throw polyhex::Error("fuzz/params is never run");
    }));

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path =
      polyhex_fuzz::write_scratch("config.json", std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    polyhex::json j = polyhex::load_config_json(path, {{"input", "in.off"}});
    polyhex::PipelineConfig cfg = polyhex::parse_config(j, path.string());
    polyhex::Pipeline p = polyhex::Pipeline::build(cfg);
    (void)p.dot();
  } catch (const polyhex::Error&) {
  }
  return 0;
}
