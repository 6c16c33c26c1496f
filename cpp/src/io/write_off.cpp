// OFF written by vpffd. ASCII: "OFF" (or "NOFF" with normals, "x y z nx ny nz"
// per vertex), the counts "#V #F 0", then "3 a b c" per face. Binary: the layout
// OpenMesh writes and read_off reads ("[N]OFF BINARY\n", little-endian uint32
// counts #V #F 0, float32 x y z [nx ny nz] per vertex, "uint32 3, 3 x uint32" per
// face); float32, so write_mesh refuses coordinates beyond its range first.

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {

void put_ascii_body(std::string& s, const ConstV& V, const ConstF& F, const ConstV& N, int precision) {
  const bool normals = N.rows() > 0;
  for (Index v = 0; v < V.rows(); ++v) {
    for (int c = 0; c < 3; ++c) {
      if (c) s += ' ';
      put_real(s, V(v, c), precision);
    }
    for (int c = 0; normals && c < 3; ++c) s += ' ', put_real(s, N(v, c), precision);
    s += '\n';
  }
  for (Index f = 0; f < F.rows(); ++f) {
    s += '3';
    for (int c = 0; c < 3; ++c) s += ' ', put_int(s, F(f, c));
    s += '\n';
  }
}

std::string format_off(const ConstV& V, const ConstF& F, const ConstV& N, bool binary, int precision) {
  const bool normals = N.rows() > 0;
  std::string s;
  s += normals ? "NOFF" : "OFF";
  if (binary) {
    s += " BINARY\n";
    s.reserve(s.size() + 12 + static_cast<std::size_t>(V.rows()) * (normals ? 24 : 12) +
              static_cast<std::size_t>(F.rows()) * 16);
    put_u32le(s, static_cast<std::uint32_t>(V.rows()));
    put_u32le(s, static_cast<std::uint32_t>(F.rows()));
    put_u32le(s, 0);
    for (Index v = 0; v < V.rows(); ++v) {
      for (int c = 0; c < 3; ++c) put_f32le(s, static_cast<float>(V(v, c)));
      for (int c = 0; normals && c < 3; ++c) put_f32le(s, static_cast<float>(N(v, c)));
    }
    for (Index f = 0; f < F.rows(); ++f) {
      put_u32le(s, 3);
      for (int c = 0; c < 3; ++c) put_u32le(s, static_cast<std::uint32_t>(F(f, c)));
    }
    return s;
  }
  s += '\n';
  s.reserve(static_cast<std::size_t>(V.rows()) * (normals ? 120 : 60) + static_cast<std::size_t>(F.rows()) * 32);
  put_int(s, V.rows());
  s += ' ';
  put_int(s, F.rows());
  s += " 0\n";
  put_ascii_body(s, V, F, N, precision);
  return s;
}

}  // namespace vpffd::io_detail
