import shutil
from pathlib import Path

import pytest

import robots


@pytest.fixture
def quad_copy(tmp_path: Path) -> Path:
    """A user's copy of the quad12 folder, to break on purpose."""
    dst = tmp_path / "myquad"
    shutil.copytree(robots.robot.BUILTIN_DIR / "quad12", dst)
    return dst
