import importlib.util
from pathlib import Path

import pytest

import vpffd

SHARED_MESHES = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "meshes"
BENCH_PYTHON = Path(__file__).resolve().parents[2] / "bench" / "python"


@pytest.fixture(scope="session")
def load_bench():
    """load_bench(name): bench/python/<name>.py as a module (the benchmarks are scripts,
    not a package), for tests of their arithmetic."""
    def load(name: str):
        spec = importlib.util.spec_from_file_location(name, BENCH_PYTHON / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    return load


@pytest.fixture(scope="session")
def shared_meshes():
    """The developer mesh set beside the checkout; tests using it skip in a user's clone."""
    if not SHARED_MESHES.is_dir():
        pytest.skip("../shared/data/meshes is not present (a user's clone)")
    return SHARED_MESHES


# The icosphere(3) in a 6^3 cubic lattice that the core API tests share
# (test_lattice_basis, test_correction, test_api_input); a module may define its own.
@pytest.fixture(scope="module")
def sphere():
    return vpffd.shapes.icosphere(3)


@pytest.fixture(scope="module")
def lat(sphere):
    return vpffd.Lattice.around(sphere, shape=(6, 6, 6), degree=3, padding=0.05)


def pytest_collection_modifyitems(config, items):
    """Every test that runs the Vulkan backend carries the ``gpu`` marker
    (``pytest -m gpu`` / ``-m "not gpu"``, ``ctest -L gpu``). The rule: such tests
    live in test_vulkan.py or have "vulkan" in their name or parameters."""
    for item in items:
        if "vulkan" in item.nodeid.lower():
            item.add_marker(pytest.mark.gpu)
