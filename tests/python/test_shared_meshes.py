"""Issue 2 on the real meshes of ../shared (skipped in a user's clone)."""
import numpy as np
import pytest

import vpffd


@pytest.mark.parametrize("name,volume", [("sphere_ico4.ply", 4.17973892), ("bunny_watertight.ply", 0.745450755),
                                         ("horse.ply", 0.000263418277)])
def test_real_mesh_volume_and_correction(shared_meshes, name, volume):
    m = vpffd.load_mesh(shared_meshes / name)
    assert m.volume == pytest.approx(volume, rel=1e-6)  # file stats were computed in float32 sources
    lat = vpffd.Lattice.around(m, shape=(8, 8, 8), degree=3)
    d = vpffd.Deformer(m, lat)
    for axes in ("xyz", "xy", "z"):
        r = d.deform(vpffd.twist(vpffd.squash(lat.control_points, 0.5), 120), axes=axes)
        assert abs(r.volume - d.rest_volume) <= 1e-12 * d.rest_volume
    r_csr = d.deform(vpffd.twist(vpffd.squash(lat.control_points, 0.5), 120), method="csr")
    r_tr = d.deform(vpffd.twist(vpffd.squash(lat.control_points, 0.5), 120))
    np.testing.assert_allclose(r_csr.vertices, r_tr.vertices, atol=1e-12 * np.ptp(m.vertices))


def test_open_scan_is_refused(shared_meshes):
    m = vpffd.load_mesh(shared_meshes / "BADINPUT_bunny_stanford_zipper_holes.ply")
    with pytest.raises(vpffd.InvalidInputError, match="223 boundary edges"):
        m.volume
