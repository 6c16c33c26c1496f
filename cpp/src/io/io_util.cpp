#include "io_util.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <charconv>
#include <limits>

namespace vpffd::io_detail {

void fail(const std::string& what, const std::string& shown, const std::string& why) {
  throw MeshIOError(what + ": '" + shown + "': " + why);
}

namespace {

// Length of the valid UTF-8 sequence starting at s[i] (1 to 4), or 0 if the
// bytes there are not one (overlong forms and surrogates included).
std::size_t utf8_length(const std::string& s, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[i + k]); };
  const unsigned char c = b(0);
  std::size_t n = 0;
  std::uint32_t cp = 0;
  if (c < 0x80) return 1;
  if (c >= 0xC2 && c <= 0xDF) n = 2, cp = c & 0x1F;
  else if (c >= 0xE0 && c <= 0xEF) n = 3, cp = c & 0x0F;
  else if (c >= 0xF0 && c <= 0xF4) n = 4, cp = c & 0x07;
  else return 0;
  if (i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((b(k) & 0xC0) != 0x80) return 0;
    cp = (cp << 6) | (b(k) & 0x3F);
  }
  if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10FFFF)) || (cp >= 0xD800 && cp <= 0xDFFF))
    return 0;
  return n;
}

void hex(std::string& out, unsigned char c) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "\\x%02x", c);
  out += buf;
}

}  // namespace

std::string printable(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const std::size_t n = utf8_length(text, i);
    if (n == 0 || (n == 1 && (c < 32 || c == 127))) {
      hex(out, c);
      ++i;
    } else {
      out.append(text, i, n);
      i += n;
    }
  }
  return out;
}

std::string display_name(const std::string& path) { return printable(path); }

std::string quote(const std::string& tok) {
  std::string s = "'";
  for (std::size_t i = 0; i < tok.size() && i < 60; ++i) {
    const unsigned char c = static_cast<unsigned char>(tok[i]);
    if (c >= 32 && c < 127)
      s += static_cast<char>(c);
    else
      hex(s, c);
  }
  return s + (tok.size() > 60 ? "...'" : "'");
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::vector<std::string> tokens_of(const std::string& line, bool comments) {
  std::vector<std::string> t;
  std::size_t i = 0;
  const std::size_t n = comments ? std::min(line.find('#'), line.size()) : line.size();
  while (i < n) {
    while (i < n && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    std::size_t j = i;
    while (j < n && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    if (j > i) t.push_back(line.substr(i, j - i));
    i = j;
  }
  return t;
}

bool parse_double(const std::string& tok, double& v) {
  const char* b = tok.c_str();
  char* e = nullptr;
  v = std::strtod(b, &e);
  return e != b && *e == '\0' && std::strlen(b) == tok.size();
}

bool parse_int(const std::string& tok, long long& v) {
  const char* b = tok.c_str();
  char* e = nullptr;
  errno = 0;
  v = std::strtoll(b, &e, 10);
  return e != b && *e == '\0' && errno != ERANGE && std::strlen(b) == tok.size();
}

std::string at_line(long long n) { return "line " + std::to_string(n) + ": "; }

bool Lines::next(std::string& line) {
  line.clear();
  std::streambuf* sb = in_.rdbuf();
  if (!in_) return false;
  bool any = false;
  for (;;) {
    const int c = sb->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in_.setstate(std::ios::eofbit);
      if (!any) {
        in_.setstate(std::ios::failbit);
        return false;
      }
      break;
    }
    any = true;
    if (c == '\n') break;
    if (line.size() >= max_line)
      fail("load_mesh", shown_,
           at_line(number_ + 1) + "longer than " + std::to_string(max_line) + " bytes: not a text file of this format");
    line.push_back(static_cast<char>(c));
  }
  ++number_;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (number_ == 1) {
    // A UTF-8 byte-order mark (some Windows tools write one) is not part of the first
    // keyword: read as one, an OBJ's first "v" line would be skipped and every face
    // index would shift. UTF-16 text is not this format's text at all.
    if (line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
    if (line.compare(0, 2, "\xFF\xFE") == 0 || line.compare(0, 2, "\xFE\xFF") == 0)
      fail("load_mesh", shown_, "the file is UTF-16 text; save it as UTF-8 or ASCII");
  }
  return true;
}

bool Bytes::uint(int bytes, std::uint64_t& v) {
  if (left() < static_cast<std::size_t>(bytes)) return false;
  v = 0;
  for (int k = 0; k < bytes; ++k) {
    const std::uint64_t b = p_[at_ + static_cast<std::size_t>(big_ ? k : bytes - 1 - k)];
    v = (v << 8) | b;
  }
  at_ += static_cast<std::size_t>(bytes);
  return true;
}

bool Bytes::f32(double& v) {
  std::uint64_t u = 0;
  if (!uint(4, u)) return false;
  const std::uint32_t w = static_cast<std::uint32_t>(u);
  float f;
  std::memcpy(&f, &w, 4);
  v = f;
  return true;
}

bool Bytes::f64(double& v) {
  std::uint64_t u = 0;
  if (!uint(8, u)) return false;
  std::memcpy(&v, &u, 8);
  return true;
}

std::vector<unsigned char> read_all(const std::string& file, const std::string& shown) {
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) fail("load_mesh", shown, "cannot open it for reading");
  const std::streamoff n = in.tellg();
  if (n < 0) fail("load_mesh", shown, "cannot read its size");
  std::vector<unsigned char> data(static_cast<std::size_t>(n));
  in.seekg(0);
  if (n > 0 && !in.read(reinterpret_cast<char*>(data.data()), n)) fail("load_mesh", shown, "read error");
  return data;
}

std::uint64_t times(std::uint64_t count, std::uint64_t each) {
  if (each != 0 && count > std::numeric_limits<std::uint64_t>::max() / each)
    return std::numeric_limits<std::uint64_t>::max();
  return count * each;
}

void put_real(std::string& s, double v, int precision) {
  char buf[64];
  const auto r = precision >= 17 ? std::to_chars(buf, buf + sizeof buf, v)
                                 : std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, precision);
  s.append(buf, r.ptr);
}

void put_int(std::string& s, long long v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  s.append(buf, r.ptr);
}

namespace {
void put_le(std::string& s, std::uint64_t v, int bytes) {
  for (int k = 0; k < bytes; ++k) s += static_cast<char>((v >> (8 * k)) & 0xFF);
}
}  // namespace

void put_u16le(std::string& s, std::uint16_t v) { put_le(s, v, 2); }
void put_u32le(std::string& s, std::uint32_t v) { put_le(s, v, 4); }
void put_f32le(std::string& s, float v) {
  std::uint32_t u = 0;
  std::memcpy(&u, &v, 4);
  put_le(s, u, 4);
}
void put_f64le(std::string& s, double v) {
  std::uint64_t u = 0;
  std::memcpy(&u, &v, 8);
  put_le(s, u, 8);
}

}  // namespace vpffd::io_detail
