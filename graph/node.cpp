#include "graph/node.h"

namespace polyhex {

Registry& Registry::instance() {
  static Registry r;
  return r;
}

void Registry::add(NodeSpec spec) {
  if (spec.type.find('/') == std::string::npos) spec.type += "/default";
  if (specs_.count(spec.type)) throw Error("node type `" + spec.type + "` registered twice");
  std::string stage = spec.stage();
  if (!default_variant_.count(stage)) default_variant_[stage] = spec.type;
  specs_.emplace(spec.type, std::move(spec));
}

void Registry::set_default_variant(const std::string& stage, const std::string& variant) {
  default_variant_[stage] = stage + "/" + variant;
}

const NodeSpec* Registry::find(const std::string& type) const {
  auto it = specs_.find(type);
  if (it != specs_.end()) return &it->second;
  if (type.find('/') == std::string::npos) {
    auto d = default_variant_.find(type);
    if (d != default_variant_.end()) return find(d->second);
  }
  return nullptr;
}

std::vector<std::string> Registry::types() const {
  std::vector<std::string> out;
  for (auto& [k, v] : specs_) out.push_back(k);
  return out;
}

void Registry::add_saver(const std::string& artefact_type, const std::string& ext, ArtefactSaver saver) {
  savers_[artefact_type] = {ext, std::move(saver)};
}

void Registry::add_turner(const std::string& artefact_type, ArtefactTurner turner) {
  turners_[artefact_type] = std::move(turner);
}

const ArtefactTurner* Registry::turner(const std::string& artefact_type) const {
  auto it = turners_.find(artefact_type);
  return it == turners_.end() ? nullptr : &it->second;
}

std::pair<std::string, ArtefactSaver> Registry::saver(const std::string& artefact_type) const {
  auto it = savers_.find(artefact_type);
  if (it == savers_.end()) return {"", nullptr};
  return it->second;
}

void Registry::add_codec(const std::string& artefact_type, ArtefactCodec codec) {
  if (codecs_.count(artefact_type)) throw Error("artefact type `" + artefact_type + "` has two cache codecs");
  codecs_.emplace(artefact_type, std::move(codec));
}

const ArtefactCodec* Registry::codec(const std::string& artefact_type) const {
  auto it = codecs_.find(artefact_type);
  return it == codecs_.end() ? nullptr : &it->second;
}

}  // namespace polyhex
