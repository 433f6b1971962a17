"""The "Adding your own robot" walkthrough runs exactly as written: URDF → init → show → check."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
README = REPO / "README.md"


def _walkthrough_block() -> str:
    """The first ```bash block of the README's "Adding your own robot" section."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Adding your own robot") :]
    section = section[: section.index("\n## ", 3)]
    block = re.search(r"```bash\n(.*?)\n```", section, re.S)
    assert block is not None, "README: no ```bash block under 'Adding your own robot'"
    return str(block.group(1))


@pytest.mark.slow  # three fresh `gaitsmith` processes (≈ 15 s on a loaded 2-core box)
def test_walkthrough_commands_run_as_written(tmp_path: Path) -> None:
    block = _walkthrough_block()
    # the commands run from the repository's root: give the temporary folder the files they name
    for rel in re.findall(r"\btests/zoo/\S+", block):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(REPO / rel, tmp_path / rel)
    env = {
        **os.environ,
        "MUJOCO_GL": "egl",
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
    }
    proc = subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", block],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    assert (tmp_path / "my_spot" / "robot.xml").is_file()
    assert "front_left" in proc.stdout and "stands" in proc.stdout
    assert "least margin" in proc.stdout
