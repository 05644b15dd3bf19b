/// @file node.h
/// @brief The node contract: artefacts, typed params, node specs and the registry.
///
/// A node = a plain params struct with in-class defaults + a pure compute function (in
/// `nodes/<stage>/<stage>.h`, no JSON, no TBB) + a thin binding (`<stage>_node.cpp`) that declares
/// the params with ParamSet, the input ports and the output artefact type, and registers itself:
///
/// @code
///   namespace {
///   const bool registered = polyhex::register_node(polyhex::make_node<TetgenParams>(
///       "tetrahedralize/tetgen", "TetGen isotropic tet mesh of a closed surface",
///       polyhex::ParamSet<TetgenParams>()
///           .add("edge_length", &TetgenParams::edge_length, "target edge, fraction of bbox diagonal", 1e-4, 0.5),
///       {{"surface", polyhex::artefact_name<SurfaceMesh>()}},
///       polyhex::artefact_name<TetMesh>(),
///       [](const TetgenParams& p, const polyhex::Inputs& in, polyhex::NodeContext& ctx) {
///         auto out = tetrahedralize(*in.get<SurfaceMesh>(0), p);
///         ctx.metrics["tets"] = out.T.rows();
///         return polyhex::make_artefact(std::make_shared<const TetMesh>(std::move(out)));
///       }));
///   }
/// @endcode
#pragma once

#include "nodes/artefacts/frames.h"
#include "nodes/artefacts/meshes.h"
#include "runtime/cancel.h"
#include "runtime/errors.h"
#include "runtime/progress.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <iosfwd>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace polyhex {

using json = nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Artefacts

/// The name of an artefact type as it appears in port declarations and error messages.
/// Specialise ArtefactName for every artefact type that flows through the graph.
template <class T>
struct ArtefactName;
template <>
struct ArtefactName<SurfaceMesh> {
  static constexpr const char* value = "SurfaceMesh";
};
template <>
struct ArtefactName<TetMesh> {
  static constexpr const char* value = "TetMesh";
};
template <>
struct ArtefactName<HexMesh> {
  static constexpr const char* value = "HexMesh";
};

template <class T>
std::string artefact_name() {
  return ArtefactName<T>::value;
}

/// A type-erased, immutable artefact: its type name and the shared data.
struct Artefact {
  std::string type;                  ///< ArtefactName of the data, "" for none (sink nodes)
  std::shared_ptr<const void> data;  ///< the data, null for none

  /// \pre type == artefact_name<T>()   \throw Error when the type does not match
  template <class T>
  std::shared_ptr<const T> as() const {
    if (type != ArtefactName<T>::value)
      throw Error("artefact of type `" + type + "` used as `" + ArtefactName<T>::value + "`");
    return std::static_pointer_cast<const T>(data);
  }
  explicit operator bool() const { return data != nullptr; }
};

template <class T>
Artefact make_artefact(std::shared_ptr<const T> p) {
  return Artefact{ArtefactName<T>::value, std::move(p)};
}
template <class T>
Artefact make_artefact(T&& value) {
  using U = std::decay_t<T>;
  return Artefact{ArtefactName<U>::value, std::make_shared<const U>(std::forward<T>(value))};
}

/// The inputs of one node, in port order. An optional port that is not connected is empty.
struct Inputs {
  std::vector<Artefact> items;
  /// \throw Error when port i is not connected or holds another type
  template <class T>
  std::shared_ptr<const T> get(size_t i) const {
    if (i >= items.size() || !items[i]) throw Error("input port " + std::to_string(i) + " is not connected");
    return items[i].as<T>();
  }
  bool has(size_t i) const { return i < items.size() && bool(items[i]); }
};

// ---------------------------------------------------------------------------------------------
// Run context

/// What a node body may touch besides its inputs: metrics and warnings for the report, the output
/// folder (for nodes that write files or intermediate artefacts), progress.
struct NodeContext {
  std::string id;                     ///< node id from the config
  std::string type;                   ///< full type, "stage/variant"
  std::filesystem::path out_dir;      ///< output folder of the run (exists)
  bool save_all = false;              ///< --save-all: nodes may also write intermediate meshes
  json metrics = json::object();      ///< node-specific figures, copied into report.json
  std::vector<std::string> warnings;  ///< repairs and fallbacks, copied into report.json
  ProgressFn on_progress;             ///< may be empty
  /// Set by a node whose output is in another frame than its inputs (NodeSpec::frame_role enters): the
  /// frame, against its inputs' frame. --save-all turns the outputs of it and of everything downstream of it
  /// back.
  std::optional<RigidFrame> frame;
  /// The frame the node's inputs are in, against the input file's (set by the runtime downstream of a node
  /// that enters a frame: the canonical frame, a branch of the orientation search, or both; none = the
  /// input's frame). A node that writes side files writes positions through in_input_frame.
  std::optional<RigidFrame> input_frame;
  /// V (#V by 3 positions in the inputs' frame) in the input's frame, for side files.
  RowMatrixX3d in_input_frame(const RowMatrixX3d& V) const { return input_frame ? input_frame->inverse().apply(V) : V; }

  void warn(const std::string& w) { warnings.push_back(w); }
  /// Reports progress and is a cancellation point: \throw Interrupted after SIGINT/SIGTERM.
  void progress(double fraction, const std::string& what = {}) const {
    throw_if_interrupted();
    if (on_progress) on_progress(fraction, what);
  }
  /// progress() as the callback of a compute function (valid while this context lives).
  ProgressFn progress_fn() const {
    return [this](double fraction, const std::string& what) { progress(fraction, what); };
  }
};

// ---------------------------------------------------------------------------------------------
// Params

/// Description of one parameter, for validation, `--help`, DOT and the README.
struct ParamInfo {
  std::string name;
  std::string kind;  ///< "number", "integer", "boolean", "string"
  json default_value;
  std::string doc;
  std::optional<double> lo, hi;      ///< inclusive numeric range
  std::vector<std::string> choices;  ///< allowed strings, empty = any
};

/// The JSON names of an enum's values, declared once: a param's choices (ParamSet::add_enum) and any
/// report of the value (a node's metrics) read the same list.
template <class E>
class EnumNames {
 public:
  EnumNames(std::initializer_list<std::pair<E, std::string>> entries) : entries_(entries) {}
  /// The name of e, "" if e is not named.
  const std::string& name(E e) const {
    static const std::string none;
    for (const auto& [value, n] : entries_)
      if (value == e) return n;
    return none;
  }
  /// The value named `n`, nullptr if none is.
  const E* value(const std::string& n) const {
    for (const auto& entry : entries_)
      if (entry.second == n) return &entry.first;
    return nullptr;
  }
  const std::vector<std::pair<E, std::string>>& entries() const { return entries_; }

 private:
  std::vector<std::pair<E, std::string>> entries_;
};

/// Declares the fields of a params struct P by name: the same names are the JSON keys, the
/// `--set id.name=value` and sweep paths, and part of the cache key.
template <class P>
class ParamSet {
 public:
  template <class F>
  ParamSet& add(const std::string& name, F P::*member, const std::string& doc, std::optional<double> lo = std::nullopt,
                std::optional<double> hi = std::nullopt) {
    static_assert(std::is_same_v<F, double> || std::is_same_v<F, int> || std::is_same_v<F, bool> ||
                      std::is_same_v<F, std::string>,
                  "params are double, int, bool or std::string");
    ParamInfo info;
    info.name = name;
    info.doc = doc;
    info.lo = lo;
    info.hi = hi;
    if constexpr (std::is_same_v<F, double>) info.kind = "number";
    if constexpr (std::is_same_v<F, int>) info.kind = "integer";
    if constexpr (std::is_same_v<F, bool>) info.kind = "boolean";
    if constexpr (std::is_same_v<F, std::string>) info.kind = "string";
    info.default_value = P{}.*member;
    fields_.push_back(Field{info, [member](P& p, const json& v) { p.*member = v.get<F>(); },
                            [member](const P& p) { return json(p.*member); }});
    return *this;
  }
  /// A string param restricted to a list of choices.
  ParamSet& add_choice(const std::string& name, std::string P::*member, std::vector<std::string> choices,
                       const std::string& doc) {
    add(name, member, doc);
    fields_.back().info.choices = std::move(choices);
    return *this;
  }

  /// An enum param, declared once: `names` pairs each value with its JSON name. The JSON holds the name,
  /// the check lists the names, and the params struct holds the value.
  /// \pre the struct's default is one of the values named
  template <class E>
  ParamSet& add_enum(const std::string& name, E P::*member, EnumNames<E> names, const std::string& doc) {
    static_assert(std::is_enum_v<E>, "add_enum takes an enum member");
    ParamInfo info;
    info.name = name;
    info.doc = doc;
    info.kind = "string";
    for (const auto& entry : names.entries()) info.choices.push_back(entry.second);
    info.default_value = names.name(P{}.*member);
    fields_.push_back(Field{info,
                            [member, names](P& p, const json& v) {
                              if (const E* e = names.value(v.get<std::string>())) p.*member = *e;
                            },
                            [member, names](const P& p) { return json(names.name(p.*member)); }});
    return *this;
  }

  std::vector<ParamInfo> info() const {
    std::vector<ParamInfo> out;
    for (auto& f : fields_) out.push_back(f.info);
    return out;
  }

  /// Params from JSON (missing keys keep their defaults).
  /// \throw ConfigError on an unknown key, a wrong JSON type, a value out of range or not a choice;
  ///        the message names the node and lists the valid keys.
  P parse(const json& j, const std::string& where) const {
    P p{};
    if (j.is_null()) return p;
    if (!j.is_object()) throw ConfigError(where + ": `params` must be an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
      const Field* f = find(it.key());
      if (!f) throw ConfigError(where + ": unknown param `" + it.key() + "`; valid params: " + names());
      check(f->info, it.value(), where);
      f->set(p, it.value());
    }
    return p;
  }
  /// Canonical JSON of all params (every key, defaults filled in).
  json to_json(const P& p) const {
    json j = json::object();
    for (auto& f : fields_) j[f.info.name] = f.get(p);
    return j;
  }
  std::string names() const {
    std::string s;
    for (auto& f : fields_) s += (s.empty() ? "" : ", ") + f.info.name;
    return s.empty() ? "(none)" : s;
  }

 private:
  struct Field {
    ParamInfo info;
    std::function<void(P&, const json&)> set;
    std::function<json(const P&)> get;
  };
  const Field* find(const std::string& n) const {
    for (auto& f : fields_)
      if (f.info.name == n) return &f;
    return nullptr;
  }
  static void check(const ParamInfo& info, const json& v, const std::string& where) {
    const std::string what = where + ": param `" + info.name + "` ";
    if (info.kind == "number" && !v.is_number()) throw ConfigError(what + "must be a number, got " + v.dump());
    if (info.kind == "integer" && !v.is_number_integer())
      throw ConfigError(what + "must be an integer, got " + v.dump());
    if (info.kind == "boolean" && !v.is_boolean()) throw ConfigError(what + "must be true or false, got " + v.dump());
    if (info.kind == "string" && !v.is_string()) throw ConfigError(what + "must be a string, got " + v.dump());
    if (v.is_number()) {
      double x = v.get<double>();
      if ((info.lo && x < *info.lo) || (info.hi && x > *info.hi) || x != x) {
        std::string range = "[" + (info.lo ? json(*info.lo).dump() : std::string("-inf")) + ", " +
                            (info.hi ? json(*info.hi).dump() : std::string("inf")) + "]";
        throw ConfigError(what + "= " + v.dump() + " is out of range " + range);
      }
    }
    if (!info.choices.empty()) {
      auto s = v.get<std::string>();
      bool ok = false;
      std::string list;
      for (auto& c : info.choices) {
        ok = ok || c == s;
        list += (list.empty() ? "" : ", ") + c;
      }
      if (!ok) throw ConfigError(what + "= \"" + s + "\" is not one of: " + list);
    }
  }
  std::vector<Field> fields_;
};

// ---------------------------------------------------------------------------------------------
// Node specs and the registry

struct PortSpec {
  std::string name;           ///< port name, used in `inputs` of the config
  std::string artefact_type;  ///< ArtefactName expected
  bool optional = false;
};

/// Everything the graph builder needs to know about a node type.
struct NodeSpec {
  std::string type;  ///< "stage/variant"
  std::string doc;
  std::vector<PortSpec> inputs;
  std::string output;  ///< ArtefactName produced, "" for a sink
  std::vector<ParamInfo> params;
  /// Validate params JSON, return the canonical JSON (all keys). \throw ConfigError
  std::function<json(const json& params, const std::string& where)> check_params;
  /// Run on canonical params. Exceptions propagate to the runtime which wraps them in NodeError.
  std::function<Artefact(const json& params, const Inputs& in, NodeContext& ctx)> run;
  /// Files the node reads besides its inputs (e.g. a reader's `path`), given its canonical params: their
  /// contents are part of the cache key. Empty function = none.
  std::function<std::vector<std::filesystem::path>(const json& params)> input_files;
  /// Code version of the node, part of its cache key: bump it when the algorithm's output changes.
  std::string version = "1";
  /// The node may return no artefact (an empty Artefact): it has nothing to do in this run (a branch
  /// without a candidate frame). Its dependants are then skipped: each node with a required input from
  /// a skipped node is not run, produces nothing and is reported as skipped; an optional port from a
  /// skipped node is left unconnected. Empty results are not cached.
  bool may_skip = false;
  /// How the node's output relates to the input's frame (the canonical frame and the orientation search,
  /// nodes/orient): `keeps` the frame of its inputs, `enters` a candidate's frame (it sets
  /// NodeContext::frame, against its inputs' frame), `leaves` it (its output is in the frame of its Frames
  /// input again: the input's, or the canonical frame for a branch's mesh). --save-all writes every artefact
  /// in the input's frame.
  enum class FrameRole { keeps, enters, leaves } frame_role = FrameRole::keeps;
  std::string stage() const { return type.substr(0, type.find('/')); }
  /// `register_node(make_node<P>(...).with_version("2"))`
  NodeSpec with_version(std::string v) && {
    version = std::move(v);
    return std::move(*this);
  }
  NodeSpec with_frame_role(FrameRole r) && {
    frame_role = r;
    return std::move(*this);
  }
  NodeSpec with_may_skip() && {
    may_skip = true;
    return std::move(*this);
  }
  NodeSpec with_input_files(std::function<std::vector<std::filesystem::path>(const json&)> f) && {
    input_files = std::move(f);
    return std::move(*this);
  }
};

template <class P>
NodeSpec make_node(std::string type, std::string doc, ParamSet<P> params, std::vector<PortSpec> inputs,
                   std::string output, std::function<Artefact(const P&, const Inputs&, NodeContext&)> body) {
  NodeSpec s;
  s.type = std::move(type);
  s.doc = std::move(doc);
  s.inputs = std::move(inputs);
  s.output = std::move(output);
  s.params = params.info();
  auto ps = std::make_shared<ParamSet<P>>(std::move(params));
  s.check_params = [ps](const json& j, const std::string& where) { return ps->to_json(ps->parse(j, where)); };
  s.run = [ps, body](const json& j, const Inputs& in, NodeContext& ctx) { return body(ps->parse(j, ctx.id), in, ctx); };
  return s;
}

/// Writes an artefact to a file (used by --save-all). \throw IOError
using ArtefactSaver = std::function<void(const Artefact&, const std::filesystem::path&)>;

/// An artefact with every position x replaced by f.R (x - f.centre), for --save-all of artefacts built in
/// another frame. \pre f.R is a rotation
using ArtefactTurner = std::function<Artefact(const Artefact&, const RigidFrame& f)>;

/// Binary serialisation of one artefact type, for the artefact cache. `version` is the format
/// version of the payload: bump it when the layout changes (older cache entries are then ignored).
struct ArtefactCodec {
  std::uint32_t version = 1;
  std::function<void(const Artefact&, std::ostream&)> write;  ///< \throw IOError
  std::function<Artefact(std::istream&)> read;                ///< \throw IOError on malformed data
};

class Registry {
 public:
  static Registry& instance();
  /// \throw Error when the type is registered twice
  void add(NodeSpec spec);
  /// Finds "stage/variant"; a bare "stage" resolves to its first-registered variant when it has
  /// exactly one, or to the variant registered as default. Returns null when unknown.
  const NodeSpec* find(const std::string& type) const;
  /// Every registered "stage/variant", sorted.
  std::vector<std::string> types() const;
  /// Savers for --save-all, by artefact type; `ext` includes the dot.
  void add_saver(const std::string& artefact_type, const std::string& ext, ArtefactSaver saver);
  /// \return {ext, saver} or nullptr saver when none is registered
  std::pair<std::string, ArtefactSaver> saver(const std::string& artefact_type) const;
  void set_default_variant(const std::string& stage, const std::string& variant);
  /// Turners by artefact type (for --save-all in branches of the orientation search).
  void add_turner(const std::string& artefact_type, ArtefactTurner turner);
  /// \return the turner, or null when none is registered
  const ArtefactTurner* turner(const std::string& artefact_type) const;
  /// Cache codecs by artefact type. \throw Error when the type has one already
  void add_codec(const std::string& artefact_type, ArtefactCodec codec);
  /// \return the codec, or null when the type cannot be cached
  const ArtefactCodec* codec(const std::string& artefact_type) const;

 private:
  std::map<std::string, NodeSpec> specs_;
  std::map<std::string, std::string> default_variant_;
  std::map<std::string, std::pair<std::string, ArtefactSaver>> savers_;
  std::map<std::string, ArtefactCodec> codecs_;
  std::map<std::string, ArtefactTurner> turners_;
};

inline bool register_node(NodeSpec spec) {
  Registry::instance().add(std::move(spec));
  return true;
}

}  // namespace polyhex
