"""`gaitsmith-play drive` with IMU attitude feedback, on the virtual bus: the offsets are the
law's on the blend the blender plays (its entries' references and support weights, with its
weights, at its phase, faded by its α), they go in before the SafetyGate, the stand gets none,
a gait switch mid-blend keeps them bounded, a stale IMU and an IMU port that vanishes mid-drive
fade them to zero, and a library validated closed loop is refused open loop unless forced.

The library is tests/hardware/play/fixtures/biped_walk_lib.json: the built-in biped's walk at
0.222 m/s turning −0.6, 0 and +0.6 rad/s and its stand, each validated in MuJoCo closed loop at
gain 0.5 (planner.library.build_library with a validator that closes the loop at the gain
`robots.attitude.default_attitude_gain` gives the biped; 20 s on 2 cores; docs/results/
attitude_feedback.md, session 30)."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from hardware.imu.witmotion import WitmotionImu, angle_frame
from hardware.play.attitude import AttitudeCorrector, AttitudeSource, SyntheticAttitude
from hardware.play.drive import DriveConfig, Driver, drive_from_library
from hardware.play.errors import PreflightError
from hardware.play.player import PlayerConfig
from hardware.play.telemetry import TelemetryWriter
from hardware.play.watchdog import StopReason
from robots.attitude import DEFAULT_MAX_OFFSET_RAD, AttitudeLaw, blended_offsets
from robots.attitude_maps import attitude_map
from robots.library import GaitLibrary, load
from tests.hardware.imu.test_witmotion import FakePort
from tests.hardware.play.drive_rig import TELEMETRY_EXTRA, repeated, script_lines, script_source
from tests.hardware.play.player_rig import Rig, assert_wire_safe, make_rig

LIBRARY = Path(__file__).parent / "fixtures" / "biped_walk_lib.json"
TILT = (0.04, -0.03)  # a constant measured roll, pitch [rad]
CONFIG = PlayerConfig(cycles=None, ramp_s=0.5)
TICK_RAD = 2e-3  # the gate rounds goals to servo ticks (≈ 1.5e-3 rad on the biped's servos)
# straight for 3 s; at 1.0 s (inside the 2-cycle entry blend) switch to turning left, at 2.0 s
# to turning right: a gait switch mid-blend
SCRIPT = script_lines([
    *repeated(0.0, 1.0, 0.2, vx=0.222), *repeated(1.0, 2.0, 0.2, vx=0.222, yaw_rate=0.6),
    *repeated(2.0, 3.0, 0.2, vx=0.222, yaw_rate=-0.6), {"t": 3.0, "end": True},
])


# (the rig's clock) → the IMU the drive reads
SourceFactory = Callable[[Callable[[], float]], AttitudeSource]


def constant_tilt(clock: Callable[[], float]) -> AttitudeSource:
    return SyntheticAttitude(lambda t: TILT, clock)


class Drive:
    """One drive of SCRIPT on a fresh biped rig; per tick the blender's state as `on_tick`
    saw it (None before the blender exists: the ramp-in)."""

    def __init__(self, tmp_path: Path, name: str, source: SourceFactory | None = None,
                 gain: float = 1.0, config: PlayerConfig = CONFIG,
                 feed: Callable[[int], None] | None = None) -> None:
        (tmp_path / name).mkdir()
        self.rig: Rig = make_rig(tmp_path / name, "biped")
        self.library: GaitLibrary = load(LIBRARY, self.rig.robot)
        self.corrector = None if source is None else AttitudeCorrector(
            AttitudeLaw(gain), attitude_map(self.rig.robot), None, source(self.rig.clock.now_s))
        self.states: list[tuple | None] = []
        driver: Driver | None = None

        def on_tick(tick: int, t_s: float) -> None:
            b = None if driver is None else driver.blender
            if feed is not None:
                feed(tick)
            if b is None:
                self.states.append(None)
                return
            idx, w = b.entry_weights
            self.states.append((b.state, b.blend_weight, b.phase, idx, w))

        writer = TelemetryWriter(self.rig.telemetry_path, self.rig.robot.joint_names,
                                 self.rig.ids, TELEMETRY_EXTRA)
        source_cmd, _ = script_source(SCRIPT)
        driver = drive_from_library(
            self.rig.robot, self.library, source_cmd, bus=self.rig.bus, config=config,
            drive=DriveConfig(deadman_s=0.5), clock=self.rig.clock, telemetry=writer,
            on_tick=on_tick, attitude=self.corrector)
        try:
            self.result = driver.drive_run()
        finally:
            writer.close()
        self.driver = driver
        self.tel = self.rig.telemetry()

    def alpha(self) -> np.ndarray:
        return np.array([0.0 if s is None else s[1] for s in self.states])


@pytest.fixture(scope="module")
def open_loop(tmp_path_factory: pytest.TempPathFactory) -> Drive:
    # the library was validated closed loop: open loop needs force (tested below)
    return Drive(tmp_path_factory.mktemp("open"), "open", config=replace(CONFIG, force=True))


def _diff(closed: Drive, open_loop: Drive) -> np.ndarray:
    n = min(len(closed.tel.tick), len(open_loop.tel.tick))
    assert abs(len(closed.tel.tick) - len(open_loop.tel.tick)) <= 1
    return np.asarray(closed.tel.target_rad[:n] - open_loop.tel.target_rad[:n])


def test_the_offsets_are_the_laws_on_the_blend_and_pass_the_gate(
    tmp_path: Path, open_loop: Drive
) -> None:
    closed = Drive(tmp_path, "closed", constant_tilt, gain=1.0)
    assert closed.result.play.stop.reason is StopReason.COMPLETED
    assert_wire_safe(closed.rig, closed.driver.gate.max_step_ticks)
    diff = _diff(closed, open_loop)
    alpha = closed.alpha()[: len(diff)]
    full = alpha >= 1.0
    assert np.any(full) and np.max(np.abs(diff[full])) > 0.01  # the correction is streamed
    # the stand, the ramps and the ramp-in get none (α = 0)
    assert np.max(np.abs(diff[alpha == 0.0])) < TICK_RAD
    # and where it is applied it is the law's on the blender's own blend
    amap = attitude_map(closed.rig.robot)
    gaits = [e.gait for e in closed.library.entries]
    law = AttitudeLaw(1.0)
    errors = []
    for k, st in enumerate(closed.states[: len(diff)]):
        if st is None or st[1] <= 0.0:
            continue
        _, a, phase, idx, w = st
        want = blended_offsets(law, amap, [gaits[i] for i in idx], w, np.array(TILT), a, phase)
        errors.append(float(np.max(np.abs(diff[k] - want))))
    err = np.array(errors)
    off = int(np.sum(err >= TICK_RAD))
    print(f"[drive attitude] {len(err)} ticks corrected; {off} off the law by more than a "
          f"tick (max {err.max():.4f} rad); gate step clips: closed "
          f"{closed.result.play.step_clips}, open {open_loop.result.play.step_clips}")
    assert len(err) > 100
    # off the law only on ticks where the gate cut the step (the offset's own change on top of
    # the gait's motion: the gate, not the law, has the last word), and then by a few ticks
    assert off <= closed.result.play.step_clips and err.max() < 0.02
    # the blend really switched gaits mid-blend: both turning entries carried weight while α < 1
    partial = [s for s in closed.states if s is not None and 0.0 < s[1] < 1.0]
    mixed = {int(i) for s in partial for i, wi in zip(s[3], s[4], strict=True) if wi > 0.05}
    assert len(mixed) >= 2


def test_a_large_tilt_is_clipped_and_a_gait_switch_mid_blend_stays_bounded(
    tmp_path: Path, open_loop: Drive
) -> None:
    closed = Drive(tmp_path, "big", lambda clock: SyntheticAttitude(lambda t: (0.5, -0.4), clock),
                   gain=2.0)
    assert closed.result.play.stop.reason is StopReason.COMPLETED
    assert_wire_safe(closed.rig, closed.driver.gate.max_step_ticks)  # never past the gate
    diff = _diff(closed, open_loop)
    alpha = closed.alpha()[: len(diff)]
    assert np.max(np.abs(diff)) <= DEFAULT_MAX_OFFSET_RAD + TICK_RAD
    assert np.max(np.abs(diff[alpha >= 1.0])) > DEFAULT_MAX_OFFSET_RAD - 0.01  # at the clip
    assert np.max(np.abs(diff[alpha == 0.0])) < TICK_RAD


def test_a_stale_imu_mid_drive_fades_the_correction_to_zero(
    tmp_path: Path, open_loop: Drive
) -> None:
    reads_before_walk = 70 + 60  # the ramp-in (0.5 s min) and ~1.3 s into the drive
    closed = Drive(tmp_path, "stale", lambda clock: SyntheticAttitude(
        lambda t: TILT, clock, stall_after_reads=reads_before_walk), gain=1.0)
    assert closed.result.play.stop.reason is StopReason.COMPLETED
    corr = closed.corrector
    assert corr is not None and corr.stale_ticks > 0 and corr.trust == 0.0
    size = np.max(np.abs(_diff(closed, open_loop)), axis=1)
    t = closed.tel.t_sched_s[: len(size)]
    applied = np.flatnonzero(size > 0.01)
    assert len(applied) > 0
    last_fresh_t = t[applied[-1]]
    gone = t > last_fresh_t + corr.max_age_s + corr.fade_s + 0.02
    walking = closed.alpha()[: len(size)] >= 1.0
    assert np.any(gone & walking) and np.max(size[gone]) < TICK_RAD


def test_an_imu_port_that_vanishes_mid_drive_fades_out_and_the_drive_completes(
    tmp_path: Path, open_loop: Drive
) -> None:
    port = FakePort()
    made: list[WitmotionImu] = []

    def imu_on(clock: Callable[[], float]) -> AttitudeSource:
        made.append(WitmotionImu(port, clock, name="/dev/ttyIMU"))
        return made[0]

    lost_at = 180  # ticks: walking, mid-blend

    def feed(tick: int) -> None:  # an angle frame per tick until the adapter vanishes
        if tick < lost_at:
            port.pending += angle_frame(2.3, -1.7, 0.0)
        elif tick == lost_at:
            port.lost = True

    closed = Drive(tmp_path, "vanish", imu_on, gain=1.0, feed=feed)
    imu = made[0]
    assert closed.result.play.stop.reason is StopReason.COMPLETED  # nothing reached the loop
    assert_wire_safe(closed.rig, closed.driver.gate.max_step_ticks)
    assert "port lost" in imu.summary() and port.closed
    size = np.max(np.abs(_diff(closed, open_loop)), axis=1)
    t = closed.tel.t_sched_s[: len(size)]
    assert np.max(size[:lost_at]) > 0.01
    corr = closed.corrector
    assert corr is not None
    gone = t > t[lost_at] + corr.max_age_s + corr.fade_s + 0.02
    assert np.any(gone) and np.max(size[gone]) < TICK_RAD


def test_a_closed_loop_library_is_refused_open_loop_unless_forced(tmp_path: Path) -> None:
    rig = make_rig(tmp_path, "biped")
    lib = load(LIBRARY, rig.robot)
    source, _ = script_source(script_lines([{"t": 0.0, "end": True}]))
    driver = drive_from_library(rig.robot, lib, source, bus=rig.bus, config=CONFIG,
                                clock=rig.clock)
    with pytest.raises(PreflightError, match=r"library .*closed loop.*--force"):
        driver.drive_run()
    (tmp_path / "f").mkdir()
    rig = make_rig(tmp_path / "f", "biped")
    source, _ = script_source(script_lines([{"t": 0.0, "end": True}]))
    forced = drive_from_library(rig.robot, lib, source, bus=rig.bus, clock=rig.clock,
                                config=replace(CONFIG, force=True)).drive_run()
    assert forced.play.stop.reason is StopReason.COMPLETED
    assert any("open loop because of --force" in w for w in forced.play.warnings)
    (tmp_path / "c").mkdir()
    rig = make_rig(tmp_path / "c", "biped")
    source, _ = script_source(script_lines([{"t": 0.0, "end": True}]))
    corr = AttitudeCorrector(AttitudeLaw(0.5), attitude_map(rig.robot), None,
                             SyntheticAttitude(lambda t: TILT, rig.clock.now_s))
    closed = drive_from_library(rig.robot, lib, source, bus=rig.bus, clock=rig.clock,
                                config=CONFIG, attitude=corr).drive_run()
    assert closed.play.stop.reason is StopReason.COMPLETED
    assert not any("closed loop" in w or "attitude" in w for w in closed.play.warnings)


def test_the_cli_drives_the_twin_closed_loop_and_refuses_what_run_refuses(
    tmp_path: Path
) -> None:
    """`gaitsmith-play drive --virtual sim`: the twin's body is the IMU, the gain the library's
    validated one; open loop is refused without --force; --attitude-gain needs an IMU; --imu
    and the twin exclude each other."""
    import subprocess
    import sys

    from tests.hardware.player_process import env

    e = env()
    e["GAITSMITH_CALIBRATION_DIR"] = str(tmp_path / "cal")
    cmds = script_lines([*repeated(0.0, 1.5, 0.2, vx=0.222), {"t": 1.5, "end": True}])
    base = [sys.executable, "-m", "hardware.cli", "drive", str(LIBRARY), "--robot", "biped",
            "--no-realtime", "--input", "stdin", "--ramp-s", "0.5"]

    def run(*extra: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([*base, *extra], input=cmds.decode(), capture_output=True,
                              text=True, env=e, timeout=300)

    out = run("--virtual", "sim")
    assert out.returncode == 0, out.stderr[-2000:]
    text = " ".join(out.stdout.split())
    assert "attitude feedback: gain 0.5 from the twin's body orientation" in text, text
    assert "stopped: completed" in text and "twin:" in text
    for extra, code, words in (
        (("--virtual", "sim", "--attitude-gain", "0"), 2, "closed loop"),
        (("--virtual", "--attitude-gain", "0.5"), 2, "no IMU to read"),
        (("--virtual", "sim", "--imu", os.devnull), 2, "--imu"),
        (("--virtual", "sim", "--attitude-gain", "7"), 2, "--attitude-gain"),
    ):
        res = run(*extra)
        err = " ".join(res.stderr.split())
        assert res.returncode == code and words in err, (extra, res.stdout, err)


def test_the_cli_drives_from_a_witmotion_imu_without_force(tmp_path: Path) -> None:
    """`gaitsmith-play drive --imu PORT` (a WitMotion stream on a pty) on the virtual bus: the
    closed-loop library drives without --force at its validated gain; the IMU's summary ends
    the run."""
    import subprocess
    import sys

    from tests.hardware.imu.test_imu_cli import PtyImu
    from tests.hardware.player_process import env

    e = env()
    e["GAITSMITH_CALIBRATION_DIR"] = str(tmp_path / "cal")
    cmds = script_lines([*repeated(0.0, 1.0, 0.2, vx=0.222), {"t": 1.0, "end": True}])
    with PtyImu(100.0) as imu:
        out = subprocess.run(
            [sys.executable, "-m", "hardware.cli", "drive", str(LIBRARY), "--robot", "biped",
             "--virtual", "--imu", imu.path, "--imu-baud", "115200", "--imu-mount", "yaw=-90",
             "--input", "stdin", "--ramp-s", "0.3"],
            input=cmds.decode(), capture_output=True, text=True, env=e, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    text = " ".join(out.stdout.split())
    assert f"attitude feedback: gain 0.5 from the IMU on {imu.path}" in text, text
    assert "stopped: completed" in text and "imu " in out.stdout and "port lost" not in text
