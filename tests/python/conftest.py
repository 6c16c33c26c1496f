import sys
from pathlib import Path

import pytest

SHARED_MESHES = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "meshes"


@pytest.fixture(scope="session")
def shared_meshes():
    """The developer mesh set beside the checkout; tests using it skip in a user's clone."""
    if not SHARED_MESHES.is_dir():
        pytest.skip("../shared/data/meshes is not present (a user's clone)")
    return SHARED_MESHES


def pytest_collection_modifyitems(config, items):
    """Every test that runs the Vulkan backend carries the ``gpu`` marker
    (``pytest -m gpu`` / ``-m "not gpu"``, ``ctest -L gpu``). The rule: such tests
    live in test_vulkan.py or have "vulkan" in their name or parameters."""
    for item in items:
        if "vulkan" in item.nodeid.lower():
            item.add_marker(pytest.mark.gpu)
