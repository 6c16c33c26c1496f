// STL written by vpffd: every face as a facet of its three corner positions, with
// the unit normal of the triangle as given ((b - a) x (c - a), zero for a
// degenerate one); STL has no shared vertices and no vertex normals. Binary STL
// stores float32 by the format's definition, so write_mesh refuses coordinates
// beyond its range first; ASCII keeps `precision` digits. The binary header does
// not start with "solid", which some readers take for the ASCII keyword.

#include <cmath>
#include <cstring>

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {
namespace {

// In float64 from the float64 positions, then rounded once for binary files.
Eigen::Vector3d facet_normal(const ConstV& V, const ConstF& F, Index f) {
  const Eigen::Vector3d a = V.row(F(f, 0)).transpose(), b = V.row(F(f, 1)).transpose(),
                        c = V.row(F(f, 2)).transpose();
  const Eigen::Vector3d u = b - a, w = c - a;
  const Eigen::Vector3d n(u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]);
  const double len = n.norm();
  return len > 0 && std::isfinite(len) ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}

}  // namespace

std::string format_stl(const ConstV& V, const ConstF& F, bool binary, int precision) {
  std::string s;
  if (binary) {
    char head[80];
    std::memset(head, ' ', sizeof head);
    const char* text = "binary STL written by vpffd";
    std::memcpy(head, text, std::strlen(text));
    s.reserve(84 + static_cast<std::size_t>(F.rows()) * 50);
    s.append(head, sizeof head);
    put_u32le(s, static_cast<std::uint32_t>(F.rows()));
    for (Index f = 0; f < F.rows(); ++f) {
      const Eigen::Vector3d n = facet_normal(V, F, f);
      for (int c = 0; c < 3; ++c) put_f32le(s, static_cast<float>(n[c]));
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) put_f32le(s, static_cast<float>(V(F(f, k), c)));
      put_u16le(s, 0);
    }
    return s;
  }
  s.reserve(32 + static_cast<std::size_t>(F.rows()) * 300);
  s += "solid vpffd\n";
  for (Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d n = facet_normal(V, F, f);
    s += "facet normal";
    for (int c = 0; c < 3; ++c) s += ' ', put_real(s, n[c], precision);
    s += "\n  outer loop\n";
    for (int k = 0; k < 3; ++k) {
      s += "    vertex";
      for (int c = 0; c < 3; ++c) s += ' ', put_real(s, V(F(f, k), c), precision);
      s += '\n';
    }
    s += "  endloop\nendfacet\n";
  }
  s += "endsolid vpffd\n";
  return s;
}

}  // namespace vpffd::io_detail
