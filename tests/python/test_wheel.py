"""The binary wheel (scripts/build_wheel.sh writes it to dist/) installed into a
fresh virtual environment: it must deform, read and write mesh files and render
with the shared libraries it carries (vpffd.libs/), not the system's, and leave
the Vulkan loader to the system (opened at run time, never linked).

numpy and scipy are not installed again: the fresh environment sees only those two
packages of the running one (symbolic links behind a .pth file), so the test needs
no network; the wheel itself goes in with ``pip install --no-deps --no-index``.
"""
from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy
import pytest
import scipy

REPO = Path(__file__).resolve().parents[2]
TAG = f"cp{sys.version_info.major}{sys.version_info.minor}"
# Linked by the extension and absent from the manylinux allow-list: these must come
# from the wheel.
BUNDLED = ("libOpenMeshCore", "libOpenMeshTools", "libembree3", "libtbb", "libgomp", "libosdCPU")
SYSTEM_LIBDIR = Path("/usr/lib/x86_64-linux-gnu")


def _wheel() -> Path | None:
    wheels = sorted((REPO / "dist").glob(f"vpffd-*-{TAG}-{TAG}-manylinux_*_x86_64.whl"), key=lambda p: p.stat().st_mtime)
    return wheels[-1] if wheels else None


pytestmark = [
    pytest.mark.skipif(sys.platform != "linux" or platform.machine() != "x86_64",
                       reason="the binary wheel is built for Linux x86-64"),
    pytest.mark.skipif(_wheel() is None,
                       reason=f"no repaired wheel for {TAG} in dist/ (scripts/build_wheel.sh builds it)"),
]

# Runs inside the fresh environment; argv[1] is a scratch folder. Prints one JSON object.
PROBE = textwrap.dedent('''
    import json, os, sys
    import numpy as np
    import vpffd

    d = sys.argv[1]
    out = {"vpffd": vpffd.__file__, "has_openmesh": vpffd._core.has_openmesh, "has_embree": vpffd._core.has_embree}
    mesh = vpffd.shapes.icosphere(3)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3)
    r = vpffd.Deformer(mesh, lat).deform(vpffd.edits.squash(lat.control_points, 0.6))
    out["volume_error"] = abs(r.volume - mesh.volume) / mesh.volume
    out["moved"] = float(np.abs(r.vertices - mesh.vertices).max())

    # vpffd's own readers
    with open(os.path.join(d, "tet.ply"), "w") as f:
        f.write("ply\\nformat ascii 1.0\\nelement vertex 4\\nproperty float x\\nproperty float y\\n"
                "property float z\\nelement face 4\\nproperty list uchar int vertex_indices\\nend_header\\n"
                "0 0 0\\n1 0 0\\n0 1 0\\n0 0 1\\n3 0 2 1\\n3 0 1 3\\n3 0 3 2\\n3 1 2 3\\n")
    with open(os.path.join(d, "quad.obj"), "w") as f:
        f.write("v 0 0 0\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\nf 1 2 3 4\\n")
    tet = vpffd.load_mesh(os.path.join(d, "tet.ply"))
    quad = vpffd.load_mesh(os.path.join(d, "quad.obj"))
    out["ply"] = [tet.n_vertices, tet.n_faces, tet.volume]
    out["obj"] = [quad.n_vertices, quad.n_faces]
    # STL written and read back (vpffd's own code); OM through the bundled OpenMesh
    stl = os.path.join(d, "deformed.stl")
    vpffd.save_mesh(stl, r)
    back = vpffd.load_mesh(stl)
    out["stl"] = [back.n_vertices, back.n_faces, abs(back.volume - r.volume) / r.volume]
    om = os.path.join(d, "deformed.om")
    vpffd.save_mesh(om, r)
    out["om"] = bool(vpffd.load_mesh(om).vertices.tobytes() == r.vertices.tobytes())
    # Embree: a picture
    png = os.path.join(d, "deformed.png")
    vpffd.save_png(png, vpffd.render(r, size=(64, 48)))
    img = vpffd.load_png(png)
    out["png"] = [list(img.shape), int((img[..., :3].min(axis=-1) < 250).sum())]

    maps = set()
    with open("/proc/self/maps") as f:
        for line in f:
            parts = line.split()
            if len(parts) >= 6 and parts[5].startswith("/"):
                maps.add(parts[5])
    out["maps"] = sorted(maps)
    print(json.dumps(out))
''')


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    """A fresh virtual environment with the wheel installed; returns (python, site-packages)."""
    root = tmp_path_factory.mktemp("wheel_env")
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = venv / "bin" / "python"
    subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-index",
                    str(_wheel())], check=True)
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                               check=True, capture_output=True, text=True).stdout.strip())
    deps = root / "deps"
    deps.mkdir()
    for mod in (numpy, scipy):
        pkg = Path(mod.__file__).parent
        for p in (pkg, pkg.with_name(pkg.name + ".libs")):
            if p.exists():
                (deps / p.name).symlink_to(p)
    (site / "_vpffd_test_deps.pth").write_text(f"{deps}\n")
    return py, site


def _clean_env() -> dict:
    """No LD_LIBRARY_PATH or PYTHONPATH that could help the loader or the import."""
    keep = {k: os.environ[k] for k in ("PATH", "HOME", "TMPDIR", "VK_DRIVER_FILES", "VK_ICD_FILENAMES") if k in os.environ}
    return {**keep, "OMP_NUM_THREADS": "2"}


def _check_probe(out: dict, site: Path) -> None:
    assert Path(out["vpffd"]).is_relative_to(site), out["vpffd"]
    assert out["has_openmesh"] and out["has_embree"], "the wheel was built without OpenMesh or Embree"
    assert out["volume_error"] < 1e-10 and out["moved"] > 0.05
    assert out["ply"][:2] == [4, 4] and abs(out["ply"][2] - 1 / 6) < 1e-12
    assert out["obj"] == [4, 2]
    assert out["stl"][1] == 1280 and out["stl"][2] < 1e-5  # float32 coordinates in binary STL
    assert out["om"]
    assert out["png"][0][:2] == [48, 64] and out["png"][1] > 100  # the mesh covers pixels
    libs = (site / "vpffd.libs").resolve()
    for name in BUNDLED:
        mapped = [m for m in out["maps"] if Path(m).name.startswith(name + "-") or Path(m).name.startswith(name + ".")]
        assert mapped, f"{name} is not loaded at all: {out['maps']}"
        for m in mapped:
            assert Path(m).resolve().parent == libs, f"{name} was loaded from {m}, not from the wheel's {libs}"
    assert not any("libvulkan" in Path(m).name for m in out["maps"]), "the Vulkan loader is opened only when used"


def _run_probe(py: Path, tmp_path: Path, prefix: list[str] = ()) -> dict:
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    r = subprocess.run([*prefix, str(py), "-I", str(script), str(tmp_path)], cwd=tmp_path, env=_clean_env(),
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-4000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_extension_links_the_wheels_libraries(env):
    py, site = env
    (core,) = (site / "vpffd").glob("_core.*.so")
    r = subprocess.run(["ldd", str(core)], capture_output=True, text=True, env=_clean_env(), check=True)
    lines = [ln.strip() for ln in r.stdout.splitlines() if ln.strip()]
    assert not [ln for ln in lines if "not found" in ln], r.stdout
    assert not [ln for ln in lines if "libvulkan" in ln], "the Vulkan loader must not be a link dependency"
    for name in BUNDLED:
        found = [ln for ln in lines if ln.startswith(name)]
        assert found, f"{name} is not linked: {r.stdout}"
        for ln in found:
            path = Path(ln.split("=>")[1].split("(")[0].strip()).resolve()
            assert path.parent == (site / "vpffd.libs").resolve(), f"{name} resolves to {path}, not into the wheel"


def test_runs_from_the_wheel(env, tmp_path):
    py, site = env
    _check_probe(_run_probe(py, tmp_path), site)


def _system_copies() -> list[Path]:
    return sorted(p for name in BUNDLED for p in SYSTEM_LIBDIR.glob(name + "*.so*") if p.exists())


def _can_hide() -> bool:
    if not shutil.which("unshare") or os.geteuid() != 0:
        return False
    return subprocess.run(["unshare", "-m", "true"], capture_output=True).returncode == 0


@pytest.mark.skipif(not _can_hide(), reason="hiding the system's libraries needs root and a mount namespace "
                                            "(unshare -m)")
def test_runs_with_the_system_copies_hidden(env, tmp_path):
    """The system's copies of the bundled libraries replaced by empty files (in a
    private mount namespace): anything still reaching for them fails to load."""
    py, site = env
    hidden = _system_copies()
    mounts = "".join(f"mount --bind /dev/null '{p}' && " for p in hidden)
    out = _run_probe(py, tmp_path, ["unshare", "-m", "sh", "-c", mounts + 'exec "$0" "$@"'])
    _check_probe(out, site)


def test_bundled_libraries_bring_their_licences(env):
    _, site = env
    (info,) = site.glob("vpffd-*.dist-info")
    licences = {p.name for p in (info / "licenses").glob("*.copyright")}
    for package in ("libembree3", "libtbb", "libopenmesh", "libgomp", "libosdcpu"):
        assert any(n.startswith(package) for n in licences), f"no licence of {package} in {licences}"
