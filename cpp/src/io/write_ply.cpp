// PLY written by vpffd, ASCII or binary little-endian: vertex coordinates (and
// normals nx ny nz) as "double", so that a file read back gives the very same
// float64 values; faces as "list uchar int vertex_indices", which every PLY
// reader takes.

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {

std::string format_ply(const ConstV& V, const ConstF& F, const ConstV& N, bool binary, int precision) {
  const bool normals = N.rows() > 0;
  std::string s = "ply\nformat ";
  s += binary ? "binary_little_endian" : "ascii";
  s += " 1.0\ncomment written by vpffd\nelement vertex ";
  put_int(s, V.rows());
  s += "\nproperty double x\nproperty double y\nproperty double z\n";
  if (normals) s += "property double nx\nproperty double ny\nproperty double nz\n";
  s += "element face ";
  put_int(s, F.rows());
  s += "\nproperty list uchar int vertex_indices\nend_header\n";
  if (binary) {
    s.reserve(s.size() + static_cast<std::size_t>(V.rows()) * (normals ? 48 : 24) +
              static_cast<std::size_t>(F.rows()) * 13);
    for (Index v = 0; v < V.rows(); ++v) {
      for (int c = 0; c < 3; ++c) put_f64le(s, V(v, c));
      for (int c = 0; normals && c < 3; ++c) put_f64le(s, N(v, c));
    }
    for (Index f = 0; f < F.rows(); ++f) {
      s += '\3';
      for (int c = 0; c < 3; ++c) put_u32le(s, static_cast<std::uint32_t>(F(f, c)));
    }
    return s;
  }
  s.reserve(s.size() + static_cast<std::size_t>(V.rows()) * (normals ? 120 : 60) +
            static_cast<std::size_t>(F.rows()) * 32);
  put_ascii_body(s, V, F, N, precision);
  return s;
}

}  // namespace vpffd::io_detail
