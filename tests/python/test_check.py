"""Mesh.check(): each defect planted on a tiny mesh is found, and the shared
BADINPUT scans give exactly the counts of MANIFEST.md."""
from pathlib import Path

import numpy as np
import pytest

import vpffd

SHARED = Path(__file__).resolve().parents[2].parent / "shared/data/meshes"

# A closed octahedron, outward: the base of the planted defects.
OCT_V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
OCT_F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])

CLEAN = dict(boundary_edges=0, boundary_loops=0, nonmanifold_edges=0, nonmanifold_vertices=0, misoriented_edges=0,
             degenerate_faces=0, duplicate_vertices=0, duplicate_faces=0, unreferenced_vertices=0, components=1)


def counts(c):
    return {k: getattr(c, k) for k in CLEAN}


def expect(c, **changes):
    want = dict(CLEAN, **changes)
    assert counts(c) == want


def test_clean_octahedron():
    c = vpffd.Mesh(OCT_V, OCT_F).check()
    expect(c)
    assert c.is_volume and c.edges == 12 and c.euler_characteristic == 2
    assert c.is_closed and c.is_watertight and vpffd.Mesh(OCT_V, OCT_F).is_closed
    assert c.signed_volume == pytest.approx(4 / 3)
    assert c.problems() == []
    assert "outward" in str(c)


def test_hole():
    c = vpffd.Mesh(OCT_V, OCT_F[1:]).check()
    expect(c, boundary_edges=3, boundary_loops=1)
    assert not c.is_closed and np.isnan(c.signed_volume)
    assert "3 boundary edges in 1 loops" in str(c)


def test_two_holes():
    c = vpffd.Mesh(OCT_V, OCT_F[[1, 2, 3, 4, 5, 7]]).check()  # faces 0 and 6 share no vertex
    assert (c.boundary_edges, c.boundary_loops) == (6, 2)


def test_nonmanifold_edge():
    V = np.vstack([OCT_V, [[0.5, 0.5, 2.0]]])
    F = np.vstack([OCT_F, [[0, 2, 6]]])  # a fin on edge (0, 2)
    c = vpffd.Mesh(V, F).check()
    assert c.nonmanifold_edges == 1
    assert c.boundary_edges == 2 and not c.is_closed


def test_nonmanifold_vertex():
    # Two octahedra touching at one vertex (a pinch point).
    V = np.vstack([OCT_V, OCT_V[[0, 2, 3, 4, 5]] + [2, 0, 0]])  # second one's vertex 1 is our vertex 0
    remap = np.array([6, 0, 7, 8, 9, 10])
    F = np.vstack([OCT_F, remap[OCT_F]])
    c = vpffd.Mesh(V, F).check()
    expect(c, nonmanifold_vertices=1, components=2)
    assert c.is_volume  # closed, just not a manifold at that vertex


def test_inconsistent_orientation():
    F = OCT_F.copy()
    F[0] = F[0, ::-1]
    c = vpffd.Mesh(OCT_V, F).check()
    expect(c, misoriented_edges=3)
    assert not c.is_consistently_oriented and np.isnan(c.signed_volume)
    # Watertight but not a closed surface: one meaning of "closed" for the check and the mesh.
    assert c.is_watertight and not c.is_closed
    assert not vpffd.Mesh(OCT_V, F).is_closed
    fixed = vpffd.Mesh(OCT_V, F).oriented()
    assert fixed.check().is_volume
    canon = lambda F: [tuple(np.roll(f, -np.argmin(f))) for f in F]  # noqa: E731  (same cyclic order)
    assert canon(fixed.faces) == canon(OCT_F)


def test_inward_orientation_and_flip():
    m = vpffd.Mesh(OCT_V, OCT_F[:, ::-1])
    c = m.check()
    expect(c)
    assert c.is_inward and not c.is_volume and c.signed_volume == pytest.approx(-4 / 3)
    assert "inward" in str(c)
    o = m.oriented()
    assert o is not m and o.check().is_volume
    assert m.check().is_inward  # the original is unchanged (Mesh is immutable)
    good = vpffd.Mesh(OCT_V, OCT_F)
    assert good.oriented() is good  # nothing to flip: no copy


def test_degenerate_faces():
    V = np.vstack([OCT_V, [[0.5, 0, 0]]])  # a point on the segment from 1,0,0 to origin
    F = np.vstack([OCT_F, [[0, 0, 2], [0, 6, 6], [0, 6, 1]]])  # repeated index x2, collinear
    c = vpffd.Mesh(V, F).check()
    assert c.degenerate_faces == 3


def test_duplicate_vertices_and_unreferenced():
    V = np.vstack([OCT_V, OCT_V[[0]], [[5, 5, 5]]])
    F = OCT_F.copy()
    F[F == 0] = 6  # vertex 0 replaced by its copy everywhere: 0 becomes unreferenced
    c = vpffd.Mesh(V, F).check()
    assert (c.duplicate_vertices, c.unreferenced_vertices) == (1, 2)
    assert c.is_volume  # the surface itself is intact


def test_unwelded_seam():
    # Split the octahedron along the equator into two open halves with own vertices.
    V = np.vstack([OCT_V, OCT_V[:4]])
    F = OCT_F.copy()
    F[4:] = np.where(F[4:] < 4, F[4:] + 6, F[4:])
    c = vpffd.Mesh(V, F).check()
    expect(c, duplicate_vertices=4, boundary_edges=8, boundary_loops=2, components=2)


def test_duplicate_faces():
    F = np.vstack([OCT_F, OCT_F[[3]], OCT_F[[5]][:, ::-1]])
    c = vpffd.Mesh(OCT_V, F).check()
    assert c.duplicate_faces == 2
    assert c.nonmanifold_edges == 6


def test_components():
    V = np.vstack([OCT_V, OCT_V + 5])
    F = np.vstack([OCT_F, OCT_F + 6])
    c = vpffd.Mesh(V, F).check()
    expect(c, components=2)
    assert c.signed_volume == pytest.approx(8 / 3)


def test_check_accepts_trimesh_like():
    class Like:
        vertices = OCT_V
        faces = OCT_F
    assert vpffd.Mesh.from_any(Like()).check().is_volume


def test_open_mesh_refused_unless_allow_open():
    m = vpffd.shapes.icosphere(2)
    opened = vpffd.Mesh(m.vertices, m.faces[1:])
    lat = vpffd.Lattice.around(opened, shape=(4, 4, 4))
    d = vpffd.Deformer(opened, lat)
    P = lat.control_points * [1.2, 1, 1]
    with pytest.raises(vpffd.InvalidInputError, match="boundary edges"):
        d.deform(P)
    with pytest.warns(UserWarning, match="depends"):
        d.deform(P, allow_open=True)


# --- the shared defective scans (MANIFEST.md) --------------------------------------
MANIFEST = {
    "BADINPUT_bunny_stanford_zipper_holes.ply": dict(
        vertices=35947, faces=69451, edges=104288, boundary_edges=223, nonmanifold_edges=0, components=1,
        euler_characteristic=-3, unreferenced_vertices=1113, duplicate_vertices=0, duplicate_faces=0,
        degenerate_faces=0),
    "BADINPUT_dragon_vrip_raw_unwelded.ply.gz": dict(
        vertices=437645, faces=871414, edges=1309256, boundary_edges=4270, nonmanifold_edges=0, components=151,
        euler_characteristic=-197, unreferenced_vertices=0, duplicate_vertices=2100, duplicate_faces=0,
        degenerate_faces=108),
    "BADINPUT_dragon_vrip_res3_nonmanifold.ply": dict(
        vertices=22998, faces=47794, edges=69509, boundary_edges=0, nonmanifold_edges=2094, components=1473,
        euler_characteristic=1267, unreferenced_vertices=16, duplicate_vertices=0, duplicate_faces=1254,
        degenerate_faces=0),
    "sphere_ico4.ply": dict(
        vertices=2562, faces=5120, edges=7680, boundary_edges=0, nonmanifold_edges=0, components=1,
        euler_characteristic=2, unreferenced_vertices=0, duplicate_vertices=0, duplicate_faces=0,
        degenerate_faces=0),
}


@pytest.mark.shared_data
@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/meshes")
@pytest.mark.skipif(not vpffd._core.has_openmesh, reason="built without OpenMesh")
@pytest.mark.parametrize("name", sorted(MANIFEST))
def test_shared_scans_match_manifest(name):
    c = vpffd.load_mesh(SHARED / name).check()
    got = {k: getattr(c, k) for k in MANIFEST[name]}
    assert got == MANIFEST[name]
    assert c.is_volume == name.startswith("sphere")
    assert c.misoriented_edges == 0  # all are "winding consistent" in the manifest
    if name.startswith("sphere"):
        assert c.signed_volume == pytest.approx(4.17973892, rel=1e-8)
