"""Where `gaitsmith-play drive` gets its velocity commands: JSON lines, keyboard, gamepad.

Every source is polled once per drive tick and never blocks (`select` with a zero timeout);
`poll(now_s)` returns the commands that arrived since the last poll, stamped with the drive
time they take effect. The drive keeps the newest one in a `CommandHold`, which falls back to
(0, 0, 0) — decelerate to the stand — once no command has arrived for `deadman_s`.

JSON lines (stdin, a file, or a Unix socket for a companion program), one object per line::

    {"vx": 0.1, "vy": 0, "yaw_rate": 0.2}      body-frame m/s, m/s, rad/s; a missing key is 0
    {"t": 4.5, "vx": 0.1}                       scripted: takes effect 4.5 s into the drive
    {"end": true}                               no more commands: stand, then end the drive

A line that is not such an object — bad JSON, an unknown key, a non-number, a value beyond
`MAX_SPEED_M_S` / `MAX_YAW_RATE_RAD_S`, a `t` that is negative or earlier than the last one,
a line longer than `MAX_LINE_BYTES` — is counted and its reason kept (`SourceStats`); it never
stops the loop. Values inside those bounds but outside the gait library's grid are clipped
into the grid by the blender, and the telemetry shows both (requested and applied).

Keyboard (a terminal only): arrows or W/S change vx, arrows or A/D the yaw rate, Q/E side-step,
space stops (0, 0, 0), Enter re-sends the command (keeps the deadman fed), X or Ctrl-D ends the
drive. The terminal goes to cbreak mode (Ctrl-C still raises SIGINT, the player's safe stop)
and is restored on every exit path (`close`, also called at interpreter exit).

Gamepad (Linux evdev, `pip install evdev`): hold the left shoulder button (the enable button,
as ROS teleop_twist_joy does) and the left stick drives vx / vy, the right stick the yaw rate,
full deflection = the grid's bound; releasing it, or a lost device, stops sending, so the
deadman brings the robot to the stand. Start ends the drive.
"""

from __future__ import annotations

import atexit
import json
import math
import os
import select
import socket
import stat
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from hardware.play.errors import PlayerError
from robots.gait import Velocity

MAX_SPEED_M_S = 5.0  # |vx|, |vy| a line may ask for (beyond: malformed, not clipped)
MAX_YAW_RATE_RAD_S = 10.0
MAX_LINE_BYTES = 4096
MAX_SCRIPT_T_S = 86400.0
READ_CHUNK = 65536
READS_PER_POLL = 4  # a large file on stdin is read over several ticks, not in one
MAX_PENDING = 100_000  # scripted lines waiting for their time, at most
MAX_CLIENTS = 8
KEYS = ("vx", "vy", "yaw_rate", "t", "end")
STOP = Velocity()


class CommandSourceError(PlayerError):
    """A command source cannot be opened (no terminal, no gamepad, socket path in use)."""


@dataclass(frozen=True)
class Received:
    """One command and the drive time [s] it takes effect (`end`: no more will come)."""

    command: Velocity
    t_s: float
    end: bool = False


@dataclass
class SourceStats:
    """What a source received: accepted commands, malformed lines and the last reason."""

    commands: int = 0
    malformed: int = 0
    last_problem: str | None = None
    notes: list[str] = field(default_factory=list)  # e.g. "gamepad lost: [Errno 19] ..."

    def reject(self, problem: str) -> None:
        self.malformed += 1
        self.last_problem = problem

    def summary(self) -> str:
        text = f"{self.commands} command(s), {self.malformed} malformed line(s)"
        if self.last_problem:
            text += f" (last: {self.last_problem})"
        return text


class CommandSource(Protocol):
    """What the drive loop polls once per tick."""

    name: str
    stats: SourceStats

    def poll(self, now_s: float) -> list[Received]: ...

    @property
    def ended(self) -> bool: ...

    def close(self) -> None: ...


class LineError(ValueError):
    """One JSON command line that is not acceptable (the message says why)."""


def _bounded(d: dict[str, Any], key: str, bound: float) -> float:
    v = d.get(key, 0.0)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise LineError(f"{key} must be a number, got {json.dumps(v)[:40]}")
    v = float(v)
    if not (math.isfinite(v) and abs(v) <= bound):
        raise LineError(f"{key} {v:g} outside [-{bound:g}, {bound:g}]")
    return v


def parse_line(text: str) -> tuple[Velocity, float | None, bool]:
    """(command, scripted time or None, end) of one JSON line; LineError if malformed."""
    try:
        d = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise LineError(f"not JSON: {str(exc)[:60]}") from None
    if not isinstance(d, dict):
        raise LineError("not a JSON object")
    unknown = sorted(set(d) - set(KEYS))
    if unknown:
        raise LineError(f"unknown key(s) {unknown[:3]}; accepted: {', '.join(KEYS)}")
    command = Velocity(
        _bounded(d, "vx", MAX_SPEED_M_S),
        _bounded(d, "vy", MAX_SPEED_M_S),
        _bounded(d, "yaw_rate", MAX_YAW_RATE_RAD_S),
    )
    t_s = None
    if "t" in d:
        t_s = _bounded(d, "t", MAX_SCRIPT_T_S)
        if t_s < 0:
            raise LineError(f"t {t_s:g} is negative")
    end = d.get("end", False)
    if not isinstance(end, bool):
        raise LineError("end must be true or false")
    return command, t_s, end


class LineDecoder:
    """Bytes → JSON command lines → `Received`, with scripted (`t`) lines held until due."""

    def __init__(self, stats: SourceStats) -> None:
        self.stats = stats
        self._partial = b""
        self._overlong = False
        self._scheduled: list[Received] = []
        self._last_t = -math.inf

    def feed(self, data: bytes, now_s: float) -> None:
        lines = (self._partial + data).split(b"\n")
        self._partial = lines.pop()
        for raw in lines:
            if self._overlong:  # the tail of a line already refused
                self._overlong = False
                continue
            self._line(raw, now_s)
        if len(self._partial) > MAX_LINE_BYTES:
            self.stats.reject(f"line longer than {MAX_LINE_BYTES} bytes")
            self._partial, self._overlong = b"", True

    def flush(self, now_s: float) -> None:
        """End of input: a last line without a newline still counts."""
        if self._partial.strip() and not self._overlong:
            self._line(self._partial, now_s)
        self._partial = b""

    def _line(self, raw: bytes, now_s: float) -> None:
        if len(raw) > MAX_LINE_BYTES:
            self.stats.reject(f"line longer than {MAX_LINE_BYTES} bytes")
            return
        text = raw.decode("utf-8", errors="replace").strip()
        if not text:
            return
        try:
            command, t_s, end = parse_line(text)
        except LineError as exc:
            self.stats.reject(str(exc))
            return
        if t_s is not None:
            if t_s < self._last_t:
                self.stats.reject(f"t {t_s:g} earlier than the line before ({self._last_t:g})")
                return
            self._last_t = t_s
        if len(self._scheduled) >= MAX_PENDING:
            self.stats.reject(f"more than {MAX_PENDING} scripted lines waiting")
            return
        self.stats.commands += 1
        self._scheduled.append(Received(command, now_s if t_s is None else t_s, end))

    def due(self, now_s: float) -> list[Received]:
        """The commands whose time has come (in order); later scripted ones wait."""
        n = 0
        while n < len(self._scheduled) and self._scheduled[n].t_s <= now_s + 1e-9:
            n += 1
        out, self._scheduled = self._scheduled[:n], self._scheduled[n:]
        return out

    @property
    def pending(self) -> int:
        return len(self._scheduled)


def _readable(fds: Sequence[int]) -> list[int]:
    if not fds:
        return []
    ready, _, _ = select.select(list(fds), [], [], 0.0)
    return ready


class StreamSource:
    """JSON lines from a file descriptor (stdin, a pipe, a file); EOF ends the input."""

    def __init__(self, fd: int, name: str = "stdin") -> None:
        self.name = name
        self.stats = SourceStats()
        self._fd: int | None = fd
        self._decoder = LineDecoder(self.stats)
        self._eof = False
        self._end_seen = False

    def poll(self, now_s: float) -> list[Received]:
        reads = 0
        while reads < READS_PER_POLL and self._fd is not None and _readable([self._fd]):
            reads += 1
            try:
                data = os.read(self._fd, READ_CHUNK)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:
                self.stats.notes.append(f"{self.name} lost: {exc}")
                data = b""
            if not data:
                self._decoder.flush(now_s)
                self._fd, self._eof = None, True
                break
            self._decoder.feed(data, now_s)
        out = self._decoder.due(now_s)
        self._end_seen = self._end_seen or any(r.end for r in out)
        return out

    @property
    def ended(self) -> bool:
        return self._end_seen or (self._eof and self._decoder.pending == 0)

    def close(self) -> None:
        self._fd = None


class SocketSource:
    """JSON lines from companion programs on a Unix stream socket created at `path` (removed
    again on close). Clients come and go; the input ends only on an `{"end": true}` line."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.name = f"socket:{self.path}"
        self.stats = SourceStats()
        try:
            mode = self.path.lstat().st_mode
        except FileNotFoundError:
            mode = None
        if mode is not None and not stat.S_ISSOCK(mode):
            raise CommandSourceError(
                f"--input socket:{self.path}: the path exists and is not a socket; "
                "choose another path or remove it"
            )
        if mode is not None:
            probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                probe.connect(str(self.path))
            except OSError:
                self.path.unlink()  # a stale socket left by a killed run
            else:
                raise CommandSourceError(
                    f"--input socket:{self.path}: another program is listening there"
                )
            finally:
                probe.close()
        self._server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            self._server.bind(str(self.path))
            self._server.listen(MAX_CLIENTS)
        except OSError as exc:
            self._server.close()
            raise CommandSourceError(
                f"--input socket:{self.path}: cannot listen there: {exc.strerror or exc}"
            ) from None
        self._server.setblocking(False)
        self._clients: dict[int, tuple[socket.socket, LineDecoder]] = {}
        self._gone: list[LineDecoder] = []  # clients that left with scripted lines pending
        self._ended = False
        self._closed = False

    def poll(self, now_s: float) -> list[Received]:
        if self._closed:
            return []
        server = self._server.fileno()
        for fd in _readable([server, *self._clients]):
            if fd == server:
                self._accept()
                continue
            conn, decoder = self._clients[fd]
            try:
                data = conn.recv(READ_CHUNK)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                data = b""
            if data:
                decoder.feed(data, now_s)
                continue
            decoder.flush(now_s)  # the client left
            conn.close()
            del self._clients[fd]
            if decoder.pending:
                self._gone.append(decoder)
        out: list[Received] = []
        for decoder in [*(d for _, d in self._clients.values()), *self._gone]:
            out += decoder.due(now_s)
        self._gone = [d for d in self._gone if d.pending]
        out.sort(key=lambda r: r.t_s)
        if any(r.end for r in out):
            self._ended = True
        return out

    def _accept(self) -> None:
        try:
            conn, _ = self._server.accept()
        except (BlockingIOError, InterruptedError):
            return
        if len(self._clients) >= MAX_CLIENTS:
            conn.close()
            self.stats.notes.append(f"{self.name}: refused a client beyond {MAX_CLIENTS}")
            return
        conn.setblocking(False)
        self._clients[conn.fileno()] = (conn, LineDecoder(self.stats))

    @property
    def ended(self) -> bool:
        return self._ended

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        for conn, _ in self._clients.values():
            conn.close()
        self._clients.clear()
        self._server.close()
        try:
            self.path.unlink()
        except OSError:
            pass


class CommandHold:
    """The command in force: the newest received, or (0, 0, 0) once none has arrived for
    `deadman_s` (the deadman) or the input has ended. `trips` counts the deadman's cuts of a
    moving command."""

    def __init__(self, deadman_s: float) -> None:
        if not (math.isfinite(deadman_s) and deadman_s > 0):
            raise ValueError("deadman_s must be a finite positive number")
        self.deadman_s = deadman_s
        self.last: Received | None = None
        self.trips = 0
        self.ended = False
        self._tripped = False

    def update(self, received: Sequence[Received]) -> None:
        for r in received:
            self.last = r
            self._tripped = False
            if r.end:
                self.ended = True

    def requested(self, now_s: float) -> Velocity:
        r = self.last
        if r is None or r.end or self.ended:
            return STOP
        if now_s - r.t_s > self.deadman_s + 1e-9:
            if not self._tripped and r.command != STOP:
                self.trips += 1
            self._tripped = True
            return STOP
        return r.command


def _clip(value: float, lo: float, hi: float) -> float:
    return min(max(value, lo), hi)


def clip_into(command: Velocity, bounds: tuple[Velocity, Velocity]) -> Velocity:
    lo, hi = bounds
    return Velocity(
        _clip(command.vx_m_s, lo.vx_m_s, hi.vx_m_s),
        _clip(command.vy_m_s, lo.vy_m_s, hi.vy_m_s),
        _clip(command.yaw_rate_rad_s, lo.yaw_rate_rad_s, hi.yaw_rate_rad_s),
    )


KEY_STEPS = 4  # keyboard: a key moves the command by 1/KEY_STEPS of the grid's bound
# key → (axis, sign); axis 0 vx, 1 vy, 2 yaw rate
_KEYMAP: dict[bytes, tuple[int, int]] = {
    b"\x1b[A": (0, 1), b"\x1bOA": (0, 1), b"w": (0, 1), b"W": (0, 1),
    b"\x1b[B": (0, -1), b"\x1bOB": (0, -1), b"s": (0, -1), b"S": (0, -1),
    b"\x1b[D": (2, 1), b"\x1bOD": (2, 1), b"a": (2, 1), b"A": (2, 1),
    b"\x1b[C": (2, -1), b"\x1bOC": (2, -1), b"d": (2, -1), b"D": (2, -1),
    b"q": (1, 1), b"Q": (1, 1), b"e": (1, -1), b"E": (1, -1),
}  # fmt: skip
_STOP_KEYS = (b" ",)
_REFRESH_KEYS = (b"\n", b"\r")
_END_KEYS = (b"x", b"X", b"\x04")
KEYBOARD_HELP = (
    "keys: arrows or W/S = forward/back, arrows or A/D = turn, Q/E = side-step, space = stop, "
    "Enter = keep going, X = stand and end (Ctrl-C: safe stop now)"
)


class KeyboardSource:
    """Arrows / WASD in a terminal (module docstring); cbreak mode, restored by `close`."""

    def __init__(
        self,
        bounds: tuple[Velocity, Velocity],
        fd: int | None = None,
        echo: Callable[[str], None] | None = None,
    ) -> None:
        import sys
        import termios
        import tty

        self.name = "keyboard"
        self.stats = SourceStats()
        self.bounds = bounds
        self._fd = sys.stdin.fileno() if fd is None else fd
        if not os.isatty(self._fd):
            raise CommandSourceError(
                "--input keyboard needs a terminal on stdin; from a program or a file use "
                "--input stdin (JSON lines) or --input socket:PATH"
            )
        lo, hi = bounds
        self._step = [
            max(abs(lo.vx_m_s), abs(hi.vx_m_s)) / KEY_STEPS,
            max(abs(lo.vy_m_s), abs(hi.vy_m_s)) / KEY_STEPS,
            max(abs(lo.yaw_rate_rad_s), abs(hi.yaw_rate_rad_s)) / KEY_STEPS,
        ]
        self._value = [0.0, 0.0, 0.0]
        self._echo = echo
        self._buffer = b""
        self._ended = False
        self._termios = termios
        self._saved: list[Any] | None = termios.tcgetattr(self._fd)
        tty.setcbreak(self._fd)  # keys one by one, no echo; Ctrl-C still sends SIGINT
        atexit.register(self.close)

    @property
    def command(self) -> Velocity:
        return Velocity(*self._value)

    def poll(self, now_s: float) -> list[Received]:
        if self._saved is None or self._ended:
            return []
        changed = False
        while _readable([self._fd]):
            try:
                data = os.read(self._fd, 256)
            except OSError:
                data = b""
            if not data:  # the terminal went away: stand and end
                self._ended = True
                return [Received(STOP, now_s, end=True)]
            self._buffer += data
            changed |= self._keys()
            if self._ended:
                return [Received(STOP, now_s, end=True)]
        if not changed:
            return []
        self.stats.commands += 1
        if self._echo is not None:
            c = self.command
            self._echo(
                f"command vx {c.vx_m_s:+.3f} m/s, vy {c.vy_m_s:+.3f} m/s, "
                f"yaw rate {c.yaw_rate_rad_s:+.3f} rad/s"
            )
        return [Received(self.command, now_s)]

    def _keys(self) -> bool:
        """Consume whole keys from the buffer; True if any key counted as a command."""
        any_key = False
        buf = self._buffer
        while buf:
            if buf[:1] == b"\x1b" and buf[1:2] in (b"", b"[", b"O"):
                if len(buf) < 3:
                    break  # the rest of an escape sequence is still on its way
                key, buf = buf[:3], buf[3:]
            else:
                key, buf = buf[:1], buf[1:]
            if key in _END_KEYS:
                self._ended = True
                break
            if key in _STOP_KEYS:
                self._value = [0.0, 0.0, 0.0]
            elif key in _KEYMAP:
                axis, sign = _KEYMAP[key]
                self._value[axis] += sign * self._step[axis]
                c = clip_into(self.command, self.bounds)
                self._value = [c.vx_m_s, c.vy_m_s, c.yaw_rate_rad_s]
            elif key not in _REFRESH_KEYS:
                self.stats.reject(f"key {key!r} does nothing ({KEYBOARD_HELP})")
                continue
            any_key = True
        self._buffer = buf
        return any_key

    @property
    def ended(self) -> bool:
        return self._ended

    def close(self) -> None:
        """Restore the terminal (idempotent; also registered with atexit)."""
        saved, self._saved = self._saved, None
        if saved is not None:
            try:
                self._termios.tcsetattr(self._fd, self._termios.TCSADRAIN, saved)
            except (OSError, self._termios.error):
                pass  # the terminal is gone
            atexit.unregister(self.close)


GAMEPAD_DEADZONE = 0.1  # of full stick deflection
EVDEV_HINT = "pip install 'evdev>=1.6' (Linux only)"


def _evdev() -> Any:
    try:
        import evdev
    except ImportError:
        raise CommandSourceError(
            f"--input gamepad needs the evdev package, which is not installed: {EVDEV_HINT}"
        ) from None
    return evdev


def find_gamepad(evdev: Any, path: str | None) -> Any:
    """The device at `path`, or the first input device with two stick axes and a left
    shoulder button; CommandSourceError naming what was found otherwise."""
    ecodes = evdev.ecodes
    if path is not None:
        try:
            return evdev.InputDevice(path)
        except OSError as exc:
            raise CommandSourceError(
                f"--input gamepad:{path}: cannot open it: {exc.strerror or exc}"
            ) from None
    paths = evdev.list_devices()
    for p in paths:
        try:
            dev = evdev.InputDevice(p)
        except OSError:
            continue
        caps = dev.capabilities()
        axes = {a[0] if isinstance(a, tuple) else a for a in caps.get(ecodes.EV_ABS, [])}
        if {ecodes.ABS_X, ecodes.ABS_Y} <= axes and ecodes.BTN_TL in caps.get(ecodes.EV_KEY, []):
            return dev
        dev.close()
    raise CommandSourceError(
        f"--input gamepad: no gamepad among {len(paths)} readable input device(s) under "
        "/dev/input; plug one in, check you may read /dev/input/event* (group 'input'), or "
        "name it: --input gamepad:/dev/input/eventN"
    )


class GamepadSource:
    """A Linux evdev gamepad (module docstring); `device`: an opened evdev.InputDevice."""

    def __init__(self, bounds: tuple[Velocity, Velocity], device: Any) -> None:
        self.evdev = _evdev()
        ecodes = self.evdev.ecodes
        self.name = f"gamepad:{getattr(device, 'path', '?')}"
        self.stats = SourceStats()
        self.bounds = bounds
        self.device = device
        self._axis_of = {ecodes.ABS_Y: 0, ecodes.ABS_X: 1, ecodes.ABS_RX: 2}
        self._range: dict[int, tuple[float, float]] = {}
        for code in self._axis_of:
            try:
                info = device.absinfo(code)
            except (OSError, KeyError, TypeError):
                continue  # no such axis (a pad without a right stick: no yaw)
            self._range[code] = (float(info.min), float(info.max))
        self._stick = [0.0, 0.0, 0.0]  # normalised, +: stick up / left
        for code, axis in self._axis_of.items():  # where the sticks are now
            if code in self._range:
                self._stick[axis] = self._normalised(code, float(device.absinfo(code).value))
        self._enabled = False
        self._ended = False

    def _normalised(self, code: int, value: float) -> float:
        lo, hi = self._range.get(code, (-1.0, 1.0))
        if hi <= lo:
            return 0.0
        u = -(2.0 * (value - lo) / (hi - lo) - 1.0)  # evdev: up / left are the low values
        return 0.0 if abs(u) < GAMEPAD_DEADZONE else _clip(u, -1.0, 1.0)

    def command(self) -> Velocity:
        lo, hi = self.bounds
        lows = (lo.vx_m_s, lo.vy_m_s, lo.yaw_rate_rad_s)
        highs = (hi.vx_m_s, hi.vy_m_s, hi.yaw_rate_rad_s)
        v = [u * (h if u > 0 else -lw) for u, lw, h in zip(self._stick, lows, highs, strict=True)]
        return Velocity(*v)

    def poll(self, now_s: float) -> list[Received]:
        if self._ended:
            return []
        ecodes = self.evdev.ecodes
        try:
            while _readable([self.device.fd]):
                try:
                    events = list(self.device.read())
                except BlockingIOError:
                    break
                for ev in events:
                    if ev.type == ecodes.EV_ABS and ev.code in self._axis_of:
                        self._stick[self._axis_of[ev.code]] = self._normalised(ev.code, ev.value)
                    elif ev.type == ecodes.EV_KEY and ev.code == ecodes.BTN_TL:
                        self._enabled = ev.value != 0
                    elif ev.type == ecodes.EV_KEY and ev.code == ecodes.BTN_START and ev.value:
                        self._ended = True
        except OSError as exc:  # unplugged (ENODEV): no more commands; stand and end
            self.stats.notes.append(f"{self.name} lost: {exc.strerror or exc}")
            self._ended = True
        if self._ended:
            return [Received(STOP, now_s, end=True)]
        if not self._enabled:
            return []  # enable button released: the deadman takes over
        self.stats.commands += 1
        return [Received(self.command(), now_s)]

    @property
    def ended(self) -> bool:
        return self._ended

    def close(self) -> None:
        try:
            self.device.close()
        except OSError:
            pass


INPUT_FORMS = "keyboard, gamepad, gamepad:/dev/input/eventN, stdin, socket:PATH"


def check_input_spec(text: str) -> str | None:
    """The one-line complaint about `--input text` (None: accepted)."""
    kind, sep, arg = text.partition(":")
    if kind in ("keyboard", "stdin") and not sep:
        return None
    if kind == "gamepad" and (not sep or arg):
        return None
    if kind == "socket" and arg:
        return None
    return f"--input {text!r}: accepted: {INPUT_FORMS}"


def open_source(
    text: str,
    bounds: tuple[Velocity, Velocity],
    stdin_fd: int = 0,
    echo: Callable[[str], None] | None = None,
) -> CommandSource:
    """The source named by `--input text` (see `check_input_spec`), opened."""
    problem = check_input_spec(text)
    if problem is not None:
        raise CommandSourceError(problem)
    kind, _, arg = text.partition(":")
    if kind == "keyboard":
        return KeyboardSource(bounds, stdin_fd, echo)
    if kind == "gamepad":
        evdev = _evdev()
        return GamepadSource(bounds, find_gamepad(evdev, arg or None))
    if kind == "socket":
        return SocketSource(arg)
    return StreamSource(stdin_fd, "stdin")
