/// @file boundary_groups.h
/// @brief What every reader of a HexMesh's boundary groups needs: the vertices of a face and of a group,
/// and the consistency check the writers and the cache codec apply before they trust the groups.
#pragma once

#include "nodes/artefacts/hex_topology.h"
#include "nodes/artefacts/meshes.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <set>
#include <string>
#include <vector>

namespace polyhex {

/// Longest group name: Exodus II keeps 32 characters.
inline constexpr size_t kMaxGroupName = 32;

/// A group name every format accepts: a letter, then letters, digits and '_', at most kMaxGroupName.
inline bool valid_group_name(const std::string& name) {
  if (name.empty() || name.size() > kMaxGroupName || !std::isalpha(static_cast<unsigned char>(name[0]))) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

/// The 4 vertices of local face `face` of hex `hex`, outward for a valid hex (hex_topology::kFaces).
/// \pre hex and face in range
inline std::array<int, 4> hex_face_vertices(const HexMesh& mesh, int hex, int face) {
  std::array<int, 4> q;
  for (int k = 0; k < 4; ++k) q[size_t(k)] = mesh.H(hex, hex_topology::kFaces[face][k]);
  return q;
}

/// The vertices of a group's faces (its node set), sorted, 0-based. \pre check_boundary_groups passes
inline std::vector<int> group_vertices(const HexMesh& mesh, const BoundaryGroup& g) {
  std::vector<int> v;
  v.reserve(g.faces.size() * 4);
  for (const auto& [h, f] : g.faces)
    for (int x : hex_face_vertices(mesh, h, f)) v.push_back(x);
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

/// What is wrong with the groups of `mesh`, "" when nothing: a name that valid_group_name refuses or
/// that repeats, an empty family, a negative id, a (hex, face) out of range, faces not sorted or
/// repeated, a face in two groups of one family. (Whether each face is on the boundary is not checked.)
inline std::string boundary_groups_problem(const HexMesh& mesh) {
  std::set<std::string> names;
  std::set<std::pair<std::string, std::array<int, 2>>> taken;  // (family, face)
  for (const BoundaryGroup& g : mesh.groups) {
    const std::string who = "boundary group `" + g.name + "`";
    if (!valid_group_name(g.name))
      return who + ": the name must be a letter followed by letters, digits or '_', at most " +
             std::to_string(kMaxGroupName) + " characters";
    if (!names.insert(g.name).second) return who + ": the name is used twice";
    if (g.family.empty()) return who + ": no family";
    if (g.id < 0) return who + ": negative id " + std::to_string(g.id);
    for (size_t i = 0; i < g.faces.size(); ++i) {
      const auto& [h, f] = g.faces[i];
      if (h < 0 || h >= mesh.H.rows() || f < 0 || f >= 6)
        return who + ": face (" + std::to_string(h) + ", " + std::to_string(f) + ") out of range (" +
               std::to_string(mesh.H.rows()) + " hexes, 6 faces each)";
      if (i > 0 && !(g.faces[i - 1] < g.faces[i])) return who + ": faces not sorted or repeated";
      if (!taken.insert({g.family, g.faces[i]}).second)
        return who + ": face (" + std::to_string(h) + ", " + std::to_string(f) + ") is in another `" + g.family +
               "` group too";
    }
  }
  return "";
}

}  // namespace polyhex
