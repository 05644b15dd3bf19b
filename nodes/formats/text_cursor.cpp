#include "nodes/formats/text_cursor.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <system_error>

namespace polyhex::io_detail {

std::string load_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw IOError(path.string() + ": no such file");
  if (std::filesystem::is_directory(path, ec)) throw IOError(path.string() + ": is a directory, not a mesh file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IOError(path.string() + ": cannot open file for reading");
  std::string data;
  in.seekg(0, std::ios::end);
  auto size = in.tellg();
  if (size < 0) throw IOError(path.string() + ": cannot read file");
  data.resize(static_cast<size_t>(size));
  in.seekg(0, std::ios::beg);
  in.read(data.data(), size);
  if (!in) throw IOError(path.string() + ": cannot read file");
  return data;
}

std::string lower_extension(const std::filesystem::path& path) {
  std::string e = path.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

bool parse_double(std::string_view tok, double& out) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  auto r = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}

bool parse_int(std::string_view tok, long long& out) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  auto r = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}

namespace {
inline bool blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
}  // namespace

size_t split_blanks(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0, n = line.size();
  while (i < n) {
    while (i < n && (blank(line[i]) || line[i] == '\n')) ++i;
    if (i >= n) break;
    size_t s = i;
    while (i < n && !blank(line[i]) && line[i] != '\n') ++i;
    out.push_back(line.substr(s, i - s));
  }
  return out.size();
}

TextCursor::TextCursor(std::string_view text, std::string file, char comment)
    : text_(text), file_(std::move(file)), comment_(comment) {}

bool TextCursor::next(std::string_view& tok) {
  const size_t n = text_.size();
  while (pos_ < n) {
    char c = text_[pos_];
    if (c == '\n') {
      ++line_;
      ++pos_;
    } else if (blank(c)) {
      ++pos_;
    } else if (comment_ && c == comment_) {
      while (pos_ < n && text_[pos_] != '\n') ++pos_;
    } else {
      break;
    }
  }
  if (pos_ >= n) return false;
  size_t s = pos_;
  while (pos_ < n && !blank(text_[pos_]) && text_[pos_] != '\n' && !(comment_ && text_[pos_] == comment_)) ++pos_;
  tok = text_.substr(s, pos_ - s);
  last_line_ = line_;
  return true;
}

std::string_view TextCursor::token(std::string_view what) {
  std::string_view t;
  if (!next(t)) {
    last_line_ = eof_line();
    fail("truncated: unexpected end of file (expected " + std::string(what) + ")");
  }
  return t;
}

double TextCursor::real(std::string_view what) {
  std::string_view t = token(what);
  double x;
  if (!parse_double(t, x)) fail("expected " + std::string(what) + ", got `" + std::string(t) + "`");
  if (!std::isfinite(x)) fail(std::string(what) + " is not finite (`" + std::string(t) + "`)");
  return x;
}

long long TextCursor::integer(std::string_view what) {
  std::string_view t = token(what);
  long long x;
  if (!parse_int(t, x)) fail("expected " + std::string(what) + " (an integer), got `" + std::string(t) + "`");
  return x;
}

bool TextCursor::line(std::string_view& out) {
  const size_t n = text_.size();
  if (pos_ >= n) return false;
  size_t s = pos_;
  size_t e = text_.find('\n', s);
  if (e == std::string_view::npos) e = n;
  pos_ = e < n ? e + 1 : n;
  last_line_ = line_;
  if (e < n) ++line_;
  size_t end = e;
  while (end > s && text_[end - 1] == '\r') --end;
  out = text_.substr(s, end - s);
  return true;
}

bool TextCursor::next_line(std::string_view& out) {
  std::string_view l;
  while (line(l)) {
    if (comment_) {
      size_t c = l.find(comment_);
      if (c != std::string_view::npos) l = l.substr(0, c);
    }
    size_t a = 0;
    while (a < l.size() && blank(l[a])) ++a;
    size_t b = l.size();
    while (b > a && blank(l[b - 1])) --b;
    if (b > a) {
      out = l.substr(a, b - a);
      return true;
    }
  }
  last_line_ = eof_line();
  return false;
}

void TextCursor::seek(size_t pos, int line) {
  pos_ = std::min(pos, text_.size());
  if (line >= 1) line_ = line;
}

int TextCursor::eof_line() const { return (!text_.empty() && text_.back() == '\n' && line_ > 1) ? line_ - 1 : line_; }

size_t TextCursor::reserve_hint(long long n, size_t min_bytes) const {
  if (n <= 0) return 0;
  const size_t fit = (remaining() + 1) / std::max<size_t>(min_bytes, 1);
  return std::min(static_cast<size_t>(n), fit);
}

void TextCursor::fail(const std::string& msg) const {
  throw IOError(file_ + ": line " + std::to_string(last_line_) + ": " + msg);
}

void append_double(std::string& out, double x) {
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof(buf), x);
  out.append(buf, r.ptr);
}

void append_int(std::string& out, long long x) {
  char buf[32];
  auto r = std::to_chars(buf, buf + sizeof(buf), x);
  out.append(buf, r.ptr);
}

}  // namespace polyhex::io_detail
