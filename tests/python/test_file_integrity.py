"""Files never lose data: a write that fails (a file-size limit, a full disk) raises and
leaves the old file byte for byte, with no temporary file behind; targets that cannot
be replaced safely are refused; the CLI does not overwrite its input by accident; and
text files with a byte-order mark keep their meaning."""
import os
import resource
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import vpffd
from vpffd import shapes
from vpffd._files import open_replacing, replaced_path, write_bytes

needs_openmesh = pytest.mark.skipif(not vpffd._core.has_openmesh, reason="built without OpenMesh")


def _keep(folder: Path, name="keep.ply") -> tuple[Path, bytes]:
    """A good small mesh file whose bytes must survive a failed write."""
    path = folder / name
    vpffd.save_mesh(path, shapes.icosphere(1))
    return path, path.read_bytes()


def _only(folder: Path, *names):
    assert sorted(p.name for p in folder.iterdir()) == sorted(names)


CHILD = textwrap.dedent("""
    import resource, sys
    import vpffd
    from vpffd import shapes
    limit, target = int(sys.argv[1]), sys.argv[2]
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
    try:
        vpffd.save_mesh(target, shapes.icosphere(5))
        print("OK")
    except vpffd.MeshIOError as e:
        print("MeshIOError", e)
""")


@needs_openmesh
@pytest.mark.parametrize("ext", ["ply", "obj", "om"])
def test_write_past_the_file_size_limit_keeps_the_old_file(tmp_path, ext):
    path, before = _keep(tmp_path, f"keep.{ext}")
    r = subprocess.run([sys.executable, "-c", CHILD, str(64 * 1024), str(path)], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("MeshIOError"), r.stdout
    assert "file-size limit" in r.stdout and "keep." in r.stdout
    assert path.read_bytes() == before
    _only(tmp_path, path.name)


@needs_openmesh
def test_cli_write_past_the_file_size_limit_fails_and_keeps_the_old_file(tmp_path):
    src = tmp_path / "big.ply"
    vpffd.save_mesh(src, shapes.icosphere(5))
    path, before = _keep(tmp_path)

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (64 * 1024, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))

    r = subprocess.run([sys.executable, "-m", "vpffd", "deform", str(src), str(path), "--squash", "0.8"],
                       capture_output=True, text=True, timeout=300, preexec_fn=limit)
    assert r.returncode != 0
    assert "wrote" not in r.stdout
    assert "file-size limit" in r.stderr + r.stdout
    assert path.read_bytes() == before
    _only(tmp_path, "big.ply", "keep.ply")


@pytest.fixture
def full_disk(tmp_path):
    """A 64 KiB tmpfs (root only; skipped where mounting is not allowed)."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a small file system needs root")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.decode(errors='replace').strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


@needs_openmesh
def test_write_to_a_full_disk_keeps_the_old_file(full_disk):
    path, before = _keep(full_disk)
    with pytest.raises(vpffd.MeshIOError, match="No space left on device.*old file is unchanged"):
        vpffd.save_mesh(path, shapes.icosphere(5))
    assert path.read_bytes() == before
    _only(full_disk, "keep.ply")


def test_python_writers_on_a_full_disk_keep_the_old_file(full_disk):
    path = full_disk / "table.csv"
    path.write_text("old\n")
    with pytest.raises(vpffd.MeshIOError, match="table.csv.*unchanged"):
        write_bytes(path, b"x" * 200_000)
    assert path.read_text() == "old\n"
    _only(full_disk, "table.csv")


@needs_openmesh
def test_unreplaceable_targets_are_refused(tmp_path):
    fifo = tmp_path / "pipe.ply"
    os.mkfifo(fifo)
    with pytest.raises(vpffd.MeshIOError, match="pipe.ply.*not a regular file"):
        vpffd.save_mesh(fifo, shapes.icosphere(1))  # never blocks on the FIFO
    dev = tmp_path / "full.ply"
    dev.symlink_to("/dev/full")
    with pytest.raises(vpffd.MeshIOError, match="full.ply.*not a regular file"):
        vpffd.save_mesh(dev, shapes.icosphere(1))
    with pytest.raises(vpffd.MeshIOError, match="FIFO"):
        write_bytes(fifo, b"abc")


@needs_openmesh
def test_a_link_stays_a_link_and_permissions_stay(tmp_path):
    real, _ = _keep(tmp_path, "real.ply")
    os.chmod(real, 0o640)
    link = tmp_path / "link.ply"
    link.symlink_to(real.name)
    mesh = shapes.icosphere(2)
    vpffd.save_mesh(link, mesh)
    assert link.is_symlink() and np.allclose(vpffd.load_mesh(real).vertices, mesh.vertices, atol=1e-6)
    assert stat.S_IMODE(real.stat().st_mode) == 0o640
    _only(tmp_path, "real.ply", "link.ply")


@pytest.mark.skipif(not vpffd._core.has_mesh_io, reason="built without mesh file I/O")
def test_float32_overflow_is_refused_where_float32_is_stored(tmp_path):
    # Only binary STL and binary OFF store float32 (OpenMesh's writers, used before,
    # stored float32 in every format but OM, which refused all four); ASCII files,
    # PLY and OM keep float64 and so the coordinates, exactly.
    m = shapes.icosphere(1)
    big = vpffd.Mesh(m.vertices * 1e39, m.faces)
    for ext, binary in (("stl", None), ("stl", True), ("off", True)):
        with pytest.raises(vpffd.InvalidInputError, match=rf"vertex 0 .*float32.*binary \.{ext}.*save as ASCII"):
            vpffd.save_mesh(tmp_path / f"big.{ext}", big, binary=binary)
    names = []
    for ext, binary in (("ply", None), ("ply", False), ("obj", None), ("off", None), ("stl", False)) + (
            (("om", None),) if vpffd._core.has_openmesh else ()):
        names.append(f"big_{binary}.{ext}")
        vpffd.save_mesh(tmp_path / names[-1], big, binary=binary)
        back = vpffd.load_mesh(tmp_path / names[-1])
        if ext == "stl":
            assert np.array_equal(back.vertices[back.faces], big.vertices[big.faces])
        else:
            assert np.array_equal(back.vertices, big.vertices)
    _only(tmp_path, *names)


def test_replaced_path_keeps_the_old_file_when_the_writer_fails(tmp_path):
    path = tmp_path / "frame.png"
    path.write_bytes(b"old")
    with pytest.raises(ZeroDivisionError):
        with open_replacing(path, "wb") as fh:
            fh.write(b"partial")
            1 / 0
    assert path.read_bytes() == b"old"
    with replaced_path(path) as tmp:
        assert tmp.endswith(".png") and os.path.dirname(tmp) == str(tmp_path)
        Path(tmp).write_bytes(b"new")
    assert path.read_bytes() == b"new"
    _only(tmp_path, "frame.png")


@needs_openmesh
def test_cli_refuses_to_overwrite_its_input(tmp_path):
    src, before = _keep(tmp_path, "in.ply")
    r = subprocess.run([sys.executable, "-m", "vpffd", "deform", str(src), str(src), "--squash", "0.8"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "OUT is IN" in r.stderr and "--in-place" in r.stderr
    assert src.read_bytes() == before
    r = subprocess.run([sys.executable, "-m", "vpffd", "deform", str(src), str(src), "--squash", "0.8", "--in-place"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert src.read_bytes() != before
    _only(tmp_path, "in.ply")


OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n"


@needs_openmesh
def test_obj_with_a_byte_order_mark_keeps_its_first_vertex(tmp_path):
    plain, bom = tmp_path / "plain.obj", tmp_path / "bom.obj"
    plain.write_text(OBJ)
    bom.write_bytes(b"\xef\xbb\xbf" + OBJ.encode())
    a, b = vpffd.load_mesh(plain), vpffd.load_mesh(bom)
    assert b.n_vertices == 4 and np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert b.volume == pytest.approx(1 / 6)


@needs_openmesh
def test_utf16_text_is_refused_by_name(tmp_path):
    p = tmp_path / "wide.obj"
    p.write_bytes(b"\xff\xfe" + OBJ.encode("utf-16-le"))
    with pytest.raises(vpffd.MeshIOError, match="UTF-16"):
        vpffd.load_mesh(p)


@pytest.mark.parametrize("scale", [1e-100, 1e-50, 1.0, 1e50, 1e100])
def test_volume_is_finite_for_finite_coordinates_in_range(scale):
    m = shapes.icosphere(2)
    ref = m.volume
    v = vpffd.Mesh(m.vertices * scale, m.faces).volume
    # Scaling rounds each coordinate once (u = 1.1e-16 relative) and the sum of 1,280
    # cone volumes, all of one sign on a sphere about its centre, adds at most 1,280 u:
    # under 1.5e-13 relative, so 1e-12 holds on any IEEE machine.
    assert np.isfinite(v) and v == pytest.approx(ref * scale**3, rel=1e-12)


def test_volume_out_of_range_is_a_clear_error():
    m = shapes.icosphere(2)
    with pytest.raises(vpffd.InvalidInputError, match="beyond the double range"):
        vpffd.Mesh(m.vertices * 1e300, m.faces).volume
    with pytest.raises(vpffd.InvalidInputError, match="below the smallest normal double"):
        vpffd.Mesh(m.vertices * 1e-150, m.faces).volume
    # A volume near the top of the range (its edges 1e100, far from the origin): finite.
    # The corners are rounded to ulp(1e110) ~ 1.5e94, 1.5e-6 of an edge: hence rel=1e-4.
    tet = vpffd.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * 1e100 + 1e110,
                     np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]))
    assert tet.volume == pytest.approx(1e300 / 6, rel=1e-4)
