"""The hobby-legged-robot servos in `robots/servos.toml`: figures against the cited datasheets,
physical plausibility, the per-protocol field rules, and `gaitsmith-play` refusing what it cannot
drive while planning and simulation still work."""

from __future__ import annotations

import math
import re
import shutil
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

import robots
from hardware.cli import app
from hardware.play.virtual_rig import bringup_gait
from planner.nlp.servo_loop import factory_servo_loops
from robots import RobotConfigError, load_catalogue, servo_model
from robots.gait import save
from robots.servo import (
    CATALOGUE_PATH,
    FEETECH_STS_DUTY_PER_P_RAD,
    FEETECH_STS_P_DEFAULT,
    PROTOCOLS,
    factory_gains,
    parse_catalogue,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

KGF_CM_NM = 0.0980665  # 1 kgf·cm in N·m

ADDED = (
    "XM430_W350",
    "XM430_W210",
    "MX_28_P2",
    "MX_64_P2",
    "XL_320",
    "AX_18A",
    "MG996R",
    "MG90S",
    "SG90",
    "STS3250",
    "SCS0009",
    "LX_16A",
    "PETOI_P1S",
    "STS3032",
    "STS3032_12V",
    "SM80BL",
    "HX_35H",
    "HX_35HM",
)


def rpm(value: float) -> float:
    return value * 2 * math.pi / 60


def per_60deg(seconds: float) -> float:
    return (math.pi / 3) / seconds


def test_every_added_entry_loads_and_validates() -> None:
    cat = load_catalogue()
    for name in ADDED:
        assert name in cat, name
        assert cat[name].protocol in PROTOCOLS
    # the whole file parses entry by entry as well (each table on its own)
    raw = tomllib.loads(CATALOGUE_PATH.read_text(encoding="utf-8"))
    for name, table in raw.items():
        body = "\n".join(f"{k} = {v!r}".replace("'", '"') for k, v in table.items())
        assert parse_catalogue(f"[{name}]\n{body}", "one.toml")[name] == cat[name]


def _entry_comments() -> dict[str, str]:
    """The comment block under each [NAME] header of the catalogue."""
    blocks: dict[str, str] = {}
    name = None
    for line in CATALOGUE_PATH.read_text(encoding="utf-8").splitlines():
        head = re.fullmatch(r"\[([A-Za-z0-9_]+)\]", line.strip())
        if head:
            name = head.group(1)
            blocks[name] = ""
        elif name is not None and line.startswith("#"):
            blocks[name] += line[1:] + "\n"
    return blocks


@pytest.mark.parametrize("name", sorted(load_catalogue()))
def test_every_entry_cites_its_source_at_its_nominal_voltage(name: str) -> None:
    comment = _entry_comments()[name]
    servo = servo_model(name)
    assert len(comment) > 80, f"[{name}] has no source comment"
    volts = f"{servo.nominal_voltage_v:g}"
    assert re.search(rf"(?<![\d.]){re.escape(volts)}(\.0)? ?V\b", comment), (
        f"[{name}] comment does not name its nominal {volts} V"
    )


# (name, stall torque as published [N·m], no-load speed as published [rad/s], mass [kg],
#  model number, protocol, ticks per revolution as published)
PUBLISHED = [
    ("XM430_W350", 4.1, rpm(46), 0.082, 1020, "dynamixel2", 4096),
    ("XM430_W210", 3.0, rpm(77), 0.082, 1030, "dynamixel2", 4096),
    ("MX_28_P2", 2.5, rpm(55), 0.077, 30, "dynamixel2", 4096),
    ("MX_64_P2", 6.0, rpm(63), 0.135, 311, "dynamixel2", 4096),
    ("XL_320", 0.39, rpm(114), 0.0167, 350, "dynamixel2_xl320", 1024 * 360 / 300),
    ("AX_18A", 1.8, rpm(97), 0.0559, 18, "dynamixel1", 1024 * 360 / 300),
    # PWM: kgf·cm and s/60° datasheets; ticks = µs of pulse width (catalogue header convention)
    ("MG996R", 11 * KGF_CM_NM, per_60deg(0.14), 0.055, 0, "pwm", 1000 * 360 / 120),
    ("MG90S", 1.8 * KGF_CM_NM, per_60deg(0.10), 0.0134, 0, "pwm", 1000 * 360 / 180),
    ("SG90", 1.8 * KGF_CM_NM, per_60deg(0.10), 0.009, 0, "pwm", 1000 * 360 / 180),
    # Feetech: kgf·cm and s/60° sheets; STS 4096/rev, SCS 0-1023 over 300°
    ("STS3250", 50 * KGF_CM_NM, per_60deg(0.133), 0.0745, 2825, "feetech_sts", 4096),
    ("SCS0009", 2.3 * KGF_CM_NM, per_60deg(0.10), 0.0132, 1284, "feetech_scs", 1024 * 360 / 300),
    ("STS3032", 4.5 * KGF_CM_NM, per_60deg(0.09), 0.020, 521, "feetech_sts", 4096),
    ("STS3032_12V", 10 * KGF_CM_NM, per_60deg(0.067), 0.0206, 521, "feetech_sts", 4096),
    # SMS series: the STS protocol over RS-485
    ("SM80BL", 80 * KGF_CM_NM, per_60deg(0.161), 0.0975, 10504, "feetech_sts", 4096),
    # Hiwonder: 0-1000 over 240°; no model-number read
    ("LX_16A", 17 * KGF_CM_NM, per_60deg(0.16), 0.052, 0, "hiwonder_bus", 1000 * 360 / 240),
    ("HX_35H", 35 * KGF_CM_NM, per_60deg(0.18), 0.052, 0, "hiwonder_bus", 1000 * 360 / 240),
    # HX-35HM: speed published; torque and mass estimated from the HX-35H (see its entry)
    ("HX_35HM", 35 * KGF_CM_NM, per_60deg(0.19), 0.052, 0, "hiwonder_bus", 1000 * 360 / 240),
    # Petoi P1S: 500-2500 µs over 270°
    ("PETOI_P1S", 3 * KGF_CM_NM, per_60deg(0.07), 0.014, 0, "pwm", 2000 * 360 / 270),
]


@pytest.mark.parametrize(
    ("name", "stall_nm", "speed_rad_s", "mass_kg", "model_number", "protocol", "ticks_rev"),
    PUBLISHED,
)
def test_figures_match_the_cited_datasheets(
    name: str,
    stall_nm: float,
    speed_rad_s: float,
    mass_kg: float,
    model_number: int,
    protocol: str,
    ticks_rev: float,
) -> None:
    s = servo_model(name)
    assert s.stall_torque_nm == pytest.approx(stall_nm, rel=1e-3)
    assert s.no_load_speed_rad_s == pytest.approx(speed_rad_s, rel=1e-3)
    assert s.mass_kg == pytest.approx(mass_kg)
    assert s.model_number == model_number
    assert s.protocol == protocol
    assert s.ticks_per_rev == pytest.approx(ticks_rev)


def test_unit_conversions_spot_checked_by_hand() -> None:
    # MG996R: 11 kgf·cm = 11 × 9.80665 N × 0.01 m; 0.14 s per 60° = 1.0472 rad / 0.14 s
    assert servo_model("MG996R").stall_torque_nm == pytest.approx(1.0787, abs=5e-4)
    assert servo_model("MG996R").no_load_speed_rad_s == pytest.approx(7.480, abs=5e-3)
    # XM430-W350: 46 rpm = 46 × 2π / 60 rad/s
    assert servo_model("XM430_W350").no_load_speed_rad_s == pytest.approx(4.817, abs=5e-3)
    # SG90: 1.8 kgf·cm, 0.1 s/60° → 10.47 rad/s (= 100 rpm)
    assert servo_model("SG90").stall_torque_nm == pytest.approx(0.1765, abs=5e-4)
    assert servo_model("SG90").no_load_speed_rad_s == pytest.approx(rpm(100), rel=1e-3)
    # AX-18A / XL-320: 1023 ticks span 300° → 0.293° per tick
    for name in ("AX_18A", "XL_320"):
        deg_per_tick = 360 / servo_model(name).ticks_per_rev
        assert deg_per_tick == pytest.approx(300 / 1024, rel=1e-6)
    # MG996R: 1000 µs of pulse for its 120° travel → 8.33 µs per degree
    assert servo_model("MG996R").ticks_per_rad == pytest.approx(1000 / math.radians(120))


def test_bus_conventions_of_the_feetech_hiwonder_and_petoi_entries() -> None:
    # Feetech model numbers are the two bytes at address 3: STS reads them low byte first
    # (STS3250: bytes 9, 11 → 0x0B09), SCS high byte first (SCS0009: bytes 5, 4 → 0x0504)
    assert servo_model("STS3250").model_number == int.from_bytes(bytes((9, 11)), "little")
    assert servo_model("SCS0009").model_number == int.from_bytes(bytes((5, 4)), "big")
    for name, model_bytes in (("STS3032", (9, 2)), ("STS3032_12V", (9, 2)), ("SM80BL", (8, 41))):
        assert servo_model(name).model_number == int.from_bytes(bytes(model_bytes), "little")
    # LX-16A: 1000 ticks span 240° → 0.24° per tick, at the protocol's fixed 115200 baud
    lx = servo_model("LX_16A")
    assert (lx.position_max_tick - lx.position_min_tick) / lx.ticks_per_rad == pytest.approx(
        math.radians(240)
    )
    assert 360 / lx.ticks_per_rev == pytest.approx(0.24)
    assert lx.default_baud == 115200
    # P1S: 500-2500 µs for its 270° travel → 7.41 µs per degree, 1500 µs centre
    p1s = servo_model("PETOI_P1S")
    assert p1s.ticks_per_rad == pytest.approx(2000 / math.radians(270), rel=1e-6)
    assert (p1s.position_min_tick + p1s.position_max_tick) / 2 == 1500
    # STS3250: 50 kgf·cm @12 V is 4.90 N·m, 0.133 s/60° is 75 rpm
    assert servo_model("STS3250").stall_torque_nm == pytest.approx(4.903, abs=5e-4)
    assert servo_model("STS3250").no_load_speed_rad_s == pytest.approx(rpm(75.2), rel=2e-3)


# Entries with a field filled from a sibling or a convention, and the field the comment must name
ESTIMATED = {
    "STS3250": ("mass", "baud"),
    "SCS0009": ("max_temperature_c",),
    "PETOI_P1S": ("7.4 V", "max_temperature_c"),
    "STS3032": ("max_temperature_c",),
    "SM80BL": ("max_temperature_c",),
    "HX_35HM": ("11.1 V", "stall torque", "mass"),
}


@pytest.mark.parametrize(("name", "fields"), sorted(ESTIMATED.items()))
def test_estimated_fields_are_said_so_in_the_comment(name: str, fields: tuple[str, ...]) -> None:
    comment = " ".join(_entry_comments()[name].split())
    for field in fields:
        assert re.search(
            rf"{re.escape(field)}[^.]*estimated|estimated:[^.]*{re.escape(field)}", comment, re.I
        ), f"[{name}] does not say its {field} is estimated"


@pytest.mark.parametrize("name", sorted(load_catalogue()))
def test_figures_are_physically_plausible(name: str) -> None:
    """Bands wide enough for a 9 g micro servo and an MX-64, narrow enough to catch a unit slip
    (kgf·cm typed as N·m is ×10, rpm typed as rad/s is ×9.5)."""
    s = servo_model(name)
    assert 0.05 <= s.stall_torque_nm <= 15.0
    assert 1.0 <= s.no_load_speed_rad_s <= 30.0  # ≈ 10 … 290 rpm
    assert 5.0 <= s.stall_torque_nm / s.mass_kg <= 100.0  # N·m per kg of servo
    peak_power_w = s.stall_torque_nm * s.no_load_speed_rad_s / 4  # DC motor: at ω₀/2
    assert peak_power_w / s.mass_kg <= 200.0  # W per kg
    assert 3.0 <= s.voltage_min_v <= s.nominal_voltage_v <= s.voltage_max_v <= 30.0
    assert 40.0 <= s.max_temperature_c <= 100.0
    span = s.position_max_tick - s.position_min_tick
    assert 0 < span < s.ticks_per_rev  # the commandable range is at most one turn
    assert math.radians(90) <= span / s.ticks_per_rad <= 2 * math.pi


def _entry(**patch: str) -> str:
    base = {
        "vendor": '"X"',
        "protocol": '"pwm"',
        "model_number": "0",
        "nominal_voltage_v": "6.0",
        "voltage_min_v": "4.8",
        "voltage_max_v": "7.2",
        "stall_torque_nm": "1.0",
        "no_load_speed_rad_s": "7.0",
        "ticks_per_rev": "3000",
        "position_min_tick": "1000",
        "position_max_tick": "2000",
        "default_baud": "0",
        "mass_kg": "0.05",
        "max_temperature_c": "55.0",
    }
    base.update(patch)
    return "[S]\n" + "\n".join(f"{k} = {v}" for k, v in base.items())


@pytest.mark.parametrize(
    ("patch", "field"),
    [
        ({"model_number": "12"}, "model_number"),
        ({"default_baud": "57600"}, "default_baud"),
        ({"protocol": '"hiwonder_bus"'}, "default_baud"),  # a bus servo with baud 0
        ({"protocol": '"feetech_scs"', "default_baud": "0"}, "default_baud"),
        ({"protocol": '"i2c"'}, "protocol"),
    ],
)
def test_protocol_field_rules_name_the_field(patch: dict[str, str], field: str) -> None:
    with pytest.raises(RobotConfigError) as info:
        parse_catalogue(_entry(**patch), "servos.toml")
    assert f"[S].{field}" in str(info.value) and "servos.toml" in str(info.value)


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_every_protocol_is_accepted_with_its_fields(protocol: str) -> None:
    patch = {"protocol": f'"{protocol}"'}
    if protocol != "pwm":
        patch |= {"model_number": "1", "default_baud": "115200"}
    assert parse_catalogue(_entry(**patch))["S"].protocol == protocol


@pytest.mark.parametrize("name", sorted(load_catalogue()))
def test_every_entry_has_factory_gains_so_it_plans_and_simulates(name: str) -> None:
    duty_p, duty_d = factory_gains(servo_model(name))
    assert duty_p > 0 and duty_d >= 0
    assert 1.0 < duty_p < 20.0  # full duty somewhere between 3° and 60° of error


def test_unpublished_loops_use_the_measured_sts_stand_in() -> None:
    sts = FEETECH_STS_P_DEFAULT * FEETECH_STS_DUTY_PER_P_RAD
    for name in ("MG996R", "SG90", "XL_320"):
        assert factory_gains(servo_model(name)) == (pytest.approx(sts), 0.0)
    # the Dynamixel X formula still applies to the XM430 and MX (2.0): 800/128 · ticks/rad / 885
    x = 800 / 128 * 4096 / (2 * math.pi) / 885
    assert factory_gains(servo_model("XM430_W350"))[0] == pytest.approx(x)


# ---------------------------------------------------------------------------------------------
# A user's robot on servos gaitsmith-play cannot drive


def _retarget(robot_dir: Path, servo_name: str) -> None:
    """Switch every joint of the copied quad12 to `servo_name`, narrowing each joint's range to
    what the servo's travel covers (around the stance) and re-centring zero_offset_ticks."""
    base = robots.load("quad12")
    servo = servo_model(servo_name)
    tpr = servo.ticks_per_rad
    centre = (servo.position_min_tick + servo.position_max_tick) / 2
    travel = 0.9 * (servo.position_max_tick - servo.position_min_tick) / tpr
    reach = (servo.position_max_tick - centre) / tpr  # joint 0 must stay inside the travel
    text = (robot_dir / "robot.toml").read_text(encoding="utf-8")
    for j in base.joints:
        s = j.stance_rad
        options = []
        for lo, hi in (
            (max(j.lower_rad, s - 0.05), min(j.upper_rad, max(j.lower_rad, s - 0.05) + travel)),
            (max(j.lower_rad, min(j.upper_rad, s + 0.05) - travel), min(j.upper_rad, s + 0.05)),
        ):
            options.append((abs((lo + hi) / 2), lo, hi))
        _, lo, hi = min(options)
        mid = (lo + hi) / 2
        assert abs(mid) < reach, f"{servo_name} cannot reach joint {j.name}'s zero"
        zero = round(centre - j.direction * mid * tpr)
        block = re.compile(rf"(\[joints\.{j.name}\]\n)(.*?)(?=\n\[|\Z)", re.S)
        body = block.search(text)
        assert body is not None
        lines = [
            ln
            for ln in body.group(2).splitlines()
            if not ln.startswith(("servo", "zero_offset_ticks", "limits_deg"))
        ]
        lines += [
            f'servo = "{servo_name}"',
            f"zero_offset_ticks = {zero}",
            # rounded inwards: limits_deg may only narrow the MJCF range
            f"limits_deg = [{math.ceil(math.degrees(lo) * 1e3) / 1e3}, "
            f"{math.floor(math.degrees(hi) * 1e3) / 1e3}]",
        ]
        text = text[: body.start(2)] + "\n".join(lines) + text[body.end(2) :]
    (robot_dir / "robot.toml").write_text(text, encoding="utf-8")


BuildRobot = Callable[[str], tuple[Path, Path]]  # servo name → (robot folder, bring-up gait)


@pytest.fixture
def build_robot(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> BuildRobot:
    monkeypatch.setenv("GAITSMITH_CALIBRATION_DIR", str(tmp_path / "cal"))

    def build(servo_name: str) -> tuple[Path, Path]:
        robot_dir = tmp_path / f"quad_{servo_name.lower()}"
        shutil.copytree(robots.robot.BUILTIN_DIR / "quad12", robot_dir)
        _retarget(robot_dir, servo_name)
        gait = tmp_path / f"bringup_{servo_name.lower()}.json"
        save(bringup_gait(robots.load(str(robot_dir))), gait)
        return robot_dir, gait

    return build


REFUSED = {
    "MG996R": "uses PWM",
    "XL_320": "uses the XL-320's own Protocol 2.0 control table",
    "SCS0009": "uses the big-endian Feetech SCS protocol",
    "LX_16A": "uses the Hiwonder bus protocol",
}


@pytest.mark.parametrize("servo_name", sorted(REFUSED))
@pytest.mark.parametrize(
    "mode",
    [
        ("--virtual", "--no-realtime"),
        ("--port", "/dev/ttyUSB0"),
        ("--dry-run",),
    ],
)
def test_play_refuses_servos_it_cannot_drive_in_one_line(
    build_robot: BuildRobot, servo_name: str, mode: tuple[str, ...]
) -> None:
    robot_dir, gait = build_robot(servo_name)
    res = CliRunner().invoke(app, ["run", str(gait), "--robot", str(robot_dir), "--force", *mode])
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert res.exit_code == 2, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit)
    assert "Traceback" not in res.output
    assert len(lines) == 1, res.output
    assert lines[0] == (
        f"error: servo model {servo_name} on joint fl_hip_roll {REFUSED[servo_name]}, which "
        "gaitsmith-play cannot drive; plan and simulate work, play needs a Dynamixel (Protocol "
        "1.0 AX / MX or 2.0 X-series) or Feetech STS bus servo"
    )


def test_calibrate_refuses_a_pwm_robot_too(build_robot: BuildRobot) -> None:
    robot_dir, _ = build_robot("MG996R")
    res = CliRunner().invoke(app, ["calibrate", "--robot", str(robot_dir), "--virtual"])
    assert res.exit_code == 2, res.output
    assert "servo model MG996R on joint fl_hip_roll uses PWM" in res.output
    assert "Traceback" not in res.output


def test_a_pwm_robot_still_plans_and_simulates(build_robot: BuildRobot) -> None:
    from sim import simulate

    robot_dir, _ = build_robot("MG996R")
    robot = robots.load(str(robot_dir))
    loops = factory_servo_loops(robot)  # the planner's servo-goal inversion needs these
    assert all(lp.kp_nm_per_rad > 0 for lp in loops)
    _, traj = simulate(bringup_gait(robot), robot, cycles=1)
    assert traj.time_s.size > 10 and bool((abs(traj.q_rad) < 10).all())


def test_a_pwm_robot_needs_no_bus_baud(build_robot: BuildRobot) -> None:
    robot_dir, _ = build_robot("SG90")
    toml = robot_dir / "robot.toml"
    toml.write_text(toml.read_text(encoding="utf-8").replace("bus_baud = 1000000\n", ""))
    assert robots.load(str(robot_dir)).bus_baud == 0  # the catalogue's "no serial bus"
