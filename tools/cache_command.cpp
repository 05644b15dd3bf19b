// `polyhex cache stats|clear|prune`: inspect and trim the artefact cache (graph/cache.h).
#include "graph/cache.h"
#include "tools/commands.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <memory>

namespace polyhex {
namespace {

struct CacheOptions {
  std::filesystem::path dir;  // empty = the default beside ./polyhex-out
  bool json_out = false;
  std::string max_size;
};

ArtefactCache open_cache(const CacheOptions& o) {
  return ArtefactCache(o.dir.empty() ? default_cache_dir("polyhex-out") : o.dir);
}

int cmd_stats(const CacheOptions& o) {
  ArtefactCache c = open_cache(o);
  CacheStats s = c.stats();
  if (o.json_out) {
    json j{{"dir", c.dir().string()}, {"entries", s.entries}, {"bytes", s.bytes}, {"temp_files", s.temp_files}};
    j["by_type"] = json::object();
    for (auto& [type, t] : s.by_type) j["by_type"][type] = {{"entries", t.first}, {"bytes", t.second}};
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::printf("cache %s: %zu entries, %s\n", c.dir().c_str(), s.entries, format_size(s.bytes).c_str());
  for (auto& [type, t] : s.by_type)
    std::printf("  %-40s %6zu entries %12s\n", type.c_str(), t.first, format_size(t.second).c_str());
  if (s.temp_files)
    std::printf("  %zu temporary files (writes in progress or left by a killed process)\n", s.temp_files);
  return 0;
}

int cmd_clear(const CacheOptions& o) {
  ArtefactCache c = open_cache(o);
  std::size_t n = c.clear();
  std::printf("cache %s: removed %zu entries\n", c.dir().c_str(), n);
  return 0;
}

int cmd_prune(const CacheOptions& o) {
  const std::uintmax_t max = parse_size(o.max_size);  // ConfigError -> exit 2
  ArtefactCache c = open_cache(o);
  ArtefactCache::PruneResult r = c.prune(max);
  std::printf("cache %s: removed %zu least recently used entries (%s), %s left\n", c.dir().c_str(), r.removed,
              format_size(r.freed).c_str(), format_size(r.remaining).c_str());
  return 0;
}

const bool registered = register_commands([](CLI::App& app, std::vector<Command>& out) {
  auto* cache = app.add_subcommand("cache", "inspect or trim the artefact cache (stats, clear, prune)");
  cache->require_subcommand(1);
  auto opts = std::make_shared<CacheOptions>();
  auto add_dir = [&](CLI::App* sub) {
    sub->add_option("--cache", opts->dir, "cache folder (default: ./.polyhex-cache, beside ./polyhex-out)");
  };
  auto* stats = cache->add_subcommand("stats", "number and size of the entries, per node type");
  add_dir(stats);
  stats->add_flag("--json", opts->json_out, "as JSON");
  auto* clear = cache->add_subcommand("clear", "remove every entry");
  add_dir(clear);
  auto* prune = cache->add_subcommand("prune", "remove least recently used entries down to a total size");
  add_dir(prune);
  prune->add_option("--max-size", opts->max_size, "largest total size to keep, e.g. 500M, 2G")->required();
  out.push_back({cache, [opts, stats, clear, prune] {
                   if (stats->parsed()) return cmd_stats(*opts);
                   if (clear->parsed()) return cmd_clear(*opts);
                   if (prune->parsed()) return cmd_prune(*opts);
                   return 2;
                 }});
});

}  // namespace
}  // namespace polyhex
