// Carrying fans and rings from one processing order to the next (ffd/reorder.h), and
// the shortcuts of Deformer::set_rest_vertices built on them: every result must be
// that of a fresh Deformer on the moved mesh, bit for bit.

#include <algorithm>
#include <numeric>
#include <random>

#include "helpers.h"
#include "vpffd/ffd/reorder.h"

using namespace vpffd;
using namespace vpffd::test;

namespace {

std::vector<std::int32_t> random_order(Index n, std::mt19937& rng) {
  std::vector<std::int32_t> o(n);
  std::iota(o.begin(), o.end(), 0);
  std::shuffle(o.begin(), o.end(), rng);
  return o;
}

/// The same mesh moved: every vertex by `d`, plus a small wobble (amplitude `wobble`).
RowMatrixX3d moved(const RowMatrixX3d& V, const Vector3d& d, double wobble) {
  RowMatrixX3d X = V;
  for (Index v = 0; v < V.rows(); ++v)
    X.row(v) += d.transpose() + wobble * Eigen::RowVector3d(std::sin(3.0 * v), std::cos(5.0 * v), std::sin(7.0 * v));
  return X;
}

/// Everything a frame reads from the rest mesh, compared bit for bit.
void expect_same_deformer(const Deformer& D, const Deformer& fresh, const RowMatrixX3d& X, const RowMatrixX3d& P) {
  EXPECT_EQ(D.processing_order(), fresh.processing_order());
  EXPECT_EQ(D.face_processing_order(), fresh.face_processing_order());
  EXPECT_EQ(D.processing_faces(), fresh.processing_faces());
  EXPECT_EQ(D.part_start(), fresh.part_start());
  EXPECT_EQ(D.rest_volume(true), fresh.rest_volume(true));
  if (D.has_parts()) EXPECT_EQ(D.rest_part_volumes(), fresh.rest_part_volumes());
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(D.processing_embedding().span[a], fresh.processing_embedding().span[a]);
    EXPECT_EQ(D.processing_embedding().tau[a], fresh.processing_embedding().tau[a]);
    // The weights come from the fans (closed) or rings (open): equal coefficients
    // mean equal lists in the same order.
    const AxisCoefficients c = D.volume_coefficients(X, a), f = fresh.volume_coefficients(X, a);
    EXPECT_EQ(c.alpha, f.alpha);
    EXPECT_EQ(c.volume, f.volume);
  }
  CorrectionOptions o;
  o.allow_open = !D.is_closed();
  const DeformResult a = D.deform(P, o), b = fresh.deform(P, o);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.volume, b.volume);
  EXPECT_EQ(a.part_volumes, b.part_volumes);
}

/// A closed UV sphere: `segments` triangles at each pole (valence `segments` there,
/// fans longer than any padded row), valence 4-6 elsewhere.
TriMesh uv_sphere(int rings, int segments) {
  TriMesh m;
  const Index nv = 2 + Index(rings - 1) * segments;
  m.V.resize(nv, 3);
  m.V.row(0) << 0, 0, 1;
  m.V.row(nv - 1) << 0, 0, -1;
  auto idx = [&](int i, int j) { return static_cast<int>(1 + Index(i - 1) * segments + (j % segments)); };
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double t = M_PI * i / rings, p = 2 * M_PI * j / segments;
      m.V.row(idx(i, j)) << std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t);
    }
  std::vector<Eigen::RowVector3i> F;
  const int south = static_cast<int>(nv - 1);
  for (int j = 0; j < segments; ++j) {
    F.emplace_back(0, idx(1, j), idx(1, j + 1));
    for (int i = 1; i + 1 < rings; ++i) {
      F.emplace_back(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1));
      F.emplace_back(idx(i, j), idx(i + 1, j + 1), idx(i, j + 1));
    }
    F.emplace_back(idx(rings - 1, j), south, idx(rings - 1, j + 1));
  }
  m.F.resize(Index(F.size()), 3);
  for (size_t f = 0; f < F.size(); ++f) m.F.row(Index(f)) = F[f];
  return m;
}

/// Two spheres 2.5 apart along x (two components), and a lattice periodic along x with a
/// "shift" seam for them to travel past.
/// n unit icospheres (subdivided `level` times), 2.5 apart along x (one part each).
TriMesh sphere_row(int n, int level = 2) {
  const TriMesh s = icosphere(level);
  const Index nv = s.V.rows(), nf = s.F.rows();
  TriMesh m;
  m.V.resize(n * nv, 3);
  m.F.resize(n * nf, 3);
  for (int k = 0; k < n; ++k) {
    m.V.middleRows(k * nv, nv) = s.V.rowwise() + Eigen::RowVector3d(2.5 * k, 0, 0);
    m.F.middleRows(k * nf, nf) = s.F.array() + int(k * nv);
  }
  return m;
}

TriMesh two_spheres() { return sphere_row(2); }

/// f() must be refused with an InvalidInputError whose message names `word`.
template <class F>
void expect_refusal_naming(F&& f, const char* word) {
  try {
    f();
    ADD_FAILURE() << "taken, not refused";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
}

Lattice shift_seam_lattice() {
  return make_lattice(Vector3d(-1.5, -1.5, -1.5), Vector3d(5.5, 1.5, 1.5), {8, 4, 4}, {3, 2, 2},
                      {Seam::Shift, Seam::None, Seam::None});
}

}  // namespace

TEST(Reorder, CountingSortIsTheStableSortForAnyThreadCount) {
  // The threaded sort counts and places contiguous chunks of items: its order must be
  // the one stable sort by key, for few keys, many keys and more keys than items.
  std::mt19937 rng(3);
  for (const Index n_keys : {Index(1), Index(7), Index(729), Index(40000), Index(300000)})
    for (const Index n : {Index(1000), Index(100003), Index(250000)}) {
      std::vector<std::int32_t> key(n);
      for (auto& k : key) k = static_cast<std::int32_t>(rng() % n_keys);
      std::vector<std::int32_t> want(n);
      std::iota(want.begin(), want.end(), 0);
      std::stable_sort(want.begin(), want.end(), [&](std::int32_t a, std::int32_t b) { return key[a] < key[b]; });
      for (int threads : {1, 2, 3, 8}) ASSERT_EQ(counting_sort(key, n_keys, threads), want) << n << " " << n_keys;
    }
}

TEST(Reorder, OrderWithinRunsSortsEachRunStablyByKey) {
  // Runs of 1 to 5,000 items (short ones sorted by insertion, long ones by counting),
  // keys from few to all 256 values: each run's positions, stably sorted by the key of
  // their item, for any thread count.
  std::mt19937 rng(5);
  for (const int n_keys : {1, 4, 64, 256}) {
    std::vector<Index> start{0};
    while (start.back() < 60000) {
      const Index len = rng() % 3 == 0 ? 1 + Index(rng() % 5000) : 1 + Index(rng() % 40);
      start.push_back(start.back() + len);
    }
    const Index n = start.back();
    const std::vector<std::int32_t> order = random_order(n, rng);
    std::vector<std::uint8_t> key(n);
    for (auto& k : key) k = static_cast<std::uint8_t>(rng() % n_keys);
    std::vector<std::int32_t> want(n);
    std::iota(want.begin(), want.end(), 0);
    for (size_t r = 0; r + 1 < start.size(); ++r)
      std::stable_sort(want.begin() + start[r], want.begin() + start[r + 1],
                       [&](std::int32_t a, std::int32_t b) { return key[order[a]] < key[order[b]]; });
    for (int threads : {1, 2, 3, 8}) ASSERT_EQ(order_within_runs(start, order, key, threads), want) << n_keys;
  }
  EXPECT_TRUE(order_within_runs({0}, {}, {}, 2).empty());
}

TEST(Reorder, ListsAndFansRelabelledAlikeForAnyThreadCount) {
  // Lists of 0 to 11 items over more lists than one chunk: the chunks find their
  // offsets in parallel.
  std::mt19937 rng(7);
  const Index n = 50001;
  std::vector<std::int32_t> indptr{0}, items;
  for (Index i = 0; i < n; ++i) {
    const int len = static_cast<int>(rng() % 12);
    for (int k = 0; k < len; ++k) items.push_back(static_cast<std::int32_t>(rng() % n));
    indptr.push_back(static_cast<std::int32_t>(items.size()));
  }
  const std::vector<std::int32_t> from = random_order(n, rng), to = random_order(n, rng);
  std::vector<std::int32_t> want_ptr{0}, want;
  for (Index i = 0; i < n; ++i) {
    for (std::int32_t p = indptr[from[i]]; p < indptr[from[i] + 1]; ++p) want.push_back(to[items[p]]);
    want_ptr.push_back(static_cast<std::int32_t>(want.size()));
  }
  for (int threads : {1, 2, 3}) {
    std::vector<std::int32_t> got_ptr, got;
    permute_lists(indptr, items, 1, from, to, got_ptr, got, threads);
    ASSERT_EQ(got_ptr, want_ptr) << threads;
    ASSERT_EQ(got, want) << threads;
  }
  // relabel_fans: the entries through `to`, the rows where they are (padding included).
  const TriMesh m = icosphere(4);
  const Index nv = m.V.rows();
  const VertexFans fans = vertex_fans(vertex_rings(m.F, nv));
  const std::vector<std::int32_t> rows = random_order(nv, rng), relabel = random_order(nv, rng);
  std::vector<std::int32_t> identity(nv);
  std::iota(identity.begin(), identity.end(), 0);
  for (int width : {3, 7, 9}) {
    // Rows in another order than their vertices, padded with their own vertex.
    const PaddedFans p = pad_fans(permute_fans(fans, rows, identity), width, 1, rows.data());
    for (Index j = 0; j < nv; ++j) {
      const Index len = fans.indptr[rows[j] + 1] - fans.indptr[rows[j]];
      for (Index k = 0; k < width; ++k)
        ASSERT_EQ(p.head[j * width + k], k < len ? fans.fan[fans.indptr[rows[j]] + k] : rows[j]) << j;
    }
    const PaddedFans want_fans = permute_fans(p, identity, relabel, 1);
    for (int threads : {1, 2}) {
      PaddedFans got_fans = p;
      relabel_fans(got_fans, relabel, threads);
      EXPECT_EQ(got_fans.head, want_fans.head) << width;
      EXPECT_EQ(got_fans.tail_ptr, want_fans.tail_ptr) << width;
      EXPECT_EQ(got_fans.tail, want_fans.tail) << width;
    }
  }
}

TEST(Reorder, RelabelledFansComposeAndChainTheirRings) {
  std::mt19937 rng(3);
  const TriMesh m = icosphere(2);
  const Index nv = m.V.rows();
  const VertexFans base = vertex_fans(vertex_rings(m.F, nv));
  const std::vector<std::int32_t> o1 = random_order(nv, rng), r1 = inverse_order(o1);
  const std::vector<std::int32_t> o2 = random_order(nv, rng), r2 = inverse_order(o2);
  // Two relabellings in a row equal one: what set_rest_vertices relies on.
  std::vector<std::int32_t> from(nv), to(nv);
  for (Index i = 0; i < nv; ++i) {
    from[i] = r1[o2[i]];
    to[i] = r2[o1[i]];
  }
  const VertexFans once = permute_fans(base, o2, r2), twice = permute_fans(permute_fans(base, o1, r1), from, to, 2);
  EXPECT_EQ(once.indptr, twice.indptr);
  EXPECT_EQ(once.fan, twice.fan);
  // The padded layout relabelled (what a Deformer keeps) equals the relabelled fans
  // padded afresh, rows and tails, for rows shorter and longer than the fans.
  for (int width : {2, 6, 9}) {
    const PaddedFans want = pad_fans(once, width);
    const PaddedFans got = permute_fans(permute_fans(pad_fans(base, width), o1, r1), from, to, 2);
    EXPECT_EQ(got.width, width);
    EXPECT_EQ(got.head, want.head) << width;
    EXPECT_EQ(got.tail_ptr, want.tail_ptr) << width;
    EXPECT_EQ(got.tail, want.tail) << width;
  }
  // A relabelled fan is a fan of the relabelled mesh: its consecutive pairs are the
  // vertex's ring pairs (each face around it once, in its winding).
  RowMatrixX3i G(m.F.rows(), 3);
  for (Index f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) G(f, c) = r2[m.F(f, c)];
  const VertexRings rings = vertex_rings(G, nv);
  for (Index i = 0; i < nv; ++i) {
    std::vector<std::pair<int, int>> want, got;
    for (int p = rings.indptr[i]; p < rings.indptr[i + 1]; ++p) want.emplace_back(rings.pairs[2 * p], rings.pairs[2 * p + 1]);
    for (int p = once.indptr[i]; p + 1 < once.indptr[i + 1]; ++p) got.emplace_back(once.fan[p], once.fan[p + 1]);
    std::sort(want.begin(), want.end());
    std::sort(got.begin(), got.end());
    ASSERT_EQ(got, want) << "vertex " << i;
  }
}

TEST(MovingRest, KeptAndChangedOrdersEqualAFreshDeformer) {
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3, 0.4);
  const RowMatrixX3d P = twist(rest_control_points(L), 0.6, 2, 0.5 * (L.box_min + L.box_max));
  Deformer D(m.V, m.F, L, OutsidePolicy::Error, 2);
  // 1e-9 of the box moves no vertex to another cell (none lies that close to a cell
  // face on this mesh: checked below by the order staying the same); 0.07 moves many.
  const double cell = (L.box_max.x() - L.box_min.x()) / 3.0;
  const std::vector<std::int32_t> start = D.processing_order();
  RowMatrixX3d X = moved(m.V, Vector3d(1e-9, -1e-9, 1e-9) * cell, 0.0);
  D.set_rest_vertices(X, 2);
  EXPECT_EQ(D.processing_order(), start) << "the tiny move was to keep the order";
  expect_same_deformer(D, Deformer(X, m.F, L, OutsidePolicy::Error, 1), X, P);
  for (int step = 1; step <= 3; ++step) {  // several moves in a row, some reorder
    X = moved(m.V, Vector3d(0.07, -0.05, 0.03) * step, step == 2 ? 0.01 : 0.0);
    const std::vector<std::int32_t> before = D.processing_order();
    D.set_rest_vertices(X, step % 2 + 1);
    EXPECT_NE(D.processing_order(), before) << "step " << step << " was to change the order";
    expect_same_deformer(D, Deformer(X, m.F, L, OutsidePolicy::Error, 1), X, P);
  }
}

TEST(MovingRest, FansOfMixedLengthsStayInTheirRowsThroughMoves) {
  // A closed mesh whose fans differ in length (poles of valence 48, the rest 4-6): its
  // fan rows are laid out once, by valence within each cell of the first order, and
  // keep their vertices through moves. Each moved Deformer must still equal a fresh
  // one bit for bit, and its coefficients the pairs' (vertex_rings) to rounding.
  const TriMesh m = uv_sphere(14, 48);
  ASSERT_TRUE(edge_report(m.F).closed());
  const Lattice L = lattice_around(m.V, {5, 6, 5}, 3, 0.6);
  const RowMatrixX3d P = twist(squashed(L, 0.8), 0.7, 2, 0.5 * (L.box_min + L.box_max));
  Deformer D(m.V, m.F, L, OutsidePolicy::Error, 2);
  const Vector3d o = D.origin();
  for (int step = 0; step <= 4; ++step) {
    // Back and forth, up to ~1.3 cells: most vertices change cell at some step.
    const RowMatrixX3d X = moved(m.V, Vector3d(0.3, -0.2, 0.25) * ((step % 3) - 0.7 * (step / 3)), 0.003 * step);
    if (step > 0) D.set_rest_vertices(X, step % 2 + 1);
    const Deformer fresh(X, m.F, L, OutsidePolicy::Error, 1);
    expect_same_deformer(D, fresh, X, P);
    // The frames that read the renumbered faces (built on first use after a move):
    // the paper's matrix (method csr) and the volume measured by a face pass.
    CorrectionOptions csr;
    csr.method = CoefficientMethod::Csr;
    EXPECT_EQ(D.deform(P, csr).vertices, fresh.deform(P, csr).vertices) << step;
    EXPECT_EQ(D.deform(P, csr).volume, fresh.deform(P, csr).volume) << step;
    const RowMatrixX3d Y = ffd_points(L, P, X);
    for (int a = 0; a < 3; ++a) {
      const AxisCoefficients c = D.volume_coefficients(Y, a);
      Embedding E = fresh.processing_embedding();
      RowMatrixX3d Ys(Y.rows(), 3);
      for (Index i = 0; i < Y.rows(); ++i) Ys.row(i) = Y.row(fresh.processing_order()[i]);
      const AxisCoefficients r = coefficients_rings(fresh.tables(), E, vertex_rings(fresh.processing_faces(), Y.rows()),
                                                    Ys.data(), a, o, 1);
      EXPECT_LE((c.alpha - r.alpha).cwiseAbs().maxCoeff(), 1e-13 * r.alpha.cwiseAbs().maxCoeff()) << step;
      EXPECT_LE(std::abs(c.volume - r.volume), 1e-13 * std::abs(r.volume)) << step;
    }
  }
}

TEST(MovingRest, OpenMeshPartsAndPeriodicEqualAFreshDeformer) {
  // An open mesh: the weights come from the rings (relabelled pairs), not the fans.
  TriMesh open = icosphere(3);
  open.F.conservativeResize(open.F.rows() - 7, 3);
  const Lattice Lo = lattice_around(open.V, {5, 6, 5}, 2, 0.4);
  const RowMatrixX3d Po = squashed(Lo, 0.8);
  Deformer Do(open.V, open.F, Lo, OutsidePolicy::Error, 2);
  ASSERT_FALSE(Do.is_closed());
  for (int step = 1; step <= 3; ++step) {
    const RowMatrixX3d X = moved(open.V, Vector3d(-0.06, 0.05, 0.04) * step, 0.005);
    Do.set_rest_vertices(X, 2);
    expect_same_deformer(Do, Deformer(X, open.F, Lo, OutsidePolicy::Error, 1), X, Po);
  }
  // Two spheres as parts on a lattice periodic along x (shift seam): the spheres
  // travel past the seam and wrap.
  const TriMesh two = two_spheres();
  const MeshParts parts = parts_from_components(two.F, two.V.rows());
  const Lattice L = shift_seam_lattice();
  const RowMatrixX3d P = restrict_points(make_ties(L), squashed(L, 0.7));
  Deformer D(two.V, two.F, L, OutsidePolicy::Error, 2, &parts);
  for (int step = 1; step <= 4; ++step) {
    const RowMatrixX3d X = moved(two.V, Vector3d(1.3 * step, 0.02, -0.02), 0.0);
    D.set_rest_vertices(X, 2);
    expect_same_deformer(D, Deformer(X, two.F, L, OutsidePolicy::Error, 1, &parts), X, P);
  }
}

/// D (moved by offsets) against `fresh` (built on X = base + offsets): expect_same_deformer
/// but for the rest volumes, which D keeps from its base (`base_volumes`); the frames
/// then aim at those on both sides and are the same bits.
void expect_same_but_base_volumes(const Deformer& D, const Deformer& fresh, const RowMatrixX3d& X,
                                  const RowMatrixX3d& P, const VectorXd& base_volumes) {
  EXPECT_EQ(D.rest_vertices(), X);
  EXPECT_EQ(D.processing_order(), fresh.processing_order());
  EXPECT_EQ(D.processing_faces(), fresh.processing_faces());
  EXPECT_EQ(D.part_start(), fresh.part_start());
  EXPECT_EQ(D.rest_part_volumes(), base_volumes);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(D.processing_embedding().span[a], fresh.processing_embedding().span[a]);
    EXPECT_EQ(D.processing_embedding().tau[a], fresh.processing_embedding().tau[a]);
    const AxisCoefficients c = D.volume_coefficients(X, a), f = fresh.volume_coefficients(X, a);
    EXPECT_EQ(c.alpha, f.alpha);
    EXPECT_EQ(c.volume, f.volume);
  }
  CorrectionOptions o;
  if (D.has_parts())
    o.part_targets.assign(base_volumes.data(), base_volumes.data() + base_volumes.size());
  else
    o.target_volume = base_volumes[0];
  const DeformResult a = D.deform(P, {}), b = fresh.deform(P, o);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.volume, b.volume);
  EXPECT_EQ(a.part_volumes, b.part_volumes);
}

TEST(MovingRest, OffsetsEqualPositionsButKeepTheBaseVolumes) {
  // Two spheres as parts on a periodic lattice (shift seam), each moved by its own
  // offset past the seam, from the base (offsets do not accumulate).
  const TriMesh two = two_spheres();
  const MeshParts parts = parts_from_components(two.F, two.V.rows());
  const Lattice L = shift_seam_lattice();
  const RowMatrixX3d P = restrict_points(make_ties(L), squashed(L, 0.7));
  Deformer D(two.V, two.F, L, OutsidePolicy::Error, 2, &parts);
  const VectorXd base = D.rest_part_volumes();
  for (int step = 1; step <= 4; ++step) {
    RowMatrixX3d O(2, 3);
    O << 1.3 * step, 0.02, -0.02, -0.7 * step, -0.03, 0.01;
    D.set_rest_offsets(O, step % 2 + 1);
    RowMatrixX3d X = two.V;
    for (Index v = 0; v < X.rows(); ++v) X.row(v) += O.row(parts.vertex_part[v]);
    expect_same_but_base_volumes(D, Deformer(X, two.F, L, OutsidePolicy::Error, 1, &parts), X, P, base);
  }
  // A new base from set_rest_vertices: its volumes are then the kept ones.
  const RowMatrixX3d Y = moved(two.V, Vector3d(0.4, 0, 0), 0.01);
  D.set_rest_vertices(Y, 2);
  EXPECT_FALSE(D.rest_is_offset());
  const VectorXd base_y = D.rest_part_volumes();
  RowMatrixX3d O(2, 3);
  O << 0.1, 0.2, 0.0, 0.3, -0.1, 0.05;
  D.set_rest_offsets(O, 2);
  EXPECT_TRUE(D.rest_is_offset());
  EXPECT_EQ(D.base_vertices(), Y);
  RowMatrixX3d X = Y;
  for (Index v = 0; v < X.rows(); ++v) X.row(v) += O.row(parts.vertex_part[v]);
  expect_same_but_base_volumes(D, Deformer(X, two.F, L, OutsidePolicy::Error, 1, &parts), X, P, base_y);
  // Refusals leave everything as it was: wrong count, non-finite, outside.
  EXPECT_THROW(D.set_rest_offsets(O.topRows(1)), InvalidInputError);
  RowMatrixX3d bad = O;
  bad(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(D.set_rest_offsets(bad), InvalidInputError);
  bad = O;
  bad(0, 1) = 1.0;  // y is not periodic: the sphere leaves the box
  EXPECT_THROW(D.set_rest_offsets(bad), InvalidInputError);
  expect_same_but_base_volumes(D, Deformer(X, two.F, L, OutsidePolicy::Error, 1, &parts), X, P, base_y);
}

TEST(MovingRest, OffsetsOfSomePartsEqualTheWholeMove) {
  // Four spheres as parts on the shift-seam lattice (the fourth past the seam). Moves
  // that change some parts' offsets re-embed only those (Deformer::move_parts): the
  // state and the frames must be those of a Deformer built on the moved mesh, through
  // every kind of move: first (whole), one part, half the parts (at the limit), none,
  // three parts (whole again), a sign of zero, and back.
  const TriMesh m = sphere_row(4);
  const MeshParts parts = parts_from_components(m.F, m.V.rows());
  ASSERT_EQ(parts.count, 4);
  const Lattice L = shift_seam_lattice();
  const RowMatrixX3d P = restrict_points(make_ties(L), squashed(L, 0.7));
  Deformer D(m.V, m.F, L, OutsidePolicy::Error, 2, &parts);
  const VectorXd base = D.rest_part_volumes();
  RowMatrixX3d O = RowMatrixX3d::Zero(4, 3);
  auto check = [&](const char* what, int threads) {
    SCOPED_TRACE(what);
    D.set_rest_offsets(O, threads);
    RowMatrixX3d X = m.V;
    for (Index v = 0; v < X.rows(); ++v) X.row(v) += O.row(parts.vertex_part[v]);
    expect_same_but_base_volumes(D, Deformer(X, m.F, L, OutsidePolicy::Error, 1, &parts), X, P, base);
  };
  O.row(1) << 0.37, 0.05, -0.02;
  check("first move", 2);
  const double before = D.bytes_per_vertex();
  O.row(2) << -0.81, -0.04, 0.06;  // across cells: the part's order changes
  check("one part", 1);
  EXPECT_GT(D.bytes_per_vertex(), before) << "the move of one part keeps each part's vertices";
  O.row(0) << 1.9, 0.01, 0.0;
  O.row(3) << 3.3, -0.02, 0.03;  // past the seam
  check("two parts of four", 2);
  check("no part", 2);
  O.row(0) << 0.2, 0.0, 0.0;
  O.row(1) << 0.0, 0.1, 0.0;
  O.row(2) << 0.0, 0.0, 0.1;
  check("three parts", 1);
  O(0, 1) = -0.0;  // another offset, bit for bit, that moves nothing
  check("a negative zero", 2);
  O.row(2) << -0.81, -0.04, 0.06;
  check("a part back", 2);
  // A moved part refused: the whole move's error (naming the part), nothing changed.
  RowMatrixX3d bad = O;
  bad(3, 1) = 1.0;  // y is not periodic: the sphere leaves the box
  expect_refusal_naming([&] { D.set_rest_offsets(bad, 2); }, "part");
  check("after the refusal", 2);
  // Parts large enough that the moved ones are embedded side by side on threads
  // (parallel_items: over kParallelMin vertices moved): the same state.
  const TriMesh big = sphere_row(4, 6);
  const MeshParts big_parts = parts_from_components(big.F, big.V.rows());
  Deformer B(big.V, big.F, L, OutsidePolicy::Error, 2, &big_parts);
  const VectorXd big_base = B.rest_part_volumes();
  O.setZero();
  for (int step = 1; step <= 3; ++step) {
    O.row(0) << 0.3 * step, 0.01, 0.0;
    O.row(2) << -0.45 * step, 0.0, -0.02;
    B.set_rest_offsets(O, step == 2 ? 1 : 2);
    RowMatrixX3d X = big.V;
    for (Index v = 0; v < X.rows(); ++v) X.row(v) += O.row(big_parts.vertex_part[v]);
    expect_same_but_base_volumes(B, Deformer(X, big.F, L, OutsidePolicy::Error, 2, &big_parts), X, P, big_base);
  }
}

TEST(MovingRest, PositionsOfSomePartsEqualTheWholeMove) {
  // set_rest_vertices with only some parts' rows changed (Deformer::reposition_parts):
  // the state, the rest volumes (of X, summed when first needed) and the frames of a
  // Deformer built on X, through moves of one part, of half, of none, of three, a
  // part's single vertex, after offset moves (whose kept volumes X's sums replace),
  // and a refusal.
  const TriMesh m = sphere_row(4);
  const MeshParts parts = parts_from_components(m.F, m.V.rows());
  const Lattice L = shift_seam_lattice();
  const RowMatrixX3d P = restrict_points(make_ties(L), squashed(L, 0.7));
  Deformer D(m.V, m.F, L, OutsidePolicy::Error, 2, &parts);
  RowMatrixX3d X = m.V;
  auto move = [&](int k, const Vector3d& by) {
    for (Index v = 0; v < X.rows(); ++v)
      if (parts.vertex_part[v] == k) X.row(v) += by.transpose();
  };
  auto check = [&](const char* what, int threads) {
    SCOPED_TRACE(what);
    D.set_rest_vertices(X, threads);
    EXPECT_FALSE(D.rest_is_offset());
    EXPECT_EQ(D.rest_vertices(), X);
    expect_same_deformer(D, Deformer(X, m.F, L, OutsidePolicy::Error, 1, &parts), X, P);
  };
  move(1, Vector3d(0.37, 0.05, -0.02));
  check("one part", 2);
  move(0, Vector3d(-0.81, -0.04, 0.06));
  move(3, Vector3d(3.3, -0.02, 0.03));  // past the seam
  check("two parts of four", 1);
  check("no part", 2);
  move(0, Vector3d(0.2, 0, 0));
  move(1, Vector3d(0, 0.1, 0));
  move(2, Vector3d(0, 0, 0.1));
  check("three parts", 2);
  X(5, 2) += 0.01;  // one vertex of part 0: the part is embedded again
  check("one vertex", 2);
  RowMatrixX3d O = RowMatrixX3d::Zero(4, 3);
  O.row(2) << 0.3, 0.0, 0.0;
  D.set_rest_offsets(O, 2);  // volumes kept from the base X...
  X = D.rest_vertices();
  move(1, Vector3d(-0.2, 0, 0));
  check("after an offset move", 2);  // ...and X's own after set_rest_vertices
  // A moved part refused: the whole move's error, nothing changed.
  RowMatrixX3d bad = X;
  for (Index v = 0; v < bad.rows(); ++v)
    if (parts.vertex_part[v] == 2) bad(v, 1) += 1.0;  // y is not periodic
  EXPECT_THROW(D.set_rest_vertices(bad, 2), InvalidInputError);
  bad = X;
  bad(7, 0) = std::numeric_limits<double>::quiet_NaN();
  expect_refusal_naming([&] { D.set_rest_vertices(bad, 2); }, "finite");
  check("after the refusals", 2);
  // A part so far along the periodic axis that the volumes might overflow: summed at
  // once by the whole move (RestVolumeBoundSumsAtOnceWhereItMightOverflow), as a
  // fresh Deformer does. The distance is a whole number of periods, 7 x 2^330: every
  // vertex of the part rounds to it and wraps to the seam exactly, with or without
  // fused multiply-adds (at other distances that far the wrap's remainder is rounding).
  for (Index v = 0; v < X.rows(); ++v)
    if (parts.vertex_part[v] == 0) X(v, 0) += std::ldexp(7.0, 330);
  D.set_rest_vertices(X, 2);
  EXPECT_TRUE(D.rest_volume_known());
  EXPECT_EQ(D.rest_part_volumes(), Deformer(X, m.F, L, OutsidePolicy::Error, 1, &parts).rest_part_volumes());
}

TEST(MovingRest, RestVolumeWaitsForItsFirstUseAndIsTheEagerSum) {
  const TriMesh m = icosphere(3);
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3, 0.4);
  const RowMatrixX3d P = twist(rest_control_points(L), 0.6, 2, 0.5 * (L.box_min + L.box_max));
  Deformer D(m.V, m.F, L, OutsidePolicy::Error, 2);
  EXPECT_FALSE(D.rest_volume_known());
  const RowMatrixX3d X = moved(m.V, Vector3d(0.07, -0.05, 0.03), 0.01);
  const double want = signed_volume(X, m.F, D.origin());  // the eager sum: same function, faces, origin
  EXPECT_EQ(D.rest_volume_of(X), want);
  D.set_rest_vertices(X, 2);
  CorrectionOptions plain;
  plain.preserve_volume = false;
  const DeformResult r = D.deform(P, plain);
  EXPECT_FALSE(D.rest_volume_known()) << "a plain frame does not need the rest volume";
  EXPECT_TRUE(std::isnan(r.target_volume));
  const DeformResult k = D.deform(P, {});  // its target is the rest volume
  EXPECT_TRUE(D.rest_volume_known());
  EXPECT_EQ(k.target_volume, want);
  EXPECT_EQ(D.rest_volume(), want);
  EXPECT_THROW(D.rest_volume_of(X.topRows(5)), InvalidInputError);
}

TEST(MovingRest, RestVolumeBoundSumsAtOnceWhereItMightOverflow) {
  const TriMesh m = icosphere(2);
  Lattice L = lattice_around(m.V, {4, 4, 4}, 3, 0.1);
  EXPECT_TRUE(rest_volume_stays_finite(L, 1000000, m.V));
  // 1e97-unit boxes: R ~ 1.7e100, R^3 ~ 5e300 per face.
  for (int a = 0; a < 3; ++a) L.box_max[a] = L.box_min[a] + 1e97;
  EXPECT_FALSE(rest_volume_stays_finite(L, 1, m.V));
  // Along a periodic axis the reach is the vertices' own: any distance is taken there.
  const Lattice Lp = lattice_around(m.V, {6, 6, 6}, 3, 0.4);
  const Lattice periodic =
      make_lattice(Lp.box_min, Lp.box_max, {6, 6, 6}, {3, 3, 3}, {Seam::Shift, Seam::None, Seam::None});
  EXPECT_FALSE(Deformer(m.V, m.F, periodic).rest_volume_known()) << "a mesh in the box waits";
  RowMatrixX3d far = m.V;
  far.col(0).array() += 1e101;  // R^3 ~ 1e303: summed (and kept: each term is finite) at once
  EXPECT_FALSE(rest_volume_stays_finite(periodic, m.F.rows(), far));
  Deformer D(far, m.F, periodic);
  EXPECT_TRUE(D.rest_volume_known());
  EXPECT_TRUE(std::isfinite(D.rest_volume()));
  D.set_rest_vertices(m.V);
  EXPECT_FALSE(D.rest_volume_known());
  EXPECT_EQ(D.rest_volume(), Deformer(m.V, m.F, periodic).rest_volume());
}

TEST(MovingRest, FansAndRingsRelabelledOnceAfterMovesInARow) {
  // The fans (closed) and rings (open) wait for the first frame that reads them: after
  // several moves with only plain frames between them, that frame relabels them from the
  // order they were left in; every result is still a fresh Deformer's, bit for bit.
  TriMesh open = icosphere(3);
  open.F.conservativeResize(open.F.rows() - 7, 3);
  const TriMesh closed = icosphere(3);
  for (const TriMesh* m : std::initializer_list<const TriMesh*>{&closed, &open}) {
    const Lattice L = lattice_around(m->V, {6, 5, 6}, 3, 0.4);
    const RowMatrixX3d P = squashed(L, 0.8);
    Deformer D(m->V, m->F, L, OutsidePolicy::Error, 2);
    CorrectionOptions plain;
    plain.preserve_volume = false;
    plain.allow_open = true;
    RowMatrixX3d X;
    for (int round = 0; round < 2; ++round) {
      for (int step = 1; step <= 3; ++step) {
        X = moved(m->V, Vector3d(0.06, -0.05, 0.04) * (step + 3 * round), 0.005 * step);
        D.set_rest_vertices(X, 2);
        const Deformer fresh(X, m->F, L, OutsidePolicy::Error, 1);
        EXPECT_EQ(D.deform(P, plain).vertices, fresh.deform(P, plain).vertices);
      }
      expect_same_deformer(D, Deformer(X, m->F, L, OutsidePolicy::Error, 1), X, P);
    }
    // Back to where it started, after a move away that no frame read: the relabelling
    // finds the adjacency already in the order it needs.
    D.set_rest_vertices(moved(m->V, Vector3d(0.1, 0.1, -0.1), 0.0), 1);
    D.set_rest_vertices(X, 1);
    expect_same_deformer(D, Deformer(X, m->F, L, OutsidePolicy::Error, 1), X, P);
  }
}
