"""`PtyServer`: serve a VirtualServoBus on a pseudo-terminal so any program can open it.

A thread owns the master side of `os.openpty()`: it feeds the host's bytes to the bus and
writes the replies back when the bus releases them (honouring injected delays). The slave path
(`server.path`, e.g. /dev/pts/7) behaves like a USB-serial adapter for the unmodified SDKs'
own `PortHandler(path)`; the baud rate a client sets is accepted and ignored.

Adapter loss (`FaultPlan.adapter_lost_at_s`, `VirtualServoBus.unplug`): the server closes
both its ends of the pty, so a client's reads and writes fail with EIO as on an unplugged USB
adapter (`lost` is then set); `stop()` is still needed to join the thread.
"""

from __future__ import annotations

import bisect
import os
import select
import threading
import time
import tty
from types import TracebackType

from hardware.virtual.bus import VirtualServoBus


class PtyServer:
    """Run `bus` behind a pseudo-terminal until `stop()` (also a context manager)."""

    def __init__(self, bus: VirtualServoBus) -> None:
        self.bus = bus
        self._master = -1
        self._slave = -1
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.path = ""
        self.error: BaseException | None = None
        self.lost = False  # the emulated adapter was unplugged (FaultPlan.adapter_lost_at_s)

    def start(self) -> str:
        """Create the pty and start serving; returns the device path."""
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line discipline until a client configures it
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        self._stop.clear()
        self._thread = threading.Thread(target=self._serve, name="virtual-bus-pty", daemon=True)
        self._thread.start()
        return self.path

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1

    def __enter__(self) -> PtyServer:
        self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    def _serve(self) -> None:
        pending: list[tuple[float, int, bytes]] = []
        seq = 0
        try:
            while not self._stop.is_set():
                if self.bus.adapter_lost():
                    self._unplug()
                    return
                now = time.monotonic()
                wait = 0.05 if not pending else max(0.0, min(0.05, pending[0][0] - now))
                ready, _, _ = select.select([self._master], [], [], wait)
                if ready:
                    try:
                        data = os.read(self._master, 4096)
                    except (BlockingIOError, InterruptedError):
                        data = b""
                    except OSError:  # EIO: no client has the slave open right now
                        time.sleep(0.01)
                        data = b""
                    if data:
                        for release, reply in self.bus.process(data, time.monotonic()):
                            seq += 1
                            bisect.insort(pending, (release, seq, reply))
                now = time.monotonic()
                while pending and pending[0][0] <= now:
                    _, _, reply = pending.pop(0)
                    self._write_all(reply)
        except BaseException as exc:  # pragma: no cover - surfaced through .error
            self.error = exc

    def _unplug(self) -> None:
        self.lost = True  # before the close: the client may see EIO the instant it happens
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1

    def _write_all(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            try:
                n = os.write(self._master, view)
            except BlockingIOError:
                select.select([], [self._master], [], 0.01)
                continue
            view = view[n:]
