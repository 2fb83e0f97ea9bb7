#include "ccfr/io/user_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "ccfr/core/error.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {
std::string quoted(const fs::path& p, const std::string& what) { return what + " '" + printable(p.string()) + "'"; }

std::string mib(std::uintmax_t bytes) {
  if (bytes >= (std::uintmax_t{1} << 30)) return std::to_string(bytes >> 30) + " GiB";
  return std::to_string(bytes >> 20) + " MiB";
}

/// What kind of non-regular file `st` describes, for the message.
const char* kind_of(fs::file_type t) {
  switch (t) {
    case fs::file_type::directory:
      return "a directory";
    case fs::file_type::fifo:
      return "a FIFO (named pipe)";
    case fs::file_type::character:
      return "a character device";
    case fs::file_type::block:
      return "a block device";
    case fs::file_type::socket:
      return "a socket";
    default:
      return "neither a file nor a directory";
  }
}
}  // namespace

fs::file_status user_path_status(const fs::path& path, const std::string& what) {
  if (path.empty()) throw Error(what + " path is empty");
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  // ENOENT and ENOTDIR are "does not exist"; ELOOP, ENAMETOOLONG, EACCES are the user's to fix too.
  if (ec && st.type() != fs::file_type::not_found)
    throw Error("cannot access " + quoted(path, what) + ": " + ec.message());
  return st;
}

std::uintmax_t check_user_file(const fs::path& path, const std::string& what, std::uintmax_t max_bytes) {
  const fs::file_status st = user_path_status(path, what);
  if (st.type() == fs::file_type::not_found) throw Error(quoted(path, what) + " does not exist");
  if (st.type() != fs::file_type::regular)
    throw Error(quoted(path, what) + " is not a regular file (it is " + kind_of(st.type()) + ")");
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw Error("cannot access " + quoted(path, what) + ": " + ec.message());
  if (size > max_bytes)
    throw Error(quoted(path, what) + " has " + std::to_string(size) + " bytes; " + what + "s are limited to " +
                mib(max_bytes));
  return size;
}

std::string read_user_file(const fs::path& path, const std::string& what, std::uintmax_t max_bytes) {
  check_user_file(path, what, max_bytes);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw Error("cannot read " + quoted(path, what) + ": " + std::strerror(errno));
  struct stat sb {};
  if (::fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode)) {
    ::close(fd);
    throw Error(quoted(path, what) + " is not a regular file");
  }
  std::string text;
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      throw Error("cannot read " + quoted(path, what) + ": " + std::strerror(err));
    }
    if (n == 0) break;
    text.append(buf, static_cast<size_t>(n));
    if (text.size() > max_bytes) {  // grew since the check
      ::close(fd);
      throw Error(quoted(path, what) + " is larger than " + mib(max_bytes));
    }
  }
  ::close(fd);
  return text;
}

namespace {
/// Length of the well-formed UTF-8 sequence at text[i] (RFC 3629: no overlong forms, no
/// surrogates, nothing above U+10FFFF), 0 if there is none; `cp` receives the code point.
size_t utf8_sequence(const std::string& text, size_t i, char32_t& cp) {
  const auto b = [&](size_t k) { return static_cast<unsigned char>(text[i + k]); };
  const unsigned char c = b(0);
  size_t len = 0;
  if (c < 0x80) {
    cp = c;
    return 1;
  }
  if (c >= 0xc2 && c <= 0xdf)
    len = 2, cp = c & 0x1f;
  else if (c >= 0xe0 && c <= 0xef)
    len = 3, cp = c & 0x0f;
  else if (c >= 0xf0 && c <= 0xf4)
    len = 4, cp = c & 0x07;
  else
    return 0;
  if (i + len > text.size()) return 0;
  for (size_t k = 1; k < len; ++k) {
    if ((b(k) & 0xc0) != 0x80) return 0;
    cp = (cp << 6) | (b(k) & 0x3f);
  }
  const char32_t min = len == 2 ? 0x80 : len == 3 ? 0x800 : 0x10000;
  if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  return len;
}

/// C0 and C1 controls, DEL, and the Unicode line and paragraph separators: each can break a line
/// or drive a terminal.
bool is_control(char32_t cp) { return cp < 0x20 || (cp >= 0x7f && cp <= 0x9f) || cp == 0x2028 || cp == 0x2029; }
}  // namespace

std::string text_problem(const std::string& text) {
  char b[64];
  for (size_t i = 0; i < text.size();) {
    char32_t cp = 0;
    const size_t len = utf8_sequence(text, i, cp);
    if (len == 0) {
      std::snprintf(b, sizeof b, "is not valid UTF-8 (byte 0x%02x at offset %zu)", static_cast<unsigned char>(text[i]),
                    i);
      return b;
    }
    if (is_control(cp)) {
      std::snprintf(b, sizeof b, "contains the control character U+%04X", static_cast<unsigned>(cp));
      return b;
    }
    i += len;
  }
  return "";
}

std::string printable(const std::string& text, bool keep_newlines) {
  std::string out;
  out.reserve(text.size());
  char b[8];
  for (size_t i = 0; i < text.size();) {
    char32_t cp = 0;
    const size_t len = utf8_sequence(text, i, cp);
    if (len == 0 || (is_control(cp) && !(keep_newlines && (cp == '\n' || cp == '\t')))) {
      for (size_t k = 0; k < std::max<size_t>(len, 1); ++k) {
        std::snprintf(b, sizeof b, "\\x%02x", static_cast<unsigned char>(text[i + k]));
        out += b;
      }
      i += std::max<size_t>(len, 1);
      continue;
    }
    out.append(text, i, len);
    i += len;
  }
  return out;
}

}  // namespace ccfr::io
