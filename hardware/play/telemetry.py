"""Player telemetry: one CSV row per tick, streamed and flushed, closed by a stop row.

Columns: ``tick, phase, t_sched_s, t_actual_s, jitter_s, loop_s, overrun, event, message`` then,
per joint ``<j>``: ``<j>_target_rad, <j>_target_ticks, <j>_present_rad, <j>_load_pct,
<j>_temperature_c, <j>_voltage_v``, then the caller's extra numeric columns, if any (`drive`:
the commands requested and applied, the gait phase). Times are seconds since the run's first
deadline; ``jitter_s = t_actual_s − t_sched_s`` (wake-up lateness). Present values are empty
when that tick's read failed; load / temperature / voltage are filled on status ticks only. The
last row has ``phase = "stop"``, ``event`` = the `StopReason` value, ``message`` its one-line
reason, ``t_sched_s`` when the stop was requested and ``t_actual_s`` when the torque-off had been
sent (their difference is the stop latency).

The file is created at the first row, i.e. only once pre-flight has accepted the run: a refused
run leaves no file behind (and does not truncate an older one at that path). Losing the log
never changes how the robot stops: a write that fails (disk full, ENOSPC; file system gone)
closes the file, the writer records why in `cut` and drops every later row, and the player
plays and stops as it would have.
`plot_telemetry` draws target vs present per joint and the loop jitter (matplotlib, Agg).
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from hardware.bus.servo_bus import ServoStatus

BASE_COLUMNS = (
    "tick", "phase", "t_sched_s", "t_actual_s", "jitter_s", "loop_s", "overrun", "event", "message"
)  # fmt: skip
JOINT_FIELDS = (
    "target_rad",
    "target_ticks",
    "present_rad",
    "load_pct",
    "temperature_c",
    "voltage_v",
)
STOP_PHASE = "stop"


@dataclass(frozen=True, eq=False)
class TickRecord:
    """Everything the player knows about one tick."""

    tick: int
    phase: str
    t_sched_s: float
    t_actual_s: float
    loop_s: float
    overrun: bool
    target_rad: np.ndarray  # (J,)
    target_ticks: tuple[int, ...]  # (J,)
    present_rad: np.ndarray | None  # (J,) or None when the read failed
    status: Mapping[int, ServoStatus] | None  # by bus id, on status ticks
    extra: Mapping[str, float] | None = None  # the writer's extra columns (missing: empty)


def columns(joint_names: Sequence[str], extra: Sequence[str] = ()) -> list[str]:
    return [*BASE_COLUMNS, *(f"{j}_{f}" for j in joint_names for f in JOINT_FIELDS), *extra]


def _num(x: float) -> str:
    return "" if x is None or not math.isfinite(x) else f"{x:.6g}"


class TelemetryWriter:
    """Streams `TickRecord`s to a CSV file (flushed each row) and closes with a stop row."""

    def __init__(
        self,
        path: str | Path,
        joint_names: Sequence[str],
        bus_ids: Sequence[int],
        extra_columns: Sequence[str] = (),
    ) -> None:
        self.path = Path(path)
        self.joint_names = tuple(joint_names)
        self.bus_ids = tuple(bus_ids)
        self.extra_columns = tuple(extra_columns)
        clash = set(self.extra_columns) & set(columns(self.joint_names))
        if clash:
            raise ValueError(f"extra telemetry columns {sorted(clash)} clash with the fixed ones")
        if self.path.is_dir():
            raise IsADirectoryError(21, "is a directory", str(self.path))
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if not os.access(self.path.parent, os.W_OK):
            raise PermissionError(13, "directory not writable", str(self.path.parent))
        self._fh: IO[str] | None = None
        self.rows = 0
        self.finished = False  # the stop row was written
        self._closed = False
        self.cut: str | None = None  # why the log was cut short (None: complete so far)

    def _open(self) -> bool:
        """Create the file and its header at the first row; False once the log is cut."""
        if self.cut is not None or self._closed:
            return False
        if self._fh is None:
            try:
                self._fh = self.path.open("w", newline="", encoding="utf-8")
                self._csv = csv.writer(self._fh)
                self._csv.writerow(columns(self.joint_names, self.extra_columns))
            except OSError as exc:
                self._cut(exc)
                return False
        return True

    def _cut(self, exc: OSError) -> None:
        self.cut = f"{exc.strerror or exc} after {self.rows} row(s)"
        fh, self._fh = self._fh, None
        if fh is not None:
            try:
                fh.close()
            except OSError:
                pass  # the buffered bytes cannot be written either

    def write(self, rec: TickRecord) -> None:
        if self._closed:
            raise ValueError("telemetry file is closed")
        if not self._open():
            return
        assert self._fh is not None
        jitter = rec.t_actual_s - rec.t_sched_s
        row = [
            str(rec.tick), rec.phase, _num(rec.t_sched_s), _num(rec.t_actual_s), _num(jitter),
            _num(rec.loop_s), "1" if rec.overrun else "0", "", "",
        ]  # fmt: skip
        for j, sid in enumerate(self.bus_ids):
            present = "" if rec.present_rad is None else _num(float(rec.present_rad[j]))
            st = rec.status.get(sid) if rec.status else None
            row += [_num(float(rec.target_rad[j])), str(rec.target_ticks[j]), present]
            if st is None:
                row += ["", "", ""]
            else:
                row += [_num(st.load_pct), _num(st.temperature_c), _num(st.voltage_v)]
        extra = rec.extra or {}
        row += [_num(extra.get(c, math.nan)) for c in self.extra_columns]
        try:
            self._csv.writerow(row)
            self._fh.flush()
        except OSError as exc:
            self._cut(exc)
            return
        self.rows += 1

    def finish(
        self, reason: str, message: str, tick: int, t_s: float, requested_s: float = math.nan
    ) -> None:
        """The stop row (`requested_s`: when the stop was requested, `t_s`: now, torque off);
        then the file is closed. Does nothing once the log was cut."""
        if not self._open():
            self._closed = True
            return
        assert self._fh is not None
        width = len(columns(self.joint_names, self.extra_columns))
        row = [str(tick), STOP_PHASE, _num(requested_s), _num(t_s), "", "", "", reason, message]
        try:
            self._csv.writerow(row + [""] * (width - len(row)))
            self._fh.flush()
        except OSError as exc:
            self._cut(exc)
        else:
            self.finished = True
        self.close()

    def close(self) -> None:
        """Close the file (if one was created: a run that never wrote a row leaves none)."""
        self._closed = True
        if self._fh is not None:
            try:
                self._fh.flush()
                self._fh.close()
            except OSError as exc:
                self._cut(exc)
            self._fh = None


@dataclass(frozen=True, eq=False)
class Telemetry:
    """A telemetry file read back (tick rows only; the stop row's fields separately)."""

    joint_names: tuple[str, ...]
    tick: np.ndarray
    phase: tuple[str, ...]
    t_sched_s: np.ndarray
    t_actual_s: np.ndarray
    jitter_s: np.ndarray
    overrun: np.ndarray
    target_rad: np.ndarray  # (K, J)
    target_ticks: np.ndarray  # (K, J)
    present_rad: np.ndarray  # (K, J), NaN where the read failed
    stop_reason: str | None
    stop_message: str | None
    stop_requested_s: float  # when the stop was requested (NaN: not recorded)
    stop_done_s: float  # when torque-off had been sent
    loop_s: np.ndarray  # (K,) tick work [s]
    load_pct: np.ndarray  # (K, J) % of max, signed; NaN off status ticks
    temperature_c: np.ndarray  # (K, J); NaN off status ticks
    voltage_v: np.ndarray  # (K, J); NaN off status ticks
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)  # (K,) per extra column


def _f(text: str) -> float:
    return float(text) if text else math.nan


def read_telemetry(path: str | Path) -> Telemetry:
    """Parse a telemetry CSV (ValueError with the line at fault if it is not one)."""
    path = Path(path)
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    if not rows or tuple(rows[0][: len(BASE_COLUMNS)]) != BASE_COLUMNS:
        raise ValueError(f"{path}: not a gaitsmith telemetry file (bad header)")
    header = rows[0]
    names = tuple(
        dict.fromkeys(c[: -len("_target_rad")] for c in header if c.endswith("_target_rad"))
    )
    fixed = columns(names)
    if len(header) < len(fixed) or header[: len(fixed)] != fixed:
        raise ValueError(
            f"{path}: header has {len(header)} columns, expected {len(fixed)} (and extras)"
        )
    extra_names = header[len(fixed) :]
    ticks = [r for r in rows[1:] if r and r[1] != STOP_PHASE]
    stops = [r for r in rows[1:] if r and r[1] == STOP_PHASE]
    nb, nf = len(BASE_COLUMNS), len(JOINT_FIELDS)

    def joint_col(field: int) -> np.ndarray:
        out = np.full((len(ticks), len(names)), math.nan)
        for k, r in enumerate(ticks):
            for j in range(len(names)):
                out[k, j] = _f(r[nb + j * nf + field])
        return out

    try:
        return Telemetry(
            joint_names=names,
            tick=np.array([int(r[0]) for r in ticks], dtype=int),
            phase=tuple(r[1] for r in ticks),
            t_sched_s=np.array([_f(r[2]) for r in ticks]),
            t_actual_s=np.array([_f(r[3]) for r in ticks]),
            jitter_s=np.array([_f(r[4]) for r in ticks]),
            overrun=np.array([r[6] == "1" for r in ticks], dtype=bool),
            target_rad=joint_col(0),
            target_ticks=joint_col(1),
            present_rad=joint_col(2),
            stop_reason=stops[-1][7] if stops else None,
            stop_message=stops[-1][8] if stops else None,
            stop_requested_s=_f(stops[-1][2]) if stops else math.nan,
            stop_done_s=_f(stops[-1][3]) if stops else math.nan,
            loop_s=np.array([_f(r[5]) for r in ticks]),
            load_pct=joint_col(3),
            temperature_c=joint_col(4),
            voltage_v=joint_col(5),
            extra={
                c: np.array([_f(r[len(fixed) + n]) for r in ticks])
                for n, c in enumerate(extra_names)
            },
        )
    except (IndexError, ValueError) as exc:
        raise ValueError(f"{path}: malformed row: {exc}") from None


def plot_telemetry(tel: Telemetry, out_path: str | Path, title: str = "") -> Path:
    """Targets vs present per joint, plus the loop jitter, to a PNG (matplotlib Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(tel.joint_names)
    ncols = 3 if n > 4 else max(1, n)
    nrows = math.ceil(n / ncols) + 1
    fig = plt.figure(figsize=(4.2 * ncols, 2.2 * nrows), constrained_layout=True)
    grid = fig.add_gridspec(nrows, ncols)
    t = tel.t_sched_s
    for j, name in enumerate(tel.joint_names):
        ax = fig.add_subplot(grid[j // ncols, j % ncols])
        ax.plot(t, tel.target_rad[:, j], lw=1.0, label="target")
        ax.plot(t, tel.present_rad[:, j], lw=1.0, ls="--", label="present")
        ax.set_title(name, fontsize=9)
        ax.tick_params(labelsize=7)
        if j == 0:
            ax.legend(fontsize=7)
            ax.set_ylabel("angle [rad]", fontsize=8)
    ax = fig.add_subplot(grid[nrows - 1, :])
    ax.plot(t, tel.jitter_s * 1e3, lw=0.8)
    if np.any(tel.overrun):
        ax.plot(t[tel.overrun], tel.jitter_s[tel.overrun] * 1e3, "r.", ms=3, label="overrun")
        ax.legend(fontsize=7)
    ax.set_xlabel("time [s]", fontsize=8)
    ax.set_ylabel("jitter [ms]", fontsize=8)
    stop = f" — stop: {tel.stop_reason}" if tel.stop_reason else ""
    fig.suptitle((title or "gaitsmith-play telemetry") + stop, fontsize=10)
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out
