"""A short deterministic run of the mesh-reader fuzzer (tests/fuzz): a few thousand
mutated files of every kind through vpffd.load_mesh, each batch in a child process
with a capped address space. Any crash, hang, non-MeshIOError exception, invalid
mesh or RSS jump is a failure; the offending inputs are listed in the message."""
import sys
from pathlib import Path

import pytest

import vpffd

pytestmark = pytest.mark.skipif(not vpffd._core.has_openmesh, reason="built without OpenMesh")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fuzz"))
import fuzz_io  # noqa: E402
import seeds  # noqa: E402

PER_KIND = 300  # x 10 kinds = 3000 inputs, about 30-60 s on 2 cores


def test_seeds_are_valid_meshes(tmp_path):
    for kind, files in seeds.seeds(str(tmp_path)).items():
        for i, (ext, data) in enumerate(files):
            p = tmp_path / f"{kind}{i}.{ext}"
            p.write_bytes(data)
            m = vpffd.load_mesh(p)
            assert m.n_faces in (4, 12), (kind, i)


def test_short_fuzz_run_finds_nothing(tmp_path):
    s = fuzz_io.fuzz(PER_KIND, seed=2026, out=tmp_path, log=lambda *a: None)
    assert sum(k["inputs"] for k in s["kinds"].values()) == PER_KIND * len(seeds.KINDS + seeds.STRATEGIES)
    assert not s["findings"], s["findings"][:10]
    # The mutants must exercise both outcomes, or the fuzzer tests nothing.
    assert sum(k["ok"] for k in s["kinds"].values()) > 0.02 * PER_KIND * len(seeds.KINDS)
    assert sum(k["meshioerror"] for k in s["kinds"].values()) > 0.5 * PER_KIND * len(seeds.KINDS)
    # The valid strategies load every file; truncations are refused but for a few cuts
    # inside trailing text (a last line without its newline).
    for kind in ("ply_types", "bom"):
        assert s["kinds"][kind]["ok"] == PER_KIND, s["kinds"][kind]
    assert s["kinds"]["truncated"]["meshioerror"] > 0.8 * PER_KIND


def test_writes_under_file_size_limits_keep_old_files():
    findings = fuzz_io.fuzz_writes(60, seed=2026)
    assert not findings, findings[:10]
