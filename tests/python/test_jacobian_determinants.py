"""Deformer.jacobian_determinants (the det-only path of the comparison pictures)
against numpy's determinants of Deformer.jacobians."""
import numpy as np
import pytest

import vpffd


def _check(d, P):
    det = d.jacobian_determinants(P)
    ref = np.linalg.det(d.jacobians(P))
    # Same Jacobians (same kernel); only the 3x3 determinant's rounding differs from
    # LAPACK's LU: a few ulps of the largest term |J|^3.
    scale = np.abs(d.jacobians(P)).max(axis=(1, 2)) ** 3
    assert det.shape == (d.mesh.n_vertices,)
    assert np.all(np.abs(det - ref) <= 1e-13 * scale)
    return det


@pytest.mark.parametrize("degree", [3, (1, 2, 3)])
def test_equals_det_of_jacobians(degree):
    mesh = vpffd.shapes.icosphere(4)  # 2,562 vertices: several blocks of 256 per chunk
    lat = vpffd.Lattice.around(mesh, shape=(6, 5, 7), degree=degree)
    d = vpffd.Deformer(mesh, lat, backend="serial")
    P = vpffd.edits.twist(lat.control_points, 120)
    det = _check(d, P)
    # A twist keeps volume locally only up to the spline's smoothing: det J near 1, not 1.
    assert 0.5 < det.min() and det.max() < 1.5 and np.ptp(det) > 1e-3
    assert np.allclose(d.jacobian_determinants(), 1.0, atol=1e-12)  # rest lattice: identity


def test_moebius_seam_keeps_the_sign():
    # The twist seam mirrors two columns of J for wrapped points: det must not flip.
    lat = vpffd.Lattice([0, -1, -0.2], [4, 1, 0.2], shape=(12, 4, 4), periodic="x", seam="twist")
    mesh = vpffd.shapes.icosphere(2)
    mesh = vpffd.Mesh(mesh.vertices * [0.5, 0.5, 0.1] + [3.9, 0, 0], mesh.faces)  # crosses the seam at x = 4
    d = vpffd.Deformer(mesh, lat, backend="serial")
    P = vpffd.edits.mobius(lat, radius=3.0)
    det = _check(d, P)
    assert np.all(det > 0)
