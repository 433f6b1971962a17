"""The WitMotion IMU driver: frames byte for byte from the datasheet's angle-output table,
checksum errors and resync, partial frames, the mount conversion against an independent
quaternion reference, a vanished adapter, and the corrector fading a silent IMU out."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from hardware.errors import ImuError
from hardware.imu.witmotion import (
    AngleFrame,
    FrameParser,
    ImuMount,
    WitmotionImu,
    angle_frame,
    parse_mount,
)
from hardware.play.attitude import AttitudeCorrector
from robots.attitude import AttitudeLaw, roll_pitch
from robots.attitude_maps import attitude_map
from tests.hardware.play.player_rig import make_rig

# WT901 datasheet §5.1.4: 0x55 0x53 RollL RollH PitchL PitchH YawL YawH VL VH SUM, angle =
# int16 / 32768 * 180 deg. Roll 90 deg = 16384 = 0x4000, pitch -45 deg = -8192 = 0xE000,
# yaw -180 deg = -32768 = 0x8000, version 0x1234; SUM = low byte of 0x55+0x53+0x00+0x40+0x00+
# 0xE0+0x00+0x80+0x34+0x12 = 0x28E -> 0x8E.
HAND_FRAME = bytes([0x55, 0x53, 0x00, 0x40, 0x00, 0xE0, 0x00, 0x80, 0x34, 0x12, 0x8E])
# an acceleration frame (0x51), valid checksum: 0x55+0x51+0x10+0x20 = 0xD6
ACCEL_FRAME = bytes([0x55, 0x51, 0x10, 0x00, 0x20, 0x00, 0, 0, 0, 0, 0xD6])


def test_angle_frame_matches_the_datasheet_bytes() -> None:
    assert angle_frame(90.0, -45.0, -180.0, version=0x1234) == HAND_FRAME
    assert angle_frame(0.0, 0.0, 0.0) == bytes([0x55, 0x53] + [0] * 8 + [0xA8])


def test_parser_decodes_the_hand_built_frame() -> None:
    parser = FrameParser()
    assert parser.feed(HAND_FRAME) == [AngleFrame(90.0, -45.0, -180.0)]
    assert parser.angle_frames == 1 and parser.bad_checksums == 0 and parser.skipped_bytes == 0


def test_bad_checksum_and_garbage_resync() -> None:
    bad = bytearray(angle_frame(10.0, 0.0, 0.0))
    bad[10] ^= 0xFF
    good = angle_frame(1.0, 2.0, 3.0)
    parser = FrameParser()
    frames = parser.feed(b"\x00\x55\x17" + bytes(bad) + ACCEL_FRAME + good)
    assert len(frames) == 1
    assert frames[0].roll_deg == pytest.approx(1.0, abs=0.006)
    assert frames[0].pitch_deg == pytest.approx(2.0, abs=0.006)
    assert parser.bad_checksums >= 2  # the stray 0x55 and the corrupted frame
    assert parser.other_frames == 1 and parser.angle_frames == 1
    # a corrupted frame whose data holds a 0x55: resync still finds the next real frame
    tricky = bytearray(angle_frame(0.0, 0.0, 0.0))
    tricky[4] = 0x55
    assert [f.yaw_deg for f in FrameParser().feed(bytes(tricky) + good)] == [
        pytest.approx(3.0, abs=0.006)]


def test_partial_frames_wait_for_their_rest() -> None:
    parser = FrameParser()
    stream = angle_frame(5.0, -5.0, 0.0) + angle_frame(6.0, -6.0, 0.0)
    got: list[AngleFrame] = []
    for i in range(len(stream)):
        got += parser.feed(stream[i:i + 1])
        assert len(got) == (i + 1) // 11
    assert [round(f.roll_deg) for f in got] == [5, 6]
    assert parser.skipped_bytes == 0


def _quat(axis: tuple[float, float, float], angle: float) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.array([math.cos(angle / 2), *(math.sin(angle / 2) * a)])


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _imu_frame(q_imu: np.ndarray) -> AngleFrame:
    """The Z-Y-X Euler angles an IMU with orientation q_imu reports (roll/pitch via
    robots.attitude.roll_pitch, yaw from the same quaternion)."""
    w, x, y, z = q_imu
    roll, pitch = roll_pitch(q_imu)
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return AngleFrame(*(math.degrees(float(a)) for a in (roll, pitch, yaw)))


def test_mount_conversion_against_quaternions() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        yaw_m, roll_m = rng.choice([-90.0, 0.0, 90.0, 180.0, 37.0]), rng.choice([0.0, 180.0])
        mount = ImuMount(yaw_m, roll_m)
        q_body = _quat(tuple(rng.normal(size=3)), rng.uniform(-0.6, 0.6))
        q_body = _qmul(_quat((0, 0, 1), rng.uniform(-3, 3)), q_body)  # any heading
        q_mount = _qmul(_quat((0, 0, 1), math.radians(yaw_m)), _quat((1, 0, 0),
                                                                    math.radians(roll_m)))
        roll, pitch = mount.body_roll_pitch(_imu_frame(_qmul(q_body, q_mount)))
        assert np.allclose([roll, pitch], roll_pitch(q_body), atol=1e-9)


def test_mount_cases_by_hand() -> None:
    rad = math.radians
    # X axis pointing left (yaw +90): the IMU's roll is the body's pitch
    assert np.allclose(ImuMount(90.0).body_roll_pitch(AngleFrame(10.0, 0.0, 0.0)),
                       [0.0, rad(10.0)], atol=1e-12)
    # X axis pointing right (yaw -90, the WT901 datasheet's axes): IMU pitch = body roll
    assert np.allclose(ImuMount(-90.0).body_roll_pitch(AngleFrame(0.0, 10.0, 0.0)),
                       [rad(10.0), 0.0], atol=1e-12)
    # upside down on a level body the IMU reads roll 180; body roll 10 deg reads -170
    upside = ImuMount(0.0, 180.0)
    assert np.allclose(upside.body_roll_pitch(AngleFrame(180.0, 0.0, 0.0)), [0, 0], atol=1e-12)
    assert np.allclose(upside.body_roll_pitch(AngleFrame(-170.0, 0.0, 0.0)), [rad(10.0), 0],
                       atol=1e-12)


def test_mount_spec_is_validated() -> None:
    assert parse_mount("") == ImuMount()
    assert parse_mount("yaw=-90, roll=180") == ImuMount(-90.0, 180.0)
    for bad, match in (("pitch=3", "yaw=DEG"), ("yaw=x", "not a number"), ("yaw=1,yaw=2", "once"),
                       ("yaw=200", r"\[-180, 180\]"), ("yaw=nan", r"\[-180, 180\]")):
        with pytest.raises(ImuError, match=match):
            parse_mount(bad)


class FakePort:
    """A serial port fed by the test; `lost` makes it fail like an unplugged adapter."""

    def __init__(self) -> None:
        self.pending = b""
        self.lost = False
        self.closed = False

    @property
    def in_waiting(self) -> int:
        if self.lost:
            raise OSError(5, "Input/output error")
        return len(self.pending)

    def read(self, size: int = 1) -> bytes:
        data, self.pending = self.pending[:size], self.pending[size:]
        return data

    def close(self) -> None:
        self.closed = True


def test_readings_are_stamped_on_the_players_clock_and_a_lost_port_reads_none() -> None:
    now = [1.0]
    port = FakePort()
    imu = WitmotionImu(port, lambda: now[0], ImuMount())
    assert imu.read() is None  # nothing yet
    port.pending = angle_frame(3.0, -2.0, 50.0) + angle_frame(4.0, -1.0, 50.0)[:5]
    reading = imu.read()
    assert reading is not None and reading.t_s == 1.0
    assert (reading.roll_rad, reading.pitch_rad) == pytest.approx(
        (math.radians(3.0), math.radians(-2.0)), abs=1e-4)
    now[0] = 1.5
    assert imu.read() == reading  # no new frame: the old reading, old stamp
    port.lost = True
    assert imu.read() is None and imu.read() is None  # never raises
    assert port.closed and imu.error is not None and "port lost" in imu.summary()


def test_a_silent_imu_fades_the_correction_out(tmp_path: Path) -> None:
    rig = make_rig(tmp_path, "biped")
    now = [0.0]
    port = FakePort()
    imu = WitmotionImu(port, lambda: now[0])
    corr = AttitudeCorrector(AttitudeLaw(1.0), attitude_map(rig.robot), rig.gait, imu)
    size = []
    for k in range(100):
        now[0] = k * 0.01
        if k < 30:
            port.pending += angle_frame(4.0, -3.0, 0.0)  # a tilted body, frames at 100 Hz
        if k == 60:
            port.lost = True  # and later the adapter vanishes: still no exception
        size.append(float(np.max(np.abs(corr.offsets(now[0], 1.0, 0.0)))))
    assert max(size[:30]) > 0.01
    # stale after max_age (0.05 s) past the last frame, then linear to zero over fade (0.2 s)
    assert all(b <= a + 1e-12 for a, b in itertools.pairwise(size[34:]))
    assert size[29 + 5 + 20 + 2] < 1e-9 and corr.trust == 0.0 and corr.stale_ticks > 0


def test_a_reading_stamped_just_after_the_ticks_clock_is_fresh(tmp_path: Path) -> None:
    """On a real clock the player reads the time, then the IMU stamps its new frame a few µs
    later: that reading must count as fresh (it was counted stale: negative age)."""
    rig = make_rig(tmp_path, "biped")
    port = FakePort()
    now = [0.0]
    imu = WitmotionImu(port, lambda: now[0] + 0.0005)  # the IMU stamps 0.5 ms after the tick
    corr = AttitudeCorrector(AttitudeLaw(1.0), attitude_map(rig.robot), rig.gait, imu)
    for k in range(20):
        now[0] = k * 0.01
        port.pending += angle_frame(4.0, -3.0, 0.0)
        size = float(np.max(np.abs(corr.offsets(now[0], 1.0, 0.0))))
        assert corr.trust == 1.0 and size > 0.01 and corr.stale_ticks == 0
    # a reading from another clock, far ahead of the player's, is not used
    imu.clock = lambda: now[0] + 1.0
    port.pending += angle_frame(4.0, -3.0, 0.0)
    corr.offsets(0.2, 1.0, 0.0)
    assert corr.stale_ticks == 1
