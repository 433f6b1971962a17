"""`WireRecorder`: what a `VirtualServoBus` received on the wire, decoded independently.

It taps the bus's `process` (the byte entry point every transport uses), runs its own stream
parser over the host's bytes, and records every goal-position write (sync-write or write) and
every torque-enable write with the bus-clock time. Tests use it to check safety properties from
the wire rather than from the player's own bookkeeping.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hardware.bus.control_table import table_for_protocol
from hardware.bus.protocol import dynamixel2 as dxl
from hardware.bus.protocol import feetech as ft
from hardware.bus.protocol.common import SYNC_WRITE, WRITE, Packet
from hardware.bus.virtual.bus import VirtualServoBus


@dataclass(frozen=True)
class WireWrite:
    """One decoded write: bus-clock time [s], register name, {servo id: value}."""

    t_s: float
    register: str
    values: dict[int, int]


class WireRecorder:
    """Records the goal-position and torque-enable writes a virtual bus receives."""

    def __init__(self, vbus: VirtualServoBus) -> None:
        self.vbus = vbus
        self.table = table_for_protocol(vbus.protocol)
        self._dxl = vbus.protocol == "dynamixel2"
        self._parser: dxl.StreamParser | ft.StreamParser = (
            dxl.StreamParser() if self._dxl else ft.StreamParser("instruction")
        )
        self.writes: list[WireWrite] = []
        self.packets = 0
        inner = vbus.process

        def process(data: bytes, now_wall_s: float | None = None) -> list[tuple[float, bytes]]:
            self._feed(bytes(data), vbus.clock())
            return inner(data, now_wall_s)

        vbus.process = process  # type: ignore[method-assign]

    def _feed(self, data: bytes, t_s: float) -> None:
        for p in self._parser.feed(data):
            self.packets += 1
            for name in ("goal_position", "torque_enable"):
                values = self._decode(p, name)
                if values:
                    self.writes.append(WireWrite(t_s, name, values))

    def _decode(self, p: Packet, name: str) -> dict[int, int]:
        reg = self.table[name]
        prm = p.params
        if p.instruction == SYNC_WRITE:
            head = 4 if self._dxl else 2
            if len(prm) < head:
                return {}
            addr = prm[0] | (prm[1] << 8) if self._dxl else prm[0]
            size = prm[2] | (prm[3] << 8) if self._dxl else prm[1]
            if addr != reg.addr or size < reg.size:
                return {}
            out = {}
            for off in range(head, len(prm) - size + 1, size + 1):
                out[prm[off]] = reg.decode(prm[off + 1 : off + 1 + reg.size])
            return out
        if p.instruction == WRITE:
            head = 2 if self._dxl else 1
            addr = prm[0] | (prm[1] << 8) if self._dxl else prm[0]
            data = prm[head:]
            if addr <= reg.addr and reg.addr + reg.size <= addr + len(data):
                at = reg.addr - addr
                return {p.servo_id: reg.decode(data[at : at + reg.size])}
        return {}

    def goal_frames(self) -> list[WireWrite]:
        return [w for w in self.writes if w.register == "goal_position"]

    def goal_matrix(self, ids: list[int]) -> np.ndarray:
        """(K, len(ids)) goal ticks of the sync-writes that addressed all of `ids`."""
        rows = [[w.values[i] for i in ids] for w in self.goal_frames() if set(ids) <= set(w.values)]
        return np.asarray(rows, dtype=float).reshape(-1, len(ids))

    def torque_writes(self) -> list[WireWrite]:
        return [w for w in self.writes if w.register == "torque_enable"]
