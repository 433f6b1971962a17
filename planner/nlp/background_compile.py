"""Compile a robot's knot derivatives in a detached background process (issue #16).

The compiled J(u) and H(u, λ) of one knot (`planner.nlp.compiled_knot`) cut IPOPT's function
evaluations 2.4–3.7× (docs/results/planner_speed_compiled.md), but compiling them takes about a
minute of CPU per robot (gcc -O1, ~870 MB at its peak on quad12), too long to make a command
wait. So when a "knot" build (`solver_cache.knot_jacobian_and_hessian`) finds no compiled entry
for the compiler at hand, `start` launches the compile in a process of its own — its own session
(Ctrl-C and the end of the command do not stop it), ``nice 10``, output to
``knot-<key>.log`` in the cache folder — and the command plans on with the SX J and H. The next
command on that robot loads the library from the cache.

- One background compile at a time per cache folder: the slot lock
  ``background-compile.slot.lock``, held like the key's (below) for as long as the compile runs.
  A command that finds it taken starts none and plans on; a later one tries again. (A
  `gaitsmith design` run or a retargeting series builds a planner for body after body; each
  started its own compile, about a minute of CPU and 0.9 GB each, a dozen at once on 2 cores.)
- One compile per key at a time, across processes: the lock ``knot-<key>.lock`` is held with
  ``flock`` by the compiling process (the launcher takes it, the compile process inherits it and
  the launcher lets go), and it holds the compile's pid for `status`. The kernel releases a
  ``flock`` when its holder dies, so the lock of a killed compile is simply taken over; a search's
  workers and its main process race for the same lock and only one of them starts a compile.
- The compile stays atomic (`compiled_knot.compile_jacobian_and_hessian`: a temp folder,
  ``os.replace``, then the manifest): a killed compile leaves no entry and a later command
  tries again. Bounded: ``knot-<key>.attempts.json`` counts the attempts and the failures (the
  compiler's exit or another error); after `MAX_FAILURES` failures, or `MAX_ATTEMPTS` attempts
  without a library (killed ones count), no command starts one again for that key
  (``gaitsmith cache build ROBOT`` still compiles in the foreground and, done, clears the record).
- No C compiler: nothing starts and nothing is printed (``gaitsmith cache`` says so).
- ``GAITSMITH_BACKGROUND_COMPILE=0`` (``gaitsmith plan --no-background-compile`` sets it for its
  process and its workers) turns it off; the test suite sets it off (tests/conftest.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca

from planner.nlp import compiled_knot
from robots.errors import OutputWriteError
from robots.files import atomic_write_bytes

#: the switch: "0", "off", "false" or "no" turn the background compile off
ENV_SWITCH = "GAITSMITH_BACKGROUND_COMPILE"
OFF_VALUES = ("0", "off", "false", "no")
ON_VALUES = ("", "1", "on", "true", "yes")
#: a key whose compile failed this many times is not compiled in the background again
MAX_FAILURES = 2
#: nor one that was started this many times without leaving a library (killed compiles count)
MAX_ATTEMPTS = 3
#: the compile process's niceness (it runs beside the command that started it, on the same cores)
NICENESS = 10

#: memory the compile may need: gcc -O1 peaked at 0.86 GB (quad12) to 1.82 GB (humanoid20)
#: (docs/results/planner_speed_compiled.md, session 31); with less available (MemAvailable)
#: the compile is not started, so a small board never swaps or meets the OOM killer over it
MIN_AVAILABLE_MEMORY_BYTES = 2 * 1024**3

#: the compile processes this process started (kept so they are not garbage-collected while
#: they run: `subprocess.Popen` warns when one is)
_started: list[subprocess.Popen[bytes]] = []
#: warned once per process about an unrecognised value of `ENV_SWITCH`
_warned_switch: list[str] = []
#: said once per process that memory was short
_warned_memory: list[int] = []


def available_memory_bytes() -> int | None:
    """The kernel's estimate of memory available without swapping (Linux ``MemAvailable``), or
    None where it cannot be read (then the compile is not held back)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _memory_allows() -> bool:
    free = available_memory_bytes()
    if free is None or free >= MIN_AVAILABLE_MEMORY_BYTES:
        return True
    if not _warned_memory:
        _warned_memory.append(free)
        compiled_knot.warn(
            f"not compiling the knot derivatives in the background: {free / 1024**3:.1f} GB of "
            f"memory available, the compiler may need {MIN_AVAILABLE_MEMORY_BYTES / 1024**3:.0f} "
            "GB; `gaitsmith cache build ROBOT` compiles them when the machine is idle")
    return False


def enabled() -> bool:
    """Whether a "knot" build may start a background compile (`ENV_SWITCH`, default on). An
    unrecognised value turns it off, with one warning line per process."""
    value = os.environ.get(ENV_SWITCH, "").strip().lower()
    if value in ON_VALUES:
        return sys.platform != "win32"  # the lock is an flock (POSIX)
    if value not in OFF_VALUES and value not in _warned_switch:
        _warned_switch.append(value)
        compiled_knot.warn(f"${ENV_SWITCH}={value!r} is not one of 0/1 (on/off); the "
                           "background compile of the knot derivatives stays off")
    return False


def lock_path(entry: compiled_knot.CompiledEntry) -> Path:
    return entry.library.with_suffix(".lock")


def slot_path(entry: compiled_knot.CompiledEntry) -> Path:
    """The lock of the cache folder's one background-compile slot (any key)."""
    return entry.library.parent / "background-compile.slot.lock"


def log_path(entry: compiled_knot.CompiledEntry) -> Path:
    return entry.library.with_suffix(".log")


def attempts_path(entry: compiled_knot.CompiledEntry) -> Path:
    return entry.library.with_suffix(".attempts.json")


def _input_path(entry: compiled_knot.CompiledEntry) -> Path:
    return entry.library.with_suffix(".input.casadi")


def _job_path(entry: compiled_knot.CompiledEntry) -> Path:
    return entry.library.with_suffix(".job.json")


@dataclass(frozen=True)
class Attempts:
    """What ``knot-<key>.attempts.json`` records of a key's background compiles."""

    label: str = ""
    attempts: int = 0
    failures: int = 0
    last_error: str = ""

    @property
    def gave_up(self) -> bool:
        return self.failures >= MAX_FAILURES or self.attempts >= MAX_ATTEMPTS


def read_attempts(path: Path) -> Attempts:
    """The record at `path`; an empty one if missing or unreadable (then a compile is allowed)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        record = Attempts(str(data.get("label", "")), int(data["attempts"]),
                          int(data["failures"]), str(data.get("last_error", "")))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return Attempts()
    return record if record.attempts >= 0 and record.failures >= 0 else Attempts()


def _write_attempts(path: Path, record: Attempts) -> None:
    text = json.dumps({"label": record.label, "attempts": record.attempts,
                       "failures": record.failures, "last_error": record.last_error})
    atomic_write_bytes(path, text.encode("utf-8"))


def _try_lock(path: Path) -> int | None:
    """An open descriptor of `path` holding its ``flock``, or None if another process holds it."""
    import fcntl  # POSIX only (`enabled` is False elsewhere)

    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        return None
    except OSError:
        os.close(fd)
        raise
    return fd


def _write_lock_text(fd: int, pid: int, label: str) -> None:
    text = json.dumps({"pid": pid, "label": label, "started_utc": time.strftime(
        "%Y-%m-%dT%H:%M:%SZ", time.gmtime())})
    os.ftruncate(fd, 0)
    os.pwrite(fd, text.encode("utf-8"), 0)


@dataclass(frozen=True)
class Running:
    """A compile running in the background: its process id (from the lock file) and its log."""

    pid: int | None
    label: str
    started_utc: str
    log: Path


def running(entry: compiled_knot.CompiledEntry) -> Running | None:
    """The compile of `entry` that holds its lock now, None if none does."""
    path = lock_path(entry)
    if not path.exists():
        return None
    try:
        fd = _try_lock(path)
    except OSError:
        return None
    if fd is not None:  # nobody holds it: a finished or killed compile's file
        os.close(fd)
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        pid, label, started = int(data["pid"]), str(data["label"]), str(data["started_utc"])
    except (OSError, ValueError, KeyError, TypeError):
        pid, label, started = None, "", ""
    return Running(pid, label, started, log_path(entry))


@dataclass(frozen=True)
class Started:
    """A background compile this process started."""

    process: subprocess.Popen[bytes]
    log: Path

    @property
    def pid(self) -> int:
        return self.process.pid


def start(knot: ca.Function, entry: compiled_knot.CompiledEntry,
          compiler: compiled_knot.Compiler, label: str = "") -> Started | None:
    """Start compiling `knot`'s J and H into `entry` in a detached process, unless the switch is
    off, less than `MIN_AVAILABLE_MEMORY_BYTES` of memory is available, another process is
    compiling this key, the key gave up (`Attempts.gave_up`) or the entry is in the cache by
    now. Says so in one line on stderr when it starts one. A cache
    folder that cannot be written or a process that cannot be started: nothing happens (the
    command plans on with the SX J and H)."""
    if not enabled() or not _memory_allows():
        return None
    try:
        entry.library.parent.mkdir(parents=True, exist_ok=True)
        fd = _try_lock(lock_path(entry))
    except OSError:
        return None
    if fd is None:
        return None
    try:
        slot = _try_lock(slot_path(entry))
    except OSError:
        slot = None
    if slot is None:  # another robot's compile runs: this one waits for a later command
        os.close(fd)
        return None
    try:
        return _start_locked(fd, slot, knot, entry, compiler, label)
    except (OSError, OutputWriteError, subprocess.SubprocessError):
        return None
    finally:
        os.close(fd)  # the compile process holds its own copies of both locks
        os.close(slot)


def _start_locked(fd: int, slot: int, knot: ca.Function, entry: compiled_knot.CompiledEntry,
                  compiler: compiled_knot.Compiler, label: str) -> Started | None:
    record_path = attempts_path(entry)
    record = read_attempts(record_path)
    if record.gave_up:
        return None
    # another process may have compiled it between this build's look and taking the lock
    if compiled_knot.load_compiled(entry) is not None:
        return None
    atomic_write_bytes(_input_path(entry), knot.serialize().encode("utf-8"))
    job = {"lock_fd": fd, "input": str(_input_path(entry)), "label": label,
           "entry": {"key": entry.key, "library": str(entry.library),
                     "manifest": str(entry.manifest), "n_u": entry.n_u, "n_y": entry.n_y},
           "compiler": {"path": compiler.path, "version": compiler.version,
                        "flags": list(compiler.flags)}}
    atomic_write_bytes(_job_path(entry), json.dumps(job).encode("utf-8"))
    _write_attempts(record_path, Attempts(label or record.label, record.attempts + 1,
                                          record.failures, record.last_error))
    # the compile process imports this very package (whatever put it on this process's path)
    root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ, OMP_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p))
    log = log_path(entry)
    with open(log, "wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "planner.nlp.background_compile", str(_job_path(entry))],
            stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT, env=env,
            pass_fds=(fd, slot), start_new_session=True, close_fds=True,
        )
    _write_lock_text(fd, process.pid, label)
    _started.append(process)
    who = f"{label}'s" if label else "the robot's"
    print(f"gaitsmith: compiling {who} knot derivatives to C in the background (pid "
          f"{process.pid}, nice {NICENESS}; later commands on it plan faster); log: {log}",
          file=sys.stderr, flush=True)
    return Started(process, log)


def wait_for(entry: compiled_knot.CompiledEntry, timeout_s: float | None = None) -> bool:
    """Wait until no process compiles `entry` (its lock is free); False if `timeout_s` passed
    first. For ``gaitsmith cache build``, so it does not compile the same key a second time."""
    path = lock_path(entry)
    if not path.exists():
        return True
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    while True:
        try:
            fd = _try_lock(path)
        except OSError:
            return True
        if fd is not None:
            os.close(fd)
            return True
        if deadline is not None and time.monotonic() >= deadline:
            return False
        time.sleep(0.5)


@dataclass(frozen=True)
class CacheStatus:
    """What the cache folder holds of compiled knot derivatives (for ``gaitsmith cache``)."""

    directory: Path
    #: compiled entries: (manifest path, its robot label, library bytes, compiler flags)
    compiled: tuple[tuple[Path, str, int, tuple[str, ...]], ...]
    #: compiles running now
    running: tuple[Running, ...]
    #: keys with recorded attempts that left no library: (record path, record)
    attempts: tuple[tuple[Path, Attempts], ...]


def cache_status(directory: Path) -> CacheStatus:
    """The compiled entries, running compiles and recorded attempts in `directory`."""
    compiled, busy, records = [], [], []
    try:
        names = sorted(p.name for p in directory.iterdir())
    except OSError:
        names = []
    for name in names:
        if not name.startswith("knot-"):
            continue
        key = name.removeprefix("knot-").split(".", 1)[0]
        entry = compiled_knot.entry_at(directory, key)
        if name == entry.manifest.name:
            try:
                doc = json.loads(entry.manifest.read_text(encoding="utf-8"))
                size = entry.library.stat().st_size
                compiled.append((entry.manifest, str(doc.get("label", "")), size,
                                 tuple(str(f) for f in doc.get("flags", []))))
            except (OSError, ValueError, TypeError, AttributeError):
                continue
        elif name == lock_path(entry).name:
            now = running(entry)
            if now is not None:
                busy.append(now)
        elif name == attempts_path(entry).name:
            record = read_attempts(attempts_path(entry))
            if record.attempts:
                records.append((attempts_path(entry), record))
    return CacheStatus(directory, tuple(compiled), tuple(busy), tuple(records))


def clear_attempts(entry: compiled_knot.CompiledEntry) -> None:
    """Forget the key's failed attempts (a library was compiled)."""
    try:
        attempts_path(entry).unlink(missing_ok=True)
    except OSError:
        pass


def _log(message: str) -> None:
    print(f"{time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC  {message}", flush=True)


def _entry_from(job: dict[str, Any]) -> tuple[compiled_knot.CompiledEntry,
                                               compiled_knot.Compiler]:
    e, c = job["entry"], job["compiler"]
    entry = compiled_knot.CompiledEntry(str(e["key"]), Path(e["library"]), Path(e["manifest"]),
                                        int(e["n_u"]), int(e["n_y"]))
    return entry, compiled_knot.Compiler(str(c["path"]), str(c["version"]),
                                         tuple(str(f) for f in c["flags"]))


def main(argv: list[str]) -> int:
    """The compile process: ``python -m planner.nlp.background_compile JOB.json`` (written by
    `start`, which passes the lock's descriptor on). Exit 0 when the library is in the cache."""
    import resource

    from planner.nlp.solver_cache import jacobian_and_hessian

    try:
        os.nice(NICENESS)
    except OSError:
        pass
    if len(argv) != 1:
        print("usage: python -m planner.nlp.background_compile JOB.json", file=sys.stderr)
        return 2
    job_file = Path(argv[0])
    job = json.loads(job_file.read_text(encoding="utf-8"))
    entry, compiler = _entry_from(job)
    label = str(job.get("label", ""))
    # keep the inherited lock descriptor open until this process ends (the kernel then frees it)
    lock_fd = int(job["lock_fd"])
    _log(f"pid {os.getpid()}: compiling the knot derivatives of {label or '(unnamed robot)'} "
         f"with {compiler.path} {' '.join(compiler.flags)} ({compiler.version}) into "
         f"{entry.library}")
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    try:
        knot = ca.Function.deserialize(Path(job["input"]).read_text(encoding="utf-8"))
        jacobian, hessian = jacobian_and_hessian(knot)
        _log(f"J and H built ({time.process_time() - t_cpu:.1f} s CPU); generating C and "
             "compiling")
        compiled_knot.compile_jacobian_and_hessian(entry, jacobian, hessian, compiler, label)
    except Exception as exc:  # every failure is recorded, so the key is not retried forever
        _log("FAILED:\n" + traceback.format_exc())
        record = read_attempts(attempts_path(entry))
        message = " ".join(str(exc).split())[:300] or type(exc).__name__
        try:
            _write_attempts(attempts_path(entry), Attempts(
                label or record.label, max(record.attempts, 1), record.failures + 1, message))
        except OutputWriteError:
            pass
        return 1
    finally:
        for path in (Path(job["input"]), job_file):
            path.unlink(missing_ok=True)
    clear_attempts(entry)
    me = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    _log(f"done: {entry.library.name} in {time.perf_counter() - t_wall:.1f} s wall; this "
         f"process {me.ru_utime + me.ru_stime:.1f} s CPU (peak RSS {me.ru_maxrss / 1024:.0f} "
         f"MB), the compiler {children.ru_utime + children.ru_stime:.1f} s CPU (peak RSS "
         f"{children.ru_maxrss / 1024:.0f} MB)")
    os.close(lock_fd)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
