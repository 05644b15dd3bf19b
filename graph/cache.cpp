#include "graph/cache.h"

#include "runtime/atomic_file.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace polyhex {

namespace fs = std::filesystem;

namespace {

// FNV-1a 128 (prime 2^88 + 0x13b), for keys: 64 bits would do for a cache of thousands of entries, but a
// collision silently returns a wrong mesh, so the key gets the wider hash.
std::string fnv1a128_hex(const std::string& s) {
  using u128 = unsigned __int128;
  u128 h = (u128(0x6c62272e07bb0142ULL) << 64) | u128(0x62b821756295c58dULL);
  const u128 prime = (u128(1) << 88) | u128(0x13b);
  for (unsigned char c : s) {
    h ^= c;
    h *= prime;
  }
  char buf[33];
  std::snprintf(buf, sizeof buf, "%016llx%016llx", (unsigned long long)(h >> 64), (unsigned long long)h);
  return buf;
}

std::string hex64(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)v);
  return buf;
}

// Size and FNV-1a 64 of a file's bytes. \throw IOError
std::string file_fingerprint(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw IOError(p.string() + ": cannot open for reading (cache key)");
  std::vector<char> buf(1 << 20);
  std::uint64_t h = fnv1a64(nullptr, 0);
  std::uintmax_t size = 0;
  while (in) {
    in.read(buf.data(), std::streamsize(buf.size()));
    const auto n = size_t(in.gcount());
    h = fnv1a64(buf.data(), n, h);
    size += n;
  }
  if (in.bad()) throw IOError(p.string() + ": read failed (cache key)");
  return std::to_string(size) + ":" + hex64(h);
}

void put_u32(std::string& s, std::uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); }
void put_u64(std::string& s, std::uint64_t v) { s.append(reinterpret_cast<const char*>(&v), 8); }
void put_block(std::string& s, const std::string& b) {
  put_u64(s, b.size());
  s += b;
}

// An input stream over bytes in memory (no copy), seekable as the codecs need.
class MemoryBuf : public std::streambuf {
 public:
  MemoryBuf(const char* data, size_t n) {
    char* p = const_cast<char*>(data);  // read-only use: the get area is never written
    setg(p, p, p + n);
  }

 protected:
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    char* base = dir == std::ios_base::beg ? eback() : dir == std::ios_base::cur ? gptr() : egptr();
    if (off < eback() - base || off > egptr() - base) return pos_type(off_type(-1));
    setg(eback(), base + off, egptr());
    return pos_type(off_type(gptr() - eback()));
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override {
    return seekoff(off_type(pos), std::ios_base::beg, which);
  }
};

// The whole file; false when it cannot be opened (a miss) or read.
bool read_whole_file(const fs::path& path, std::string& bytes, bool& read_failed) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return false;
  const auto size = in.tellg();
  if (size < 0) return read_failed = true;
  bytes.resize(size_t(size));
  in.seekg(0);
  in.read(bytes.data(), size);
  bytes.resize(size_t(in.gcount()));  // shorter when the file shrank meanwhile: reported as truncated
  read_failed = in.bad();
  return true;
}

// Cursor over an entry's bytes; every read is bounds-checked.
struct EntryCursor {
  const std::string& bytes;
  size_t pos = 0;
  size_t end;  // excludes the checksum
  bool u32(std::uint32_t& v) { return raw(&v, 4); }
  bool u64(std::uint64_t& v) { return raw(&v, 8); }
  bool block(std::string& b) {
    std::uint64_t n;
    if (!u64(n) || n > end - pos) return false;
    b.assign(bytes, pos, size_t(n));
    pos += size_t(n);
    return true;
  }
  bool raw(void* p, size_t n) {
    if (n > end - pos) return false;
    std::memcpy(p, bytes.data() + pos, n);
    pos += n;
    return true;
  }
};

std::string file_stem_of(const std::string& node_type) {
  std::string s = node_type;
  for (char& c : s) {
    if (c == '/')
      c = '.';
    else if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.')
      c = '_';
  }
  return s;
}

// "stage.variant-<32 hex>.phc" -> "stage/variant"
std::string node_type_of(const std::string& filename) {
  std::string stem = filename.substr(0, filename.size() - std::strlen(kEntryExtension));
  auto dash = stem.rfind('-');
  std::string t = dash == std::string::npos ? stem : stem.substr(0, dash);
  auto dot = t.find('.');
  if (dot != std::string::npos) t[dot] = '/';
  return t;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

struct Listed {
  fs::path path;
  std::uintmax_t bytes = 0;
  fs::file_time_type mtime;
  bool temp = false;
};

// Entries and temporary files of the cache folder (a missing folder is empty). \throw IOError
std::vector<Listed> list_folder(const fs::path& dir) {
  std::vector<Listed> out;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return out;
  fs::directory_iterator it(dir, ec);
  if (ec) throw IOError(dir.string() + ": cannot list the cache folder: " + ec.message());
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    if (ec) throw IOError(dir.string() + ": cannot list the cache folder: " + ec.message());
    const std::string name = it->path().filename().string();
    Listed l;
    l.path = it->path();
    l.temp = name.find(std::string(kEntryExtension) + ".tmp.") != std::string::npos;
    if (!l.temp && !ends_with(name, kEntryExtension)) continue;
    std::error_code e2;
    l.bytes = it->file_size(e2);
    l.mtime = it->last_write_time(e2);
    if (e2) continue;  // removed meanwhile by another process
    out.push_back(l);
  }
  return out;
}

bool stale_temp(const Listed& l) {
  return l.temp && fs::file_time_type::clock::now() - l.mtime > std::chrono::hours(1);
}

void remove_quietly(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);
}

}  // namespace

std::uint64_t fnv1a64(const void* data, size_t n, std::uint64_t h) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ULL;
  }
  return h;
}

std::string canonical_json(const json& j) {
  if (j.is_object()) {
    std::string s = "{";
    for (auto it = j.begin(); it != j.end(); ++it)  // nlohmann::json keeps object keys sorted
      s += (s.size() > 1 ? "," : "") + json(it.key()).dump() + ":" + canonical_json(it.value());
    return s + "}";
  }
  if (j.is_array()) {
    std::string s = "[";
    for (size_t i = 0; i < j.size(); ++i) s += (i ? "," : "") + canonical_json(j[i]);
    return s + "]";
  }
  if (j.is_number_integer() && std::fabs(j.get<double>()) >= 9007199254740992.0) return j.dump();  // beyond 2^53 exact
  if (j.is_number()) {
    const double x = j.get<double>();
    if (std::isfinite(x) && x == std::floor(x) && std::fabs(x) < 9007199254740992.0)
      return std::to_string(static_cast<long long>(x));  // 2, 2.0, -0.0 -> "2", "0"
    return json(x).dump();                               // shortest round-trip decimal
  }
  return j.dump();
}

fs::path default_cache_dir(const fs::path& out_dir) {
  fs::path a = fs::absolute(out_dir).lexically_normal();
  if (!a.has_filename() && a.has_parent_path() && a != a.root_path()) a = a.parent_path();  // "out/" -> "out"
  return a.parent_path() / ".polyhex-cache";
}

std::uintmax_t parse_size(const std::string& text) {
  const std::string bad = "size `" + text + "`: expected a number with an optional unit K, M, G or T (e.g. 500M, 2G)";
  size_t used = 0;
  double x = 0;
  try {
    x = std::stod(text, &used);
  } catch (const std::exception&) {
    throw ConfigError(bad);
  }
  std::string unit = text.substr(used);
  for (char& c : unit) c = char(std::toupper(static_cast<unsigned char>(c)));
  if (ends_with(unit, "IB"))
    unit.resize(unit.size() - 2);
  else if (unit.size() == 2 && unit[1] == 'B')
    unit.resize(1);
  double scale = 1;
  if (unit == "K")
    scale = 1024.0;
  else if (unit == "M")
    scale = 1024.0 * 1024;
  else if (unit == "G")
    scale = 1024.0 * 1024 * 1024;
  else if (unit == "T")
    scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!unit.empty() && unit != "B")
    throw ConfigError(bad);
  if (!std::isfinite(x) || x < 0) throw ConfigError(bad);
  return std::uintmax_t(std::llround(x * scale));
}

std::string format_size(std::uintmax_t bytes) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  double x = double(bytes);
  int u = 0;
  while (x >= 1024 && u < 4) {
    x /= 1024;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", x, units[u]);
  return buf;
}

std::string node_key(const NodeSpec& spec, const json& params, const std::vector<std::string>& input_keys) {
  std::string text = "polyhex-cache-key 1\ntype " + spec.type + "\nversion " + spec.version + "\nparams " +
                     canonical_json(params) + "\n";
  for (size_t k = 0; k < input_keys.size(); ++k)
    text += "input " + std::to_string(k) + " " + (input_keys[k].empty() ? "-" : input_keys[k]) + "\n";
  if (spec.input_files)
    for (const fs::path& f : spec.input_files(params)) text += "file " + file_fingerprint(f) + "\n";
  return fnv1a128_hex(text);
}

fs::path ArtefactCache::entry_path(const std::string& node_type, const std::string& key) const {
  return dir_ / (file_stem_of(node_type) + "-" + key + kEntryExtension);
}

CacheLookup ArtefactCache::load(const std::string& node_type, const std::string& key,
                                const std::string& artefact_type) const {
  CacheLookup r;
  const fs::path path = entry_path(node_type, key);
  std::string bytes;
  bool read_failed = false;
  if (!read_whole_file(path, bytes, read_failed)) return r;  // miss (or removed meanwhile)
  auto invalid = [&](const std::string& why) {
    r.status = CacheLookup::Status::invalid;
    r.problem = path.filename().string() + ": " + why;
    return r;
  };
  if (read_failed) return invalid("read failed");
  const size_t magic_len = std::strlen(kEntryMagic);
  if (bytes.size() < magic_len + 8 || bytes.compare(0, magic_len, kEntryMagic) != 0)
    return invalid(bytes.size() < magic_len ? "truncated (" + std::to_string(bytes.size()) + " bytes)"
                                            : "not a cache entry (bad magic)");
  EntryCursor c{bytes, magic_len, bytes.size()};
  std::uint32_t format = 0, codec_version = 0;
  c.u32(format);
  c.u32(codec_version);
  if (format != kEntryFormatVersion)
    return invalid("entry format version " + std::to_string(format) + ", expected " +
                   std::to_string(kEntryFormatVersion));
  if (bytes.size() < c.pos + 8) return invalid("truncated (" + std::to_string(bytes.size()) + " bytes)");
  c.end = bytes.size() - 8;
  std::uint64_t stored_sum = 0;
  std::memcpy(&stored_sum, bytes.data() + c.end, 8);
  std::string type, meta;
  std::uint64_t payload_len = 0;
  if (!c.block(type) || !c.block(meta) || !c.u64(payload_len) || payload_len != c.end - c.pos)
    return invalid("truncated or malformed (" + std::to_string(bytes.size()) + " bytes; lengths do not add up)");
  if (fnv1a64(bytes.data(), c.end) != stored_sum) return invalid("checksum mismatch (corrupt entry)");
  const ArtefactCodec* codec = Registry::instance().codec(artefact_type);
  if (!codec) return invalid("no codec for " + artefact_type);
  if (type != artefact_type) return invalid("holds a " + type + ", expected " + artefact_type);
  if (codec_version != codec->version)
    return invalid(type + " codec version " + std::to_string(codec_version) + ", expected " +
                   std::to_string(codec->version));
  try {
    json m = json::parse(meta);
    MemoryBuf buf(bytes.data() + c.pos, size_t(payload_len));
    std::istream ps(&buf);
    r.artefact = codec->read(ps);
    r.metrics = m.at("metrics");
    r.warnings = m.at("warnings").get<std::vector<std::string>>();
  } catch (const std::exception& e) {
    return invalid(e.what());
  }
  if (!r.artefact || r.artefact.type != artefact_type) return invalid("the codec returned no " + artefact_type);
  r.digest = fnv1a128_hex(bytes.substr(c.pos, size_t(payload_len)));
  r.status = CacheLookup::Status::hit;
  std::error_code ec;
  fs::last_write_time(path, fs::file_time_type::clock::now(), ec);  // LRU; the entry may be gone meanwhile
  return r;
}

std::string ArtefactCache::store(const std::string& node_type, const std::string& key, const Artefact& a,
                                 const json& metrics, const std::vector<std::string>& warnings) const {
  const ArtefactCodec* codec = Registry::instance().codec(a.type);
  if (!a || !codec) throw Error("artefact cache: cannot store a " + (a ? a.type : std::string("missing artefact")));
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (!fs::is_directory(dir_))
    throw IOError(dir_.string() + ": cannot create the cache folder" + (ec ? ": " + ec.message() : ""));
  std::ostringstream payload(std::ios::binary);
  codec->write(a, payload);
  json meta{{"node_type", node_type}, {"metrics", metrics}, {"warnings", warnings}};
  std::string bytes(kEntryMagic);
  put_u32(bytes, kEntryFormatVersion);
  put_u32(bytes, codec->version);
  put_block(bytes, a.type);
  put_block(bytes, meta.dump());
  const std::string body = payload.str();
  put_block(bytes, body);
  put_u64(bytes, fnv1a64(bytes.data(), bytes.size()));
  write_file_atomic(
      entry_path(node_type, key), [&](std::ostream& out) { out.write(bytes.data(), std::streamsize(bytes.size())); },
      /*binary=*/true);
  return fnv1a128_hex(body);
}

CacheStats ArtefactCache::stats() const {
  CacheStats s;
  for (const Listed& l : list_folder(dir_)) {
    if (l.temp) {
      ++s.temp_files;
      continue;
    }
    ++s.entries;
    s.bytes += l.bytes;
    auto& t = s.by_type[node_type_of(l.path.filename().string())];
    ++t.first;
    t.second += l.bytes;
  }
  return s;
}

std::size_t ArtefactCache::clear() const {
  std::size_t n = 0;
  for (const Listed& l : list_folder(dir_)) {
    if (l.temp && !stale_temp(l)) continue;
    remove_quietly(l.path);
    n += l.temp ? 0 : 1;
  }
  return n;
}

ArtefactCache::PruneResult ArtefactCache::prune(std::uintmax_t max_bytes) const {
  std::vector<Listed> entries;
  PruneResult r;
  for (Listed& l : list_folder(dir_)) {
    if (stale_temp(l)) remove_quietly(l.path);
    if (l.temp) continue;
    r.remaining += l.bytes;
    entries.push_back(std::move(l));
  }
  std::sort(entries.begin(), entries.end(),
            [](const Listed& a, const Listed& b) { return a.mtime != b.mtime ? a.mtime < b.mtime : a.path < b.path; });
  for (const Listed& l : entries) {
    if (r.remaining <= max_bytes) break;
    remove_quietly(l.path);
    ++r.removed;
    r.freed += l.bytes;
    r.remaining -= l.bytes;
  }
  return r;
}

}  // namespace polyhex
