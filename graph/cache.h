/// @file cache.h
/// @brief The on-disk artefact cache: a node's output artefact, metrics and warnings stored under a key
/// that changes whenever anything the output depends on changes.
///
/// **Key** (node_key): FNV-1a 128 of a canonical text holding the node type ("stage/variant"), its code
/// version (NodeSpec::version), its canonical params (sorted keys, every number as the shortest
/// round-trip double, -0 as 0), the keys of its input nodes in port order, and for every file the node
/// reads (NodeSpec::input_files) its size and FNV-1a 64 of its bytes. The node id is not part of the key,
/// so the same node under another id or in another config reuses the entry. Pipeline::run keys an input
/// by its artefact's *content* when the cache has it ("d:" + FNV-1a 128 of the codec's payload, from the
/// store or the load; else the input's own key, "k:" + key): a param change that leaves a node's output
/// as it was (a refusal bound not reached, a pass with nothing to do) reruns that node only, everything
/// after it is loaded.
///
/// **Entry** `DIR/<stage>.<variant>-<key>.phc`, all integers little-endian:
///
///     offset  size  field
///          0     8  magic "PHXCACHE"
///          8     4  u32 entry format version (kEntryFormatVersion)
///         12     4  u32 codec version (ArtefactCodec::version of the artefact type)
///         16     8  u64 length of the artefact type name, then the name
///          .     8  u64 length of the metadata, then the metadata (JSON: node type, metrics, warnings)
///          .     8  u64 length of the payload, then the payload (the codec's bytes)
///        end-8   8  u64 FNV-1a 64 of every byte before it
///
/// A missing entry is a miss. A truncated or corrupt entry (bad magic, lengths that do not add up to the
/// file size, checksum mismatch, a payload the codec rejects) or an entry of another format or codec
/// version is *invalid*: the caller ignores it with a warning, recomputes and overwrites it.
///
/// **Concurrency**: entries are written with write_file_atomic (unique temporary name per process and
/// call, then rename), so readers see either no entry or a whole one, in this process or another; a
/// failure to store is reported, never fatal. A hit touches the entry's modification time: `prune`
/// removes the least recently used entries first.
#pragma once

#include "graph/node.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace polyhex {

constexpr std::uint32_t kEntryFormatVersion = 1;
constexpr char kEntryMagic[9] = "PHXCACHE";
constexpr const char* kEntryExtension = ".phc";

/// FNV-1a 64 of `n` bytes, continuing from `h` (start with the default).
std::uint64_t fnv1a64(const void* data, size_t n, std::uint64_t h = 0xcbf29ce484222325ULL);

/// Canonical text of a JSON value: object keys sorted, no spaces, numbers as the shortest decimal that
/// reads back to the same double (so 2, 2.0 and 2e0 agree), -0 as 0.
std::string canonical_json(const json& j);

/// The default cache folder: `.polyhex-cache` in the folder that holds the output folder
/// (`runs/a` -> `runs/.polyhex-cache`; `polyhex-out` -> `./.polyhex-cache`), as an absolute path.
std::filesystem::path default_cache_dir(const std::filesystem::path& out_dir);

/// Parses a size: a number with an optional binary unit K, M, G, T (optionally followed by B or iB),
/// case-insensitive: "500M" = 500 * 2^20 bytes, "1.5G", "4096". \throw ConfigError naming the text
std::uintmax_t parse_size(const std::string& text);
/// "1.5 MB" style, binary units.
std::string format_size(std::uintmax_t bytes);

/// The cache key of a node (32 hex digits).
/// \param input_keys keys of the producing nodes, per port of spec.inputs ("" for an unconnected port)
/// \throw IOError when a file of spec.input_files cannot be read (then the node cannot be cached)
std::string node_key(const NodeSpec& spec, const json& params, const std::vector<std::string>& input_keys);

/// What a lookup found.
struct CacheLookup {
  enum class Status { miss, hit, invalid };
  Status status = Status::miss;
  Artefact artefact;                  ///< the artefact on a hit
  json metrics = json::object();      ///< the node's metrics when it was computed
  std::vector<std::string> warnings;  ///< the node's warnings when it was computed
  std::string problem;                ///< why an entry is invalid
  std::string digest;                 ///< on a hit: FNV-1a 128 (hex) of the payload (what store returned)
};

/// Totals of a cache folder.
struct CacheStats {
  std::size_t entries = 0;
  std::uintmax_t bytes = 0;
  std::size_t temp_files = 0;  ///< writes in progress (or left by a killed process)
  std::map<std::string, std::pair<std::size_t, std::uintmax_t>> by_type;  ///< node type -> {entries, bytes}
};

/// The cache in one folder. Every method may be called concurrently from several threads and processes.
class ArtefactCache {
 public:
  /// The folder is created on the first store.
  explicit ArtefactCache(std::filesystem::path dir) : dir_(std::move(dir)) {}
  const std::filesystem::path& dir() const { return dir_; }
  /// The entry file of a node type and key.
  std::filesystem::path entry_path(const std::string& node_type, const std::string& key) const;

  /// Looks an entry up and, on a hit, touches it (LRU). Never throws for a bad entry: it is `invalid`.
  /// \pre a codec is registered for artefact_type
  CacheLookup load(const std::string& node_type, const std::string& key, const std::string& artefact_type) const;
  /// Stores (replaces) an entry atomically. \return FNV-1a 128 (hex) of the payload (the artefact's content)
  /// \pre `a` is not empty and its type has a codec   \throw IOError when the folder or file cannot be written
  std::string store(const std::string& node_type, const std::string& key, const Artefact& a, const json& metrics,
                    const std::vector<std::string>& warnings) const;

  /// Counts entries and bytes (a missing folder is an empty cache). \throw IOError when it cannot be listed
  CacheStats stats() const;
  /// Removes every entry and temporary files older than an hour (younger ones belong to running
  /// processes). \return the number of entries removed   \throw IOError when the folder cannot be listed
  std::size_t clear() const;
  struct PruneResult {
    std::size_t removed = 0;
    std::uintmax_t freed = 0, remaining = 0;
  };
  /// Removes least recently used entries (oldest modification time first) until the entries take at most
  /// `max_bytes`, and temporary files older than an hour. \throw IOError when the folder cannot be listed
  PruneResult prune(std::uintmax_t max_bytes) const;

 private:
  std::filesystem::path dir_;
};

}  // namespace polyhex
