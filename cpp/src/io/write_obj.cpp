// OBJ written by vpffd: one "v" line per vertex, one "vn" line per vertex normal
// when there are normals (face corners then name vertex and normal alike,
// "f a//a b//b c//c"), one "f" line per face, 1-based as the format counts.

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {

std::string format_obj(const ConstV& V, const ConstF& F, const ConstV& N, int precision) {
  const bool normals = N.rows() > 0;
  std::string s;
  s.reserve(static_cast<std::size_t>(V.rows()) * (normals ? 120 : 60) + static_cast<std::size_t>(F.rows()) * 40);
  s += "# written by vpffd\n";
  for (Index v = 0; v < V.rows(); ++v) {
    s += "v";
    for (int c = 0; c < 3; ++c) s += ' ', put_real(s, V(v, c), precision);
    s += '\n';
  }
  for (Index v = 0; normals && v < N.rows(); ++v) {
    s += "vn";
    for (int c = 0; c < 3; ++c) s += ' ', put_real(s, N(v, c), precision);
    s += '\n';
  }
  for (Index f = 0; f < F.rows(); ++f) {
    s += "f";
    for (int c = 0; c < 3; ++c) {
      s += ' ';
      put_int(s, F(f, c) + 1LL);
      if (normals) s += "//", put_int(s, F(f, c) + 1LL);
    }
    s += '\n';
  }
  return s;
}

}  // namespace vpffd::io_detail
