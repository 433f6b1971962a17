"""Paths to the zoo robots and a broken copy for tests of failure paths."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

ZOO = Path(__file__).resolve().parent
ZOO_ROBOTS = tuple(sorted(p.parent.name for p in ZOO.glob("*/robot.toml")))
SPOT_URDF = ZOO / "urdf" / "spotmicro.urdf"


def heavy_copy(tmp_path: Path, body_mass_kg: float) -> Path:
    """spotmicro with its body `body_mass_kg` heavy (its servos cannot hold that)."""
    dst = tmp_path / "heavyspot"
    shutil.copytree(ZOO / "spotmicro", dst)
    xml = (dst / "robot.xml").read_text()
    xml, n = re.subn(r'mass="1\.3"', f'mass="{body_mass_kg}"', xml, count=1)
    if n != 1:
        raise AssertionError("spotmicro's robot.xml no longer has the 1.3 kg body")
    (dst / "robot.xml").write_text(xml)
    return dst
