/// @file text_cursor.h
/// @brief Internal helpers of the mesh readers and writers: a whole-file buffer with a token/line
/// cursor that knows its line number, a bounds-checked binary cursor with endian conversion, and
/// fast number formatting. Parsing uses std::from_chars on the loaded buffer (no iostream `>>`),
/// so a 50k-triangle file reads in a few milliseconds.
#pragma once

#include "runtime/errors.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace polyhex::io_detail {

/// The whole content of a file.
/// \throw IOError "<path>: no such file" / "<path>: cannot read file"
std::string load_file(const std::filesystem::path& path);

/// Lower-case extension of a path, with the dot (".obj"), "" when none.
std::string lower_extension(const std::filesystem::path& path);

/// Parse a whole token as a number (leading '+' allowed; "nan"/"inf" parse and are rejected by the
/// callers that need finite values). \return false when the token is not entirely a number.
bool parse_double(std::string_view tok, double& out);
bool parse_int(std::string_view tok, long long& out);

/// Splits a line at blanks. \return the number of tokens stored (at most out.size() kept, all counted).
size_t split_blanks(std::string_view line, std::vector<std::string_view>& out);

/// A cursor over text: whitespace-separated tokens or whole lines, with line numbers for messages.
class TextCursor {
 public:
  /// \param comment a character that starts a comment running to the end of the line ('\0': none)
  TextCursor(std::string_view text, std::string file, char comment = '\0');

  /// Next token, skipping blanks, newlines and comments. \return false at the end of the text.
  bool next(std::string_view& tok);
  /// Next token or an IOError "file: line N: unexpected end of file (expected WHAT)".
  std::string_view token(std::string_view what);
  /// Next token as a finite number / an integer. \throw IOError naming the line
  double real(std::string_view what);
  long long integer(std::string_view what);
  /// The rest of the current line (from the cursor to '\n', '\r' stripped); moves past the '\n'.
  /// \return false at the end of the text.
  bool line(std::string_view& out);
  /// Next line that is not empty once comments and blanks are removed (returned without the comment).
  bool next_line(std::string_view& out);
  /// Bytes from the cursor to the end of the text.
  size_t remaining() const { return text_.size() - pos_; }
  /// How many items to reserve for a count read from a header: n, but never more than the items of at
  /// least `min_bytes` each (a text line "0 0 0" needs 6 with its newline) that fit in what remains of
  /// the file, so a forged count cannot make a reader allocate without bound. The reading loop then
  /// fails with its own "truncated" message. 0 for a negative n.
  size_t reserve_hint(long long n, size_t min_bytes) const;
  /// Line number (1-based) of the last token or line returned.
  int line_no() const { return last_line_; }
  size_t pos() const { return pos_; }
  /// Moves to an absolute offset (after a binary block, or to where another cursor stopped).
  /// Newlines skipped are not counted; `line` >= 1 sets the line number of the new position.
  void seek(size_t pos, int line = -1);
  /// Line number of the cursor position (the next item starts on it or later).
  int current_line() const { return line_; }
  std::string_view text() const { return text_; }
  const std::string& file() const { return file_; }
  /// IOError "file: line N: msg".
  [[noreturn]] void fail(const std::string& msg) const;

 private:
  // At the end of the text: the last line that has content.
  int eof_line() const;

  std::string_view text_;
  std::string file_;
  char comment_;
  size_t pos_ = 0;
  int line_ = 1;       // line of pos_
  int last_line_ = 1;  // line of the last item returned
};

/// Bounds-checked reader of binary numbers from a buffer, little- or big-endian.
class BinaryCursor {
 public:
  BinaryCursor(std::string_view data, size_t pos, bool big_endian, std::string file)
      : data_(data), pos_(pos), big_(big_endian), file_(std::move(file)) {}
  /// \throw IOError "file: truncated: WHAT" when fewer than sizeof(T) bytes remain
  template <class T>
  T get(std::string_view what) {
    if (pos_ + sizeof(T) > data_.size())
      throw IOError(file_ + ": truncated: unexpected end of file in " + std::string(what));
    T v;
    unsigned char b[sizeof(T)];
    std::memcpy(b, data_.data() + pos_, sizeof(T));
    if (big_ != host_big_endian())
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    std::memcpy(&v, b, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  void skip(size_t n, std::string_view what) {
    if (pos_ + n > data_.size()) throw IOError(file_ + ": truncated: unexpected end of file in " + std::string(what));
    pos_ += n;
  }
  size_t pos() const { return pos_; }
  static bool host_big_endian() {
    const uint16_t one = 1;
    unsigned char c;
    std::memcpy(&c, &one, 1);
    return c == 0;
  }

 private:
  std::string_view data_;
  size_t pos_;
  bool big_;
  std::string file_;
};

/// Appends numbers to a text buffer: doubles in the shortest form that reads back exactly.
void append_double(std::string& out, double x);
void append_int(std::string& out, long long x);

/// Appends the bytes of a number in big-endian order (legacy VTK binary).
template <class T>
void append_big_endian(std::string& out, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (!BinaryCursor::host_big_endian())
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

}  // namespace polyhex::io_detail
