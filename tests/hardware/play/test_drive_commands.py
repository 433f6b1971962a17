"""Command sources of `gaitsmith-play drive`: JSON lines (pipe, socket), keyboard, gamepad,
and the deadman hold."""

from __future__ import annotations

import os
import socket
import termios
from pathlib import Path

import evdev
import pytest
from evdev import ecodes

from hardware.play.command_sources import (
    MAX_LINE_BYTES,
    STOP,
    CommandHold,
    CommandSourceError,
    GamepadSource,
    KeyboardSource,
    LineError,
    Received,
    SocketSource,
    StreamSource,
    check_input_spec,
    find_gamepad,
    open_source,
    parse_line,
)
from robots.gait import Velocity

BOUNDS = (Velocity(-0.1, -0.05, -0.6), Velocity(0.2, 0.05, 0.6))


def test_a_json_line_is_a_body_frame_command_missing_keys_zero() -> None:
    assert parse_line('{"vx":0.1,"vy":0,"yaw_rate":0.2}') == (Velocity(0.1, 0.0, 0.2), None, False)
    assert parse_line('{"yaw_rate": -0.3}') == (Velocity(0.0, 0.0, -0.3), None, False)
    assert parse_line('{"t": 2.5, "vx": 0.05}') == (Velocity(0.05), 2.5, False)
    assert parse_line('{"end": true}') == (STOP, None, True)


@pytest.mark.parametrize(
    "line, why",
    [
        ("vx=0.1", "not JSON"),
        ("[0.1, 0, 0]", "not a JSON object"),
        ('{"vX": 0.1}', "unknown key"),
        ('{"vx": "fast"}', "must be a number"),
        ('{"vx": true}', "must be a number"),
        ('{"vx": 1e308}', "outside"),
        ('{"vx": NaN}', "outside"),
        ('{"yaw_rate": -11}', "outside"),
        ('{"t": -1}', "negative"),
        ('{"end": 1}', "true or false"),
        ("[" * 100000, "not JSON"),
    ],
)
def test_malformed_lines_are_refused_with_a_reason(line: str, why: str) -> None:
    with pytest.raises(LineError, match=why):
        parse_line(line)


def _pipe_source(data: bytes) -> StreamSource:
    r, w = os.pipe()
    os.write(w, data)
    os.close(w)
    return StreamSource(r)


def test_stream_counts_malformed_lines_and_keeps_the_good_ones() -> None:
    src = _pipe_source(
        b'{"vx": 0.1}\nnot json\n{"vx": 9}\n\n' + b"x" * (MAX_LINE_BYTES + 10) + b"\n"
        b'{"yaw_rate": 0.3}'  # no newline at EOF: still a line
    )
    got = src.poll(0.0)
    assert [r.command for r in got] == [Velocity(0.1), Velocity(0, 0, 0.3)]
    assert src.stats.commands == 2 and src.stats.malformed == 3
    assert "longer than" in (src.stats.last_problem or "")
    assert src.ended  # EOF and nothing scheduled


def test_scripted_lines_take_effect_at_their_time_in_order() -> None:
    src = _pipe_source(b'{"t":0,"vx":0.1}\n{"t":1.5,"yaw_rate":0.4}\n{"t":1.0,"vx":0}\n')
    assert [r.command for r in src.poll(0.0)] == [Velocity(0.1)]
    assert src.stats.malformed == 1  # t 1.0 after t 1.5
    assert not src.ended
    assert src.poll(1.49) == []
    assert src.poll(1.5) == [Received(Velocity(0, 0, 0.4), 1.5)]
    assert src.ended


def test_the_deadman_falls_back_to_the_stand_and_counts_the_cut() -> None:
    hold = CommandHold(deadman_s=0.5)
    assert hold.requested(0.0) == STOP
    hold.update([Received(Velocity(0.1), 1.0)])
    assert hold.requested(1.5) == Velocity(0.1)
    assert hold.requested(1.51) == STOP and hold.trips == 1
    assert hold.requested(3.0) == STOP and hold.trips == 1
    hold.update([Received(Velocity(0.1), 3.0)])
    assert hold.requested(3.1) == Velocity(0.1)
    hold.update([Received(STOP, 3.2, end=True)])
    assert hold.ended and hold.requested(3.2) == STOP


def test_socket_source_serves_companion_programs(tmp_path: Path) -> None:
    path = tmp_path / "drive.sock"
    src = SocketSource(path)
    try:
        with pytest.raises(CommandSourceError, match="another program is listening"):
            SocketSource(path)
        a = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        a.connect(str(path))
        src.poll(0.0)  # accepts
        a.sendall(b'{"vx": 0.05}\n{"vx": bad}\n{"vy"')
        got = []
        for _ in range(50):
            got += src.poll(0.1)
            if got:
                break
        assert [r.command for r in got] == [Velocity(0.05)]
        a.sendall(b': 0.02}\n')
        a.close()  # the companion leaves; its last line still counts
        got = []
        for _ in range(50):
            got += src.poll(0.2)
        assert [r.command for r in got] == [Velocity(0.0, 0.02)]
        assert src.stats.malformed == 1 and not src.ended
        b = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        b.connect(str(path))
        b.sendall(b'{"end": true}\n')
        for _ in range(50):
            src.poll(0.3)
        assert src.ended
        b.close()
    finally:
        src.close()
    assert not path.exists()


def test_socket_source_refuses_a_path_that_is_not_a_socket_and_replaces_a_stale_one(
    tmp_path: Path,
) -> None:
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(CommandSourceError, match="not a socket"):
        SocketSource(f)
    stale = tmp_path / "stale.sock"
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.bind(str(stale))
    s.close()  # left behind by a killed run: nobody listens
    SocketSource(stale).close()


def test_keyboard_keys_step_the_command_and_the_terminal_is_restored() -> None:
    master, slave = os.openpty()
    before = termios.tcgetattr(slave)
    lines: list[str] = []
    src = KeyboardSource(BOUNDS, slave, echo=lines.append)
    try:
        assert termios.tcgetattr(slave) != before  # cbreak
        assert not termios.tcgetattr(slave)[3] & termios.ICANON
        assert termios.tcgetattr(slave)[3] & termios.ISIG  # Ctrl-C still signals
        os.write(master, b"\x1b[A\x1b[Aw")  # up, up, w: 3 steps of 0.2 / 4
        got = src.poll(0.0)
        assert got[-1].command.vx_m_s == pytest.approx(0.15)
        os.write(master, b"wwwwaq")  # clipped at the bound; turn left; side-step left
        c = src.poll(0.1)[-1].command
        assert (c.vx_m_s, c.vy_m_s, c.yaw_rate_rad_s) == pytest.approx((0.2, 0.0125, 0.15))
        os.write(master, b"\n")  # Enter: the same command again (feeds the deadman)
        assert src.poll(0.2)[-1] == Received(c, 0.2)
        os.write(master, b"z ")  # an unknown key (counted), then space = stop
        assert src.poll(0.3)[-1].command == STOP
        assert src.stats.malformed == 1
        os.write(master, b"\x1b[D")  # an arrow split over two reads
        src.poll(0.35)
        os.write(master, b"x")
        got = src.poll(0.4)
        assert got and got[-1].end and src.ended
        assert lines and lines[-1].startswith("command vx")
    finally:
        src.close()
        src.close()  # idempotent
    assert termios.tcgetattr(slave) == before
    os.close(master)
    os.close(slave)


def test_keyboard_needs_a_terminal() -> None:
    r, w = os.pipe()
    try:
        with pytest.raises(CommandSourceError, match="needs a terminal"):
            KeyboardSource(BOUNDS, r)
    finally:
        os.close(r)
        os.close(w)


class FakePad:
    """Just enough of an evdev.InputDevice: a readable fd and queued events."""

    def __init__(self) -> None:
        self._r, self._w = os.pipe()
        self.fd = self._r
        self.path = "/dev/input/event99"
        self.queue: list[evdev.InputEvent] = []
        self.unplugged = False

    def push(self, etype: int, code: int, value: int) -> None:
        self.queue.append(evdev.InputEvent(0, 0, etype, code, value))
        os.write(self._w, b".")

    def absinfo(self, code: int) -> evdev.AbsInfo:
        return evdev.AbsInfo(value=128, min=0, max=255, fuzz=0, flat=0, resolution=0)

    def read(self) -> list[evdev.InputEvent]:
        if self.unplugged:
            raise OSError(19, "No such device")
        os.read(self._r, 4096)
        out, self.queue = self.queue, []
        if not out:
            raise BlockingIOError
        return out

    def close(self) -> None:
        os.close(self._r)
        os.close(self._w)


def test_gamepad_drives_while_the_enable_button_is_held() -> None:
    pad = FakePad()
    src = GamepadSource(BOUNDS, pad)
    pad.push(ecodes.EV_ABS, ecodes.ABS_Y, 0)  # left stick fully up
    pad.push(ecodes.EV_ABS, ecodes.ABS_RX, 255)  # right stick fully right: turn right
    assert src.poll(0.0) == []  # not enabled: nothing sent, the deadman will stand it
    pad.push(ecodes.EV_KEY, ecodes.BTN_TL, 1)
    c = src.poll(0.1)[-1].command
    assert c.vx_m_s == pytest.approx(0.2) and c.vy_m_s == 0.0
    assert c.yaw_rate_rad_s == pytest.approx(-0.6)
    assert src.poll(0.2)[-1].command == c  # held: sent every poll
    pad.push(ecodes.EV_ABS, ecodes.ABS_X, 130)  # in the deadzone
    assert src.poll(0.3)[-1].command.vy_m_s == 0.0
    pad.push(ecodes.EV_KEY, ecodes.BTN_TL, 0)
    assert src.poll(0.4) == []
    pad.unplugged = True
    os.write(pad._w, b".")
    got = src.poll(0.5)
    assert got[-1].end and src.ended and "lost" in src.stats.notes[0]
    src.close()


def test_no_gamepad_is_a_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(evdev, "list_devices", lambda: [])
    with pytest.raises(CommandSourceError, match="no gamepad among 0 readable input"):
        find_gamepad(evdev, None)
    with pytest.raises(CommandSourceError, match="cannot open it"):
        find_gamepad(evdev, "/dev/input/event-none")


def test_missing_evdev_is_a_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "evdev", None)
    with pytest.raises(CommandSourceError, match="needs the evdev package"):
        open_source("gamepad", BOUNDS)


@pytest.mark.parametrize("text", ["keyboard", "stdin", "gamepad", "gamepad:/dev/x", "socket:/a"])
def test_input_specs_accepted(text: str) -> None:
    assert check_input_spec(text) is None


@pytest.mark.parametrize("text", ["joystick", "socket:", "stdin:x", "keyboard:1", ""])
def test_input_specs_refused(text: str) -> None:
    assert "accepted: keyboard, gamepad" in (check_input_spec(text) or "")


def test_a_large_file_on_stdin_is_read_over_several_polls(tmp_path: Path) -> None:
    from hardware.play.command_sources import READ_CHUNK, READS_PER_POLL

    path = tmp_path / "many.jsonl"
    line = b'{"vx": 0.1}\n'
    n = 3 * READ_CHUNK * READS_PER_POLL // len(line)
    path.write_bytes(line * n)
    fd = os.open(path, os.O_RDONLY)
    src = StreamSource(fd)
    first = len(src.poll(0.0))
    assert 0 < first < n  # one tick reads at most READS_PER_POLL chunks
    total = first
    for _ in range(10):
        total += len(src.poll(0.0))
    assert total == n and src.ended
    os.close(fd)
