"""The README's main command runs as written: plan → simulate → video + report on quad12."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def _commands(block_title: str) -> list[list[str]]:
    text = README.read_text(encoding="utf-8")
    start = text.index(block_title)
    block = re.search(r"```bash\n(.*?)\n```", text[start:], re.S)
    assert block is not None
    parts = [p.strip() for p in block.group(1).split("&&")]
    return [shlex.split(p) for p in parts]


def test_readme_main_command_plans_simulates_and_renders(tmp_path: Path) -> None:
    commands = _commands("Run the main job")
    assert commands[0][:2] == ["pip", "install"]  # installing is CI's job; run the rest
    env = {**os.environ, "MUJOCO_GL": "egl"}
    for argv in commands[1:]:
        proc = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=900, check=False)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    gait = json.loads((tmp_path / "out" / "quad12_trot.json").read_text())
    assert gait["validation"]["passed"] is True
    assert (tmp_path / "out" / "quad12_trot.mp4").stat().st_size > 10_000
    html = (tmp_path / "out" / "quad12_trot.html").read_text()
    assert "data:image/png;base64," in html


def test_readme_test_command_is_what_ci_runs() -> None:
    """CI builds a fresh venv and runs the README's test command verbatim (read from the README)."""
    commands = _commands("Run the tests")
    assert commands[0][:3] == ["pip", "install", "-e"]
    assert commands[1][:3] == ["python", "-m", "pytest"]
    ci = (README.parent / ".ci" / "run").read_text()
    assert "python3 -m venv" in ci and "/venv/bin/activate" in ci
    pattern = re.search(r"grep -m1 -E '([^']+)' README\.md", ci)
    assert pattern is not None, "CI no longer reads the test command from the README"
    lines = [ln for ln in README.read_text().splitlines() if re.match(pattern.group(1), ln)]
    assert lines and shlex.split(lines[0].replace("&&", " && ")) == [
        *commands[0], "&&", *commands[1]
    ]
