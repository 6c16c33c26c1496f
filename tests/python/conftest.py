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
