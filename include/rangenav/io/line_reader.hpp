#pragma once
// LineReader: streams the lines of a text file, plain or gzip-compressed, without loading the
// whole file; plus the whitespace tokenizer and locale-independent number parsing the text
// readers (CARMEN logs, trajectory files) share.
//
// A gzip file is recognised by its magic bytes (1f 8b), not by its name, and is read through
// zlib when RANGENAV_HAVE_ZLIB is defined (the CMake target defines it when zlib is found);
// without zlib such a file raises io_error saying so. A line longer than the reader's limit
// (ReaderLimits::max_line_bytes) raises io_error instead of growing the buffer without bound.

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <istream>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/io/reader_limits.hpp"

#ifdef RANGENAV_HAVE_ZLIB
#include <zlib.h>
#endif

namespace rangenav::io {

/// Reads a text file line by line (plain or gzip). Lines are handed out as views into an internal
/// buffer that stay valid until the next call to next(). Not thread-safe; movable, not copyable.
class LineReader {
 public:
  /// Opens `path`; `where` prefixes error messages ("rangenav: <where>: <path>: ...").
  /// Throws io_error when the file cannot be opened or is gzip-compressed and zlib is missing;
  /// next() throws io_error for a line longer than `max_line_bytes`.
  LineReader(const std::filesystem::path& path, std::string_view where,
             std::size_t max_line_bytes = ReaderLimits{}.max_line_bytes)
      : path_(path),
        where_(where),
        max_line_(std::max<std::size_t>(max_line_bytes, 1)),
        buffer_(std::min<std::size_t>(std::size_t{1} << 16, max_line_ + 1)) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (f == nullptr) {
      const int err = errno;
      fail_file("cannot open file: " + std::generic_category().message(err));
    }
    file_.reset(f);
    unsigned char magic[2] = {0, 0};
    const std::size_t got = std::fread(magic, 1, 2, f);
    gzip_ = got == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
    if (!gzip_) {
      std::rewind(f);
      return;
    }
#ifdef RANGENAV_HAVE_ZLIB
    file_.reset();
    gzFile gz = gzopen(path.c_str(), "rb");
    if (gz == nullptr) fail_file("cannot open gzip file");
    gz_.reset(gz);
    gzbuffer(gz, 1U << 17);
#else
    fail_file("gzip-compressed file, but rangenav was built without zlib (RANGENAV_HAVE_ZLIB)");
#endif
  }

  /// The next line without its line terminator ("\n" or "\r\n"), or false at the end of the file.
  bool next(std::string_view& line) {
    for (;;) {
      const char* first = buffer_.data() + begin_;
      const auto* newline = static_cast<const char*>(std::memchr(first, '\n', end_ - begin_));
      if (newline != nullptr) {
        const auto length = static_cast<std::size_t>(newline - first);
        begin_ += length + 1;
        terminated_ = true;
        return emit(line, first, length);
      }
      if (eof_) {
        if (begin_ == end_) return false;
        const std::size_t length = end_ - begin_;
        begin_ = end_;
        terminated_ = false;
        return emit(line, first, length);
      }
      refill();
    }
  }

  /// 1-based number of the line last returned by next().
  [[nodiscard]] std::size_t line_number() const {
    return line_number_;
  }
  /// False when the line last returned is the last line of the file and has no newline.
  [[nodiscard]] bool line_terminated() const {
    return terminated_;
  }
  /// True when the file is gzip-compressed (recognised by its magic bytes, not its name).
  [[nodiscard]] bool is_gzip() const {
    return gzip_;
  }
  /// The file being read, as given to the constructor (used in error messages).
  [[nodiscard]] const std::filesystem::path& path() const {
    return path_;
  }

  /// Throws io_error("rangenav: <where>: <path>:<line>: <message>") for the current line.
  [[noreturn]] void fail_line(std::string_view message) const {
    std::string msg = "rangenav: ";
    msg.append(where_).append(": ").append(path_.string()).append(":");
    msg.append(std::to_string(line_number_)).append(": ").append(message);
    if (!terminated_) msg.append(" (unterminated last line: truncated file?)");
    throw io_error(msg);
  }

 private:
  struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
#ifdef RANGENAV_HAVE_ZLIB
  struct GzCloser {
    void operator()(gzFile_s* f) const { gzclose(f); }
  };
#endif

  [[noreturn]] void fail_file(std::string_view message) const {
    std::string msg = "rangenav: ";
    msg.append(where_).append(": ").append(path_.string()).append(": ").append(message);
    throw io_error(msg);
  }

#ifdef RANGENAV_HAVE_ZLIB
  // gzerror's text starts with the path given to gzopen; the message names it once.
  [[noreturn]] void fail_gzip(const char* text) const {
    std::string_view message = text != nullptr ? text : "read error";
    const std::string prefix = path_.string() + ": ";
    if (message.starts_with(prefix)) message.remove_prefix(prefix.size());
    fail_file("gzip: " + std::string(message));
  }
#endif

  bool emit(std::string_view& line, const char* first, std::size_t length) {
    ++line_number_;
    if (length > 0 && first[length - 1] == '\r') --length;
    if (length > max_line_) fail_long_line();
    line = std::string_view(first, length);
    return true;
  }

  // Called with line_number_ already counting the line being read.
  [[noreturn]] void fail_long_line() {
    terminated_ = true;
    fail_line("line longer than ReaderLimits::max_line_bytes = " + std::to_string(max_line_) +
              " bytes");
  }

  // Moves the unread tail to the front, grows the buffer when one line fills it (up to the line
  // limit), and reads more.
  void refill() {
    if (begin_ > 0) {
      std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ == buffer_.size()) {
      if (end_ > max_line_) {
        ++line_number_;
        fail_long_line();
      }
      buffer_.resize(std::min(buffer_.size() * 2, max_line_ + 1));
    }
    const std::size_t got = read_some(buffer_.data() + end_, buffer_.size() - end_);
    if (got == 0) eof_ = true;
    end_ += got;
  }

  std::size_t read_some(char* destination, std::size_t capacity) {
#ifdef RANGENAV_HAVE_ZLIB
    if (gz_) {
      const int got = gzread(gz_.get(), destination,
                             static_cast<unsigned>(std::min<std::size_t>(capacity, 1U << 30)));
      // zlib stops at a truncated stream without an error code from gzread; gzerror says so.
      if (got <= 0) {
        int code = Z_OK;
        const char* text = gzerror(gz_.get(), &code);
        if (got < 0 || (code != Z_OK && code != Z_STREAM_END)) fail_gzip(text);
      }
      return static_cast<std::size_t>(got);
    }
#endif
    const std::size_t got = std::fread(destination, 1, capacity, file_.get());
    if (got == 0 && std::ferror(file_.get()) != 0) fail_file("read error");
    return got;
  }

  std::filesystem::path path_;
  std::string where_;
  std::size_t max_line_;
  std::unique_ptr<std::FILE, FileCloser> file_;
#ifdef RANGENAV_HAVE_ZLIB
  std::unique_ptr<gzFile_s, GzCloser> gz_;
#endif
  std::vector<char> buffer_;
  std::size_t begin_{0};
  std::size_t end_{0};
  std::size_t line_number_{0};
  bool eof_{false};
  bool terminated_{true};
  bool gzip_{false};
};

namespace detail {

/// Splits `line` at spaces and tabs into `tokens` (cleared first; its capacity is reused).
inline void split_whitespace(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (i < n) {
    while (i < n && (line[i] == ' ' || line[i] == '\t'))
      ++i;
    if (i == n) break;
    const std::size_t start = i;
    while (i < n && line[i] != ' ' && line[i] != '\t')
      ++i;
    tokens.push_back(line.substr(start, i - start));
  }
}

/// std::getline with a bound: the next line of `in` without its '\n' into `line`, or false at the
/// end of the stream. A line longer than `max_bytes` stops the read with `too_long` set (and
/// true returned), so a stream without line breaks cannot grow `line` without bound.
inline bool read_bounded_line(std::istream& in, std::string& line, std::size_t max_bytes,
                              bool& too_long) {
  line.clear();
  too_long = false;
  const std::istream::sentry ok(in, true);
  if (!ok) return false;
  std::streambuf* buffer = in.rdbuf();
  bool any = false;
  for (;;) {
    const int c = buffer->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in.setstate(any ? std::ios::eofbit : std::ios::eofbit | std::ios::failbit);
      return any;
    }
    any = true;
    if (c == '\n') return true;
    if (line.size() >= max_bytes) {
      too_long = true;
      return true;
    }
    line.push_back(static_cast<char>(c));
  }
}

/// Parses the whole token as a double ("1.13486e+09", "-0.5", "+2", "nan", "inf");
/// locale-independent. False for anything else, including out-of-range exponents.
inline bool parse_double(std::string_view token, double& value) {
  const char* first = token.data();
  const char* last = first + token.size();
  if (first != last && *first == '+') ++first;  // from_chars rejects a leading '+'
  const auto [end, ec] = std::from_chars(first, last, value);
  return ec == std::errc() && end == last && first != last;
}

/// Parses the whole token as a non-negative decimal integer.
inline bool parse_count(std::string_view token, std::size_t& value) {
  const char* first = token.data();
  const char* last = first + token.size();
  const auto [end, ec] = std::from_chars(first, last, value);
  return ec == std::errc() && end == last && first != last;
}

/// Appends `value` in fixed notation with `precision` decimals (locale-independent, like
/// printf("%.*f"), except that no "-0.000" is printed).
inline void append_fixed(std::string& out, double value, int precision) {
  char buffer[400];
  const auto [end, ec] =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::fixed, precision);
  if (ec != std::errc()) {
    out.append(std::to_string(value));
    return;
  }
  // A negative value that rounds to zero prints as "0.000", not "-0.000".
  const char* first = buffer;
  if (*first == '-' && std::string_view(first + 1, static_cast<std::size_t>(end - first - 1))
                               .find_first_not_of("0.") == std::string_view::npos)
    ++first;
  out.append(first, static_cast<std::size_t>(end - first));
}

}  // namespace detail
}  // namespace rangenav::io
