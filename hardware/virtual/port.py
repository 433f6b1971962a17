"""`VirtualPort`: an in-process stand-in for the SDKs' `PortHandler`, wired to a VirtualServoBus.

It implements the attributes and methods both `dynamixel_sdk` and `scservo_sdk` packet handlers
use (is_using, openPort/closePort/clearPort, readPort/writePort, getBytesAvailable,
setPacketTimeout/setPacketTimeoutMillis/isPacketTimeout, baud-rate accessors...), so the
unmodified SDKs run against it.

Timing: the SDKs compute a reply deadline as tx_time_per_byte·n + LATENCY_TIMER·2 + 2 ms (34 ms
of USB latency allowance). Here the allowance is `latency_ms` (drivers set it from
`BusConfig.timeout_s`) and the default baud is 1 Mbps, so a missing reply costs milliseconds,
not tens of milliseconds. Replies are available as soon as the bus releases them (immediately,
or after an injected delay on the wall clock).

Adapter loss (`FaultPlan.adapter_lost_at_s`, `VirtualServoBus.unplug`): from then on every
read, write, flush and wait raises OSError EIO, like pyserial on an unplugged USB adapter.
"""

from __future__ import annotations

import bisect
import errno
import os
import time
from collections.abc import Sequence

from hardware.virtual.bus import VirtualServoBus


class VirtualPort:
    """SDK-compatible port object connected to `bus` (no serial device involved)."""

    def __init__(
        self,
        bus: VirtualServoBus,
        baudrate: int = 1_000_000,
        latency_ms: float = 10.0,
        port_name: str = "virtual",
    ) -> None:
        self.bus = bus
        self.port_name = port_name
        self.baudrate = baudrate
        self.latency_ms = latency_ms
        self.is_open = False
        self.is_using = False
        self.packet_start_time = 0.0
        self.packet_timeout = 0.0
        self.tx_time_per_byte = 0.0
        self.ser = None  # no serial object: drivers use clearPort() to discard input
        self._rx = bytearray()
        self._pending: list[tuple[float, int, bytes]] = []
        self._seq = 0
        self.bytes_written = 0
        self.bytes_read = 0
        self._set_tx_time()

    def _set_tx_time(self) -> None:
        self.tx_time_per_byte = (1000.0 / self.baudrate) * 10.0  # ms per byte (8N1)

    # -- gaitsmith extension -----------------------------------------------------------------
    def set_latency_ms(self, ms: float) -> None:
        """Reply allowance beyond the wire time [ms] used by setPacketTimeout."""
        self.latency_ms = ms

    # -- PortHandler API ----------------------------------------------------------------------
    def openPort(self) -> bool:
        self.is_open = True
        return True

    def closePort(self) -> None:
        self.is_open = False
        self._rx.clear()
        self._pending.clear()

    def clearPort(self) -> None:
        """Discard bytes already received (like reset_input_buffer); in-flight replies stay."""
        self._check_adapter()
        self._release()
        self._rx.clear()

    def setPortName(self, port_name: str) -> None:
        self.port_name = port_name

    def getPortName(self) -> str:
        return self.port_name

    def setBaudRate(self, baudrate: int) -> bool:
        if baudrate <= 0:
            return False
        self.baudrate = baudrate
        self._set_tx_time()
        return True

    def getBaudRate(self) -> int:
        return self.baudrate

    def getBytesAvailable(self) -> int:
        self._check_adapter()
        self._release()
        return len(self._rx)

    def wait_for_input(self, timeout_s: float) -> None:
        """Sleep until a reply is due or `timeout_s` passes (gaitsmith extension: lets a driver
        wait without spinning)."""
        self._check_adapter()
        if self._rx:
            return
        due = self._pending[0][0] - time.monotonic() if self._pending else timeout_s
        time.sleep(max(0.0, min(timeout_s, due)))

    def readPort(self, length: int) -> bytes:
        self._check_adapter()
        self._release()
        if not self._rx:
            if self._pending:
                time.sleep(0)  # let other threads run while an injected delay elapses
            return b""
        out = bytes(self._rx[:length])
        del self._rx[:length]
        self.bytes_read += len(out)
        return out

    def writePort(self, packet: Sequence[int] | bytes) -> int:
        self._check_adapter()
        data = bytes(packet)
        self.bytes_written += len(data)
        for release, reply in self.bus.process(data, time.monotonic()):
            self._seq += 1
            bisect.insort(self._pending, (release, self._seq, reply))
        return len(data)

    def setPacketTimeout(self, packet_length: int) -> None:
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + self.latency_ms

    def setPacketTimeoutMillis(self, msec: float) -> None:
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = msec

    def isPacketTimeout(self) -> bool:
        if self.getTimeSinceStart() > self.packet_timeout:
            self.packet_timeout = 0
            return True
        return False

    def getCurrentTime(self) -> float:
        """Wall clock [ms] (monotonic)."""
        return time.monotonic() * 1000.0

    def getTimeSinceStart(self) -> float:
        return self.getCurrentTime() - self.packet_start_time

    # -- internals ------------------------------------------------------------------------------
    def _check_adapter(self) -> None:
        if self.bus.adapter_lost():
            self._rx.clear()
            self._pending.clear()
            raise OSError(errno.EIO, os.strerror(errno.EIO))

    def _release(self) -> None:
        if not self._pending:
            return
        now = time.monotonic()
        n = 0
        for release, _, reply in self._pending:
            if release > now:
                break
            self._rx.extend(reply)
            n += 1
        if n:
            del self._pending[:n]
