#pragma once
// Helpers shared by the readers and writers of cpp/src/io (internal; not
// installed): error messages that are always valid UTF-8, tokenising text lines,
// whole-token number parsing, a bounded little/big-endian byte reader, the memory
// check every reader applies to the counts a header announces, and the
// locale-independent number formatting of the writers.

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "vpffd/core/exceptions.h"

namespace vpffd::io_detail {

/// Throws MeshIOError "what: 'shown': why". `shown` is the file name as display_name made it.
[[noreturn]] void fail(const std::string& what, const std::string& shown, const std::string& why);

/// The file name for messages: valid UTF-8 sequences are kept, every other byte
/// (a name in Latin-1, random bytes) and every control character becomes \xNN,
/// so that the message can always be decoded (Python's str) and printed.
std::string display_name(const std::string& path);

/// A token or line for an error message: quoted, cut after 60 bytes, bytes
/// outside printable ASCII written as \xNN.
std::string quote(const std::string& tok);

/// Any text for a message (e.g. OpenMesh's own), made valid UTF-8 like display_name.
std::string printable(const std::string& text);

std::string lower(std::string s);

/// Whitespace-separated tokens of a line, optionally dropping a '#' comment.
std::vector<std::string> tokens_of(const std::string& line, bool comments);

/// The whole token must be a number ("1x", "x", "" are not).
bool parse_double(const std::string& tok, double& v);
bool parse_int(const std::string& tok, long long& v);

std::string at_line(long long n);

/// A text file read line by line (1-based line numbers, '\r' dropped). A line
/// longer than max_line bytes throws MeshIOError naming `shown` (a binary file
/// read as text would otherwise be held in memory whole). A UTF-8 byte-order mark
/// before the first line is dropped; UTF-16 text is refused.
class Lines {
 public:
  Lines(const std::string& file, const std::string& shown) : in_(file, std::ios::binary), shown_(shown) {}
  bool next(std::string& line);
  long long number() const { return number_; }
  bool ok() const { return static_cast<bool>(in_) || in_.eof(); }
  static constexpr std::size_t max_line = 1 << 20;

 private:
  std::ifstream in_;
  std::string shown_;
  long long number_ = 0;
};

/// Reads fixed-size numbers from a byte buffer; every read is checked against
/// the bytes left, so no count taken from the file can make it read past the end.
class Bytes {
 public:
  Bytes(const unsigned char* data, std::size_t size, bool big_endian = false)
      : p_(data), n_(size), big_(big_endian) {}
  std::size_t left() const { return n_ - at_; }
  std::size_t offset() const { return at_; }
  bool skip(std::uint64_t k) {
    if (k > left()) return false;
    at_ += static_cast<std::size_t>(k);
    return true;
  }
  /// Unsigned integer of `bytes` bytes (1, 2, 4 or 8); false at the end of the data.
  bool uint(int bytes, std::uint64_t& v);
  bool f32(double& v);
  bool f64(double& v);

 private:
  const unsigned char* p_;
  std::size_t n_, at_ = 0;
  bool big_;
};

/// Reads a whole (small enough) file into memory. Throws MeshIOError on a read error.
std::vector<unsigned char> read_all(const std::string& file, const std::string& shown);

/// Refuses a file whose header announces more elements than its bytes can hold:
/// `need` is the least number of bytes `count` elements take in this encoding,
/// computed without overflow by the caller's helper below.
std::uint64_t times(std::uint64_t count, std::uint64_t each);  // saturates at UINT64_MAX

/// Appends `v` as decimal text, whatever the C locale: precision 17 writes the
/// shortest text that reads back to exactly `v` (never more than 17 significant
/// digits), 1..16 writes printf's "%.{precision}g".
void put_real(std::string& s, double v, int precision);
void put_int(std::string& s, long long v);
/// Appends the little-endian bytes of a value, whatever the host's byte order.
void put_u16le(std::string& s, std::uint16_t v);
void put_u32le(std::string& s, std::uint32_t v);
void put_f32le(std::string& s, float v);
void put_f64le(std::string& s, double v);

}  // namespace vpffd::io_detail
