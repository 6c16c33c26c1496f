// OpenMesh's binary OM format, read by vpffd itself.
//
// Why not OpenMesh's OMReader behind a validating pre-parse: its trouble is not
// only the chunk layout (asserts on dimensions, counts read past the end,
// allocations sized by the header) but the meaning of the data. Since OM 2.0 the
// faces are stored as halfedge topology (next halfedge, target vertex, face per
// halfedge; one halfedge per face), which OMReader copies into OpenMesh's kernel
// unchecked: a `next` pointer out of range, a cycle that never returns to the
// face's halfedge or a face index past the end crash or hang every later walk
// (vpffd's read_mesh segfaulted in fv_range). Validating that topology before
// OMReader sees it means decoding all of it, i.e. writing this reader anyway,
// and then trusting OMReader to decode it the same way. So vpffd decodes the
// chunks itself, checks each size against the bytes left before touching the
// data, and walks every face loop with a step bound and range checks. Only the
// chunks a triangle mesh needs are interpreted (vertex positions and normals,
// face topology, halfedge topology); the others (status, colours, texture
// coordinates, custom properties) are skipped by their size.
//
// Layout (little-endian): "OM", mesh kind ('T', 'Q', 'P'), version byte
// (major << 5 | minor), uint32 #V #F #E; then chunks, each a uint16 header
// (bit 1 named, bits 2-4 entity, 5-8 type, 9 signed, 10 float, 11-13 dim-1,
// 14-15 size code), an optional name (uint8 length + bytes), and the data.

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "io_util.h"
#include "readers.h"

namespace vpffd::io_detail {
namespace {

enum Entity { kVertex = 0, kMesh = 1, kFace = 2, kEdge = 4, kHalfedge = 6, kSentinel = 7 };
enum Type { kPos = 0, kNormal = 1, kTexcoord = 2, kStatus = 3, kColor = 4, kCustom = 6, kTopology = 7 };

struct ChunkHeader {
  bool named;
  unsigned entity, type, is_signed, is_float, dim, bits;
  // Bytes of one scalar: integers 1, 2, 4, 8; floats 4, 8, 16.
  unsigned scalar() const { return is_float ? (4u << bits) : (1u << bits); }
};

ChunkHeader decode(std::uint64_t h) {
  ChunkHeader c{};
  c.named = (h >> 1) & 1;
  c.entity = (h >> 2) & 7;
  c.type = (h >> 5) & 15;
  c.is_signed = (h >> 9) & 1;
  c.is_float = (h >> 10) & 1;
  c.dim = ((h >> 11) & 7) + 1;
  c.bits = (h >> 14) & 3;
  return c;
}

std::uint8_t version(unsigned major, unsigned minor) { return static_cast<std::uint8_t>((major & 7) << 5 | (minor & 31)); }

// The newest OM version this reader knows (OpenMesh 9 writes 2.2).
constexpr unsigned kMaxMajor = 2, kMaxMinor = 2;

class OmReader {
 public:
  OmReader(const std::vector<unsigned char>& data, const std::string& shown)
      : in_(data.data(), data.size()), shown_(shown) {}

  void read(MeshData& out) {
    std::uint64_t magic = 0;
    if (in_.left() < 16) bad("the file is truncated: an OM header has 16 bytes");
    in_.uint(2, magic);
    if (magic != ('M' << 8 | 'O')) bad("not an OM file (it does not start with 'OM')");
    std::uint64_t kind = 0, ver = 0;
    in_.uint(1, kind);
    in_.uint(1, ver);
    kind_ = static_cast<char>(kind);
    version_ = static_cast<std::uint8_t>(ver);
    if (kind_ != 'T' && kind_ != 'Q' && kind_ != 'P')
      bad("unknown OM mesh kind " + quote(std::string(1, kind_)) + " (expected T, Q or P)");
    if ((version_ >> 5) > kMaxMajor || version_ > version(kMaxMajor, kMaxMinor) || version_ < version(1, 0))
      bad("unsupported OM version " + std::to_string(version_ >> 5) + "." + std::to_string(version_ & 31));
    in_.uint(4, nV_);
    in_.uint(4, nF_);
    in_.uint(4, nE_);
    constexpr auto kMax = static_cast<std::uint64_t>(std::numeric_limits<int>::max());
    if (nV_ > kMax || nF_ > kMax || nE_ > kMax / 2)
      bad("the header's counts (" + counts() + ") are too large");
    // Positions alone take 12 bytes per vertex, a face at least 1 byte.
    const std::uint64_t least = times(nV_, 12) + nF_;
    if (least > in_.left())
      bad("the header announces " + counts() + ", which take at least " + std::to_string(least) +
          " bytes; the file has " + std::to_string(in_.left()) + " after the header");

    while (in_.left() > 0) {
      std::uint64_t raw = 0;
      if (!in_.uint(2, raw)) bad("the file is truncated inside a chunk header");
      const ChunkHeader c = decode(raw);
      if (c.entity == kSentinel) break;
      if (c.named) name();
      chunk(c);
    }
    build(out);
  }

 private:
  [[noreturn]] void bad(const std::string& why) const { fail("load_mesh", shown_, why); }

  std::string counts() const {
    return std::to_string(nV_) + " vertices, " + std::to_string(nF_) + " faces, " + std::to_string(nE_) + " edges";
  }
  std::string where() const { return "at byte " + std::to_string(in_.offset()) + ": "; }

  void name() {
    std::uint64_t n = 0;
    if (!in_.uint(1, n) || !in_.skip(n)) bad(where() + "the file is truncated inside a property name");
  }

  std::uint64_t elements(unsigned entity) const {
    switch (entity) {
      case kVertex: return nV_;
      case kFace: return nF_;
      case kEdge: return nE_;
      case kHalfedge: return 2 * nE_;
      case kMesh: return 1;
      default: return 0;
    }
  }

  // Checks that `count` items of `each` bytes are there before they are read.
  void need(std::uint64_t count, std::uint64_t each, const char* what) {
    const std::uint64_t n = times(count, each);
    if (n > in_.left())
      bad(where() + std::string(what) + " needs " + std::to_string(n) + " bytes (" + std::to_string(count) + " x " +
          std::to_string(each) + "), the file has " + std::to_string(in_.left()) + " left");
  }

  std::int64_t integer(unsigned bytes) {
    std::uint64_t u = 0;
    in_.uint(static_cast<int>(bytes), u);
    if (bytes < 8 && (u >> (8 * bytes - 1)) & 1) u |= ~std::uint64_t{0} << (8 * bytes);  // sign-extend
    return static_cast<std::int64_t>(u);
  }

  void chunk(const ChunkHeader& c) {
    if (c.entity != kVertex && c.entity != kMesh && c.entity != kFace && c.entity != kEdge && c.entity != kHalfedge)
      bad(where() + "unknown chunk entity " + std::to_string(c.entity) + " (a corrupt chunk header)");
    const std::uint64_t n = elements(c.entity);
    if (c.type == kCustom) {
      // [type name, OM > 2.1] uint32 block size, block.
      if (version_ > version(2, 1)) name();
      std::uint64_t block = 0;
      if (!in_.uint(4, block) || !in_.skip(block)) bad(where() + "the file is truncated inside a custom property");
      return;
    }
    if (c.type == kTopology) return topology(c, n);
    const std::uint64_t each = c.type == kStatus ? 4 : std::uint64_t{c.dim} * c.scalar();
    need(n, each, "a chunk");
    if (c.entity == kVertex && (c.type == kPos || c.type == kNormal)) {
      if (!c.is_float || c.dim != 3 || c.bits > 1)
        bad(where() + "vertex " + (c.type == kPos ? "positions" : "normals") + " must be 3 float32 or float64");
      std::vector<double>& dst = c.type == kPos ? V_ : N_;
      dst.resize(static_cast<std::size_t>(3 * n));
      for (double& x : dst) c.bits ? in_.f64(x) : in_.f32(x);
      if (c.type == kPos) have_pos_ = true;
      return;
    }
    in_.skip(n * each);  // colours, texture coordinates, status, face normals, ...
  }

  void topology(const ChunkHeader& c, std::uint64_t n) {
    // Integer bytes. (OpenMesh's writer sets the float flag on some topology
    // chunks; its reader, like this one, reads them as integers regardless.)
    const unsigned isz = 1u << c.bits;
    if (c.entity == kVertex) {  // vertex -> outgoing halfedge: not needed for the faces
      need(n, isz, "the vertex topology");
      in_.skip(n * isz);
    } else if (c.entity == kFace && version_ < version(2, 0)) {
      // Faces as vertex indices: 3 ('T'), 4 ('Q') or a uint16 count ('P') each.
      faces_by_index_ = true;
      for (std::uint64_t f = 0; f < n; ++f) {
        std::uint64_t k = kind_ == 'T' ? 3 : 4;
        if (kind_ == 'P' && !in_.uint(2, k)) bad(where() + "the file is truncated inside face " + std::to_string(f));
        need(k, isz, "a face");
        poly_.clear();
        for (std::uint64_t j = 0; j < k; ++j) {
          std::uint64_t i = 0;
          in_.uint(static_cast<int>(isz), i);
          poly_.push_back(i);
        }
        add_polygon(f);
      }
    } else if (c.entity == kFace) {  // face -> one of its halfedges
      need(n, isz, "the face topology");
      face_he_.resize(static_cast<std::size_t>(n));
      for (auto& h : face_he_) h = integer(isz);
    } else if (c.entity == kHalfedge) {  // per edge: (next, to-vertex, face) of both halfedges
      need(nE_, 6ull * isz, "the halfedge topology");
      next_.resize(static_cast<std::size_t>(2 * nE_));
      to_.resize(next_.size());
      face_.resize(next_.size());
      for (std::size_t h = 0; h < next_.size(); ++h) {
        next_[h] = integer(isz);
        to_[h] = integer(isz);
        face_[h] = integer(isz);
      }
    } else {
      bad(where() + "a topology chunk for an unexpected entity");
    }
  }

  // Appends the polygon in poly_ as a fan, checking its indices.
  void add_polygon(std::uint64_t f) {
    ++polygons_;
    for (std::uint64_t i : poly_)
      if (i >= nV_)
        bad("face " + std::to_string(f) + " refers to vertex " + std::to_string(i) + ", but the file has " +
            std::to_string(nV_) + " vertices");
    if (poly_.size() < 3) {
      ++skipped_;
      return;
    }
    if (poly_.size() > 3) ++triangulated_;
    for (std::size_t k = 1; k + 1 < poly_.size(); ++k)
      tris_.insert(tris_.end(), {static_cast<int>(poly_[0]), static_cast<int>(poly_[k]), static_cast<int>(poly_[k + 1])});
  }

  // OM >= 2.0: each face's corners are the target vertices of its halfedge loop,
  // from the face's halfedge on (OpenMesh's face-vertex order). The loop must
  // stay in range, belong to the face and close within #halfedges steps.
  void faces_from_halfedges() {
    const auto nH = static_cast<std::int64_t>(next_.size());
    if (!face_he_.empty() && nH == 0) bad("the faces refer to halfedges, but the file has no halfedge topology");
    for (std::size_t f = 0; f < face_he_.size(); ++f) {
      const std::int64_t h0 = face_he_[f];
      auto corrupt = [&](const std::string& why) {
        bad("corrupt topology: face " + std::to_string(f) + ": " + why);
      };
      if (h0 < 0 || h0 >= nH) corrupt("its halfedge " + std::to_string(h0) + " is not in [0, " + std::to_string(nH) + ")");
      poly_.clear();
      std::int64_t h = h0;
      do {
        if (face_[static_cast<std::size_t>(h)] != static_cast<std::int64_t>(f))
          corrupt("halfedge " + std::to_string(h) + " of its loop belongs to face " +
                  std::to_string(face_[static_cast<std::size_t>(h)]));
        const std::int64_t v = to_[static_cast<std::size_t>(h)];
        if (v < 0 || static_cast<std::uint64_t>(v) >= nV_)
          corrupt("halfedge " + std::to_string(h) + " points to vertex " + std::to_string(v) + ", but the file has " +
                  std::to_string(nV_) + " vertices");
        poly_.push_back(static_cast<std::uint64_t>(v));
        if (static_cast<std::int64_t>(poly_.size()) > nH) corrupt("its halfedge loop does not close");
        h = next_[static_cast<std::size_t>(h)];
        if (h < 0 || h >= nH) corrupt("a next halfedge " + std::to_string(h) + " is not in [0, " + std::to_string(nH) + ")");
      } while (h != h0);
      add_polygon(f);
    }
  }

  void build(MeshData& out) {
    if (!have_pos_) bad("no vertex positions (no position chunk)");
    if (faces_by_index_ && !face_he_.empty()) bad("faces are stored twice (as vertex indices and as halfedges)");
    if (!faces_by_index_) faces_from_halfedges();
    if (static_cast<std::uint64_t>(polygons_) != nF_)
      bad("the header announces " + std::to_string(nF_) + " faces, the file has " + std::to_string(polygons_));
    out.polygons = polygons_;
    out.triangulated_polygons = triangulated_;
    out.skipped_faces = skipped_;
    finish_mesh(shown_, V_, tris_, out);
    if (!N_.empty()) {
      out.N.resize(static_cast<Index>(nV_), 3);
      for (Index v = 0; v < static_cast<Index>(nV_); ++v)
        for (int k = 0; k < 3; ++k) out.N(v, k) = N_[static_cast<std::size_t>(3 * v + k)];
      if (!out.N.allFinite()) out.N.resize(0, 3);  // unusable normals are dropped, not fatal
    }
  }

  Bytes in_;
  std::string shown_;
  char kind_ = 0;
  std::uint8_t version_ = 0;
  std::uint64_t nV_ = 0, nF_ = 0, nE_ = 0;
  bool have_pos_ = false, faces_by_index_ = false;
  std::vector<double> V_, N_;
  std::vector<std::int64_t> face_he_, next_, to_, face_;
  std::vector<std::uint64_t> poly_;
  std::vector<int> tris_;
  Index polygons_ = 0, triangulated_ = 0, skipped_ = 0;
};

}  // namespace

void read_om(const std::string& file, const std::string& shown, std::uint64_t, MeshData& out) {
  const std::vector<unsigned char> data = read_all(file, shown);
  OmReader(data, shown).read(out);
}

}  // namespace vpffd::io_detail
