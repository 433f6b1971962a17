"""`VirtualServoBus`: byte-level emulator of a Dynamixel 1.0 / 2.0 or Feetech STS bus.

`process(data, now_wall_s)` takes instruction bytes as written by the host (any chunking) and
returns the status packets as (release wall-time [s], bytes), in bus order, after fault
injection (drop / corrupt / delay / vanished servos / no reply to reads of given registers).
Release times never decrease: like bytes through a USB adapter, a delayed reply holds back
the replies after it instead of being overtaken.
Servo physics run on the injectable `clock` (bus time); release times are wall-clock so a
transport can honour delays.
Reach it in-process with `VirtualPort` or on a pseudo-terminal with `PtyServer`.

Wire time (`wire=WireTiming(baud, adapter_latency_s)`, off by default): replies are released
when a real half-duplex line would deliver them — the request's bytes at 10 bits per byte
(after whatever is still on the line), then per reply the servo's Return Delay Time (its
`return_delay` register) and the reply's own bytes, servo after servo; plus the USB adapter's
latency timer (an FTDI holds received bytes up to that long before the host sees them). Lets
`hardware.bus.budget`'s loop-rate estimate be checked against a player run.
"""

from __future__ import annotations

import random
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from hardware.bus.control_table import DYNAMIXEL1_BULK_READ_MODELS, table_for_protocol
from hardware.bus.protocol import dynamixel1 as dxl1
from hardware.bus.protocol import dynamixel2 as dxl
from hardware.bus.protocol import feetech as ft
from hardware.bus.protocol.common import (
    ACTION,
    BROADCAST_ID,
    FACTORY_RESET,
    PING,
    READ,
    REBOOT,
    REG_WRITE,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
    Packet,
)
from hardware.bus.servo_bus import MAX_BAUD, MAX_SERVO_ID, MIN_BAUD, bounded, bounded_int
from hardware.bus.virtual.faults import NO_FAULTS, FaultPlan
from hardware.bus.virtual.servo import VirtualServo
from robots.servo import ServoModel

if TYPE_CHECKING:
    from hardware.bus.servo_bus import BusConfig, ServoBus

ERR_INSTRUCTION = 2
ERR_DATA_LENGTH = 5
ERR_ACCESS = 7
PROTOCOLS = ("dynamixel1", "dynamixel2", "feetech_sts")


@dataclass(frozen=True)
class WireTiming:
    """Emulated line: `baud` [bit/s] (8N1, 10 bits per byte) and the USB adapter's latency
    timer `adapter_latency_s` [s] added to every reply (0: a pty / CDC-ACM adapter)."""

    baud: int
    adapter_latency_s: float = 0.0

    def __post_init__(self) -> None:
        bounded_int("wire baud", self.baud, MIN_BAUD, MAX_BAUD)
        bounded("adapter latency", self.adapter_latency_s, 0.0, 0.255, " s")

    def bytes_s(self, n: int) -> float:
        return 10.0 * n / self.baud


class ServoPlant(Protocol):
    """Drives the servos' present state from outside the bus (e.g. the MuJoCo twin, `sim.twin`).

    Called with the bus clock before every packet is served; reads each servo's goal
    (`goal_tick`, `torque_enabled`) and imposes its present state with `VirtualServo.drive`."""

    def advance(self, now_s: float, servos: Sequence[VirtualServo]) -> None: ...


class VirtualServoBus:
    """A bus of emulated servos speaking one wire protocol (one of `PROTOCOLS`)."""

    def __init__(
        self,
        servos: Mapping[int, ServoModel],
        protocol: str | None = None,
        clock: Callable[[], float] = time.monotonic,
        faults: FaultPlan = NO_FAULTS,
        wire: WireTiming | None = None,
    ) -> None:
        if not servos:
            raise ValueError("a virtual bus needs at least one servo")
        for servo_id in servos:
            bounded_int("virtual servo id", servo_id, 0, MAX_SERVO_ID)
        protocols = {m.protocol for m in servos.values()}
        protocol = protocol or (protocols.pop() if len(protocols) == 1 else "")
        if protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS} (servos speak {protocols})")
        self.protocol = protocol
        self.table = table_for_protocol(protocol)
        self.clock = clock
        self._lock = threading.RLock()
        now = clock()
        self.servos = [VirtualServo(i, m, self.table, now) for i, m in sorted(servos.items())]
        self._check_plan(faults)
        self._faults = faults
        self._rng = random.Random(faults.seed)
        self._parser: dxl.StreamParser | ft.StreamParser = (
            dxl.StreamParser() if protocol == "dynamixel2" else ft.StreamParser("instruction")
        )
        self.wire = wire
        self._wire_free = 0.0  # wall time [s] the emulated line is next idle (wire timing)
        self._registered: dict[int, tuple[int, bytes]] = {}  # Feetech REG WRITE buffer
        self.instructions = 0  # packets handled (for tests and benchmarks)
        self._last_release = 0.0  # wall time [s] of the latest reply released (FIFO order)
        self.plant: ServoPlant | None = None  # optional external physics (see ServoPlant)

    @classmethod
    def from_robot(
        cls, robot: Any, pose_rad: Sequence[float] | None = None, **kwargs: Any
    ) -> VirtualServoBus:
        """Servos at the robot's bus ids with the robot's servo models, standing at `pose_rad`
        (default: the robot's nominal stance), converted to ticks through each joint's mounting
        (zero offset, direction) — a pose the robot allows, so a player can start on it.
        Servos left mid-range (tick 2048) would sit outside many joints' limits."""
        vbus = cls({j.bus_id: j.servo for j in robot.joints}, **kwargs)
        pose = robot.nominal_stance_rad if pose_rad is None else pose_rad
        vbus.place(_pose_ticks(robot, pose))
        return vbus

    def place(self, ticks: Mapping[int, int]) -> None:
        """Re-create the named servos at rest at the given present positions [ticks] (factory
        registers, torque off, goal = present)."""
        now = self.clock()
        with self._lock:
            self.servos = [
                VirtualServo(
                    s.servo_id, s.model, s.table, now, position_tick=int(ticks[s.servo_id])
                )
                if s.servo_id in ticks
                else s
                for s in self.servos
            ]

    def unplug(self) -> None:
        """The adapter vanishes from now on (see `FaultPlan.adapter_lost_at_s`)."""
        self.faults = _replace_plan(self._faults, adapter_lost_at_s=self.clock())

    def adapter_lost(self) -> bool:
        """Whether the port has failed (`FaultPlan.adapter_lost_at_s` reached on the bus clock)."""
        return self._faults.is_adapter_lost(self.clock())

    # -- fault control (thread-safe, live) ----------------------------------------------------
    @property
    def faults(self) -> FaultPlan:
        return self._faults

    @faults.setter
    def faults(self, plan: FaultPlan) -> None:
        self._check_plan(plan)
        with self._lock:
            self._faults = plan
            self._rng = random.Random(plan.seed)

    def _check_plan(self, plan: FaultPlan) -> None:
        unknown = sorted(n for n in plan.drop_reads_of if n not in self.table.registers)
        if unknown:
            raise ValueError(
                f"drop_reads_of: no register {', '.join(map(repr, unknown))} in the "
                f"{self.protocol} control table"
            )

    def vanish(self, servo_id: int) -> None:
        """Make `servo_id` stop answering from now on."""
        plan = self._faults
        self.faults = _replace(plan, vanished=plan.vanished | {servo_id})

    def servo(self, servo_id: int) -> VirtualServo:
        for s in self.servos:
            if s.servo_id == servo_id:
                return s
        raise KeyError(f"no virtual servo with id {servo_id}")

    @property
    def ids(self) -> list[int]:
        return [s.servo_id for s in self.servos]

    # -- the wire -----------------------------------------------------------------------------
    def process(self, data: bytes, now_wall_s: float | None = None) -> list[tuple[float, bytes]]:
        """Consume host bytes; return the replies as (release wall time [s], bytes)."""
        wall = time.monotonic() if now_wall_s is None else now_wall_s
        out: list[tuple[float, bytes]] = []
        with self._lock:
            now = self.clock()
            for packet in self._parser.feed(bytes(data)):
                self.instructions += 1
                lost = self._read_lost(packet)
                line = self._line_start(packet, wall)
                for servo, reply in self._dispatch(packet, now):
                    on_wire = self._on_wire(line, servo, reply)
                    line = on_wire if on_wire is not None else line
                    if lost:
                        continue
                    injected = self._inject(servo, reply, now)
                    if injected is not None:
                        # a serial stream is FIFO: a late reply holds back the ones after it
                        due = wall if on_wire is None else on_wire + self._latency()
                        release = max(due + injected[0], self._last_release)
                        self._last_release = release
                        out.append((release, injected[1]))
        return out

    def _line_start(self, p: Packet, wall: float) -> float | None:
        """Wire timing: when the request's last byte is on the line (None: timing off)."""
        if self.wire is None:
            return None
        start = max(wall, self._wire_free)
        end = start + self.wire.bytes_s(self._request_bytes(p))
        self._wire_free = end
        return end

    def _on_wire(self, line: float | None, servo: VirtualServo, reply: bytes) -> float | None:
        """Wire timing: when `reply`'s last byte is on the line, the line free at `line`."""
        if self.wire is None or line is None:
            return None
        end = line + servo.return_delay_s + self.wire.bytes_s(len(reply))
        self._wire_free = end
        return end

    def _latency(self) -> float:
        return self.wire.adapter_latency_s if self.wire is not None else 0.0

    def _request_bytes(self, p: Packet) -> int:
        inst = p.instruction or 0
        if self.protocol == "dynamixel2":
            return len(dxl.build_packet(p.servo_id, inst, p.params))
        return 6 + len(p.params)

    def _read_lost(self, p: Packet) -> bool:
        """Whether `p` is a READ / SYNC_READ of a register in the plan's `drop_reads_of`."""
        names = self._faults.drop_reads_of
        if not names or p.instruction not in (READ, SYNC_READ, dxl1.BULK_READ):
            return False
        prm, dxl2 = p.params, self.protocol == "dynamixel2"
        if len(prm) < (4 if dxl2 else 2):
            return False
        if p.instruction == dxl1.BULK_READ and self.protocol == "dynamixel1":
            spans = [(a, n) for _, a, n in dxl1.bulk_read_items(prm)]
        else:
            spans = [(_u16(prm, 0), _u16(prm, 2)) if dxl2 else (prm[0], prm[1])]
        regs = [self.table[n] for n in names]
        return any(
            r.addr < addr + size and addr < r.addr + r.size for r in regs for addr, size in spans
        )

    def _inject(self, servo: VirtualServo, reply: bytes, now: float) -> tuple[float, bytes] | None:
        plan, rng = self._faults, self._rng
        if plan.is_vanished(servo.servo_id, now):
            return None
        if plan.drop_probability and rng.random() < plan.drop_probability:
            return None
        if plan.corrupt_probability and rng.random() < plan.corrupt_probability:
            head = 4 if self.protocol == "dynamixel2" else 2
            buf = bytearray(reply)
            i = rng.randrange(head, len(buf))
            buf[i] ^= rng.randrange(1, 256)
            reply = bytes(buf)
        delay = 0.0
        if (plan.delay_s or plan.delay_jitter_s) and rng.random() < plan.delay_probability:
            delay = plan.delay_s
            if plan.delay_jitter_s:
                delay += rng.uniform(0.0, plan.delay_jitter_s)
        if plan.noise_probability and rng.random() < plan.noise_probability:
            noise = bytes(rng.randrange(256) for _ in range(rng.randint(1, plan.noise_max_bytes)))
            reply = noise + reply
        return delay, reply

    def _targets(self, servo_id: int) -> list[VirtualServo]:
        if servo_id == BROADCAST_ID:
            return list(self.servos)
        return [s for s in self.servos if s.servo_id == servo_id]

    def _action(self, servo_id: int, bcast: bool, status: Callable[..., None]) -> None:
        """ACTION (both Feetech and Protocol 1.0): apply the REG WRITE buffered per servo; a
        servo addressed directly answers with a status packet, a broadcast gets no reply."""
        for s in self._targets(servo_id):
            pending = self._registered.pop(s.servo_id, None)
            if pending is not None:
                s.write(*pending)
            if not bcast:
                status(s)

    def _dispatch(self, p: Packet, now: float) -> list[tuple[VirtualServo, bytes]]:
        if self.plant is not None:
            self.plant.advance(now, self.servos)
        for s in self.servos:
            s.update(now, self._faults)
        if self.protocol == "dynamixel2":
            return self._dispatch_dxl(p, now)
        if self.protocol == "dynamixel1":
            return self._dispatch_dxl1(p)
        return self._dispatch_ft(p, now)

    # -- Dynamixel Protocol 1.0 (AX / MX) ----------------------------------------------------------
    def _dispatch_dxl1(self, p: Packet) -> list[tuple[VirtualServo, bytes]]:
        """PING, READ, WRITE, REG WRITE / ACTION, RESET, SYNC WRITE; BULK READ on the servos
        whose model answers it (MX, EX-106+; an AX ignores it). Status Return Level (address
        16): 0 = answer PING only, 1 = PING and READ, 2 = everything (factory)."""
        inst, prm, bcast = p.instruction, p.params, p.servo_id == BROADCAST_ID
        replies: list[tuple[VirtualServo, bytes]] = []

        def status(s: VirtualServo, err: int = 0, params: bytes = b"") -> None:
            level = s.get("status_return_level")
            if (
                inst == PING
                or (inst == READ and level >= 1)
                or level >= 2
                or err & dxl1.INSTRUCTION
            ):
                replies.append((s, dxl1.build_status(s.servo_id, err | s.status_error(), params)))

        if inst == SYNC_WRITE and bcast and len(prm) >= 2:
            addr, size = prm[0], prm[1]
            for off in range(2, len(prm) - size, size + 1):
                for s in self._targets(prm[off]):
                    s.write(addr, prm[off + 1 : off + 1 + size])
            return []
        if inst == dxl1.BULK_READ and bcast and len(prm) >= 4:
            for sid, addr, size in dxl1.bulk_read_items(prm):
                for s in self._targets(sid):
                    if s.model.model_number not in DYNAMIXEL1_BULK_READ_MODELS:
                        continue  # an AX does not know the instruction (and it was broadcast)
                    data = s.read(addr, size)
                    replies.append(
                        (
                            s,
                            dxl1.build_status(
                                s.servo_id,
                                s.status_error() | (0 if data is not None else dxl1.RANGE),
                                data or b"",
                            ),
                        )
                    )
            return replies
        if inst == ACTION:
            self._action(p.servo_id, bcast, status)
            return replies
        for s in self._targets(p.servo_id):
            if inst == PING:
                status(s)
            elif inst == READ and len(prm) == 2 and not bcast:
                data = s.read(prm[0], prm[1])
                status(s, 0 if data is not None else dxl1.RANGE, data or b"")
            elif inst == WRITE and len(prm) >= 2:
                err = s.write(prm[0], prm[1:])
                if not bcast:
                    status(s, err)
            elif inst == REG_WRITE and len(prm) >= 2:
                self._registered[s.servo_id] = (prm[0], prm[1:])
                if not bcast:
                    status(s)
            elif inst == FACTORY_RESET and not prm:
                if not bcast:
                    status(s)
                s.factory_reset(0xFF)
            elif not bcast:
                status(s, dxl1.INSTRUCTION)
        return replies

    # -- Dynamixel Protocol 2.0 -----------------------------------------------------------------
    def _dispatch_dxl(self, p: Packet, now: float) -> list[tuple[VirtualServo, bytes]]:
        inst, prm, bcast = p.instruction, p.params, p.servo_id == BROADCAST_ID
        replies: list[tuple[VirtualServo, bytes]] = []

        def status(s: VirtualServo, err: int = 0, params: bytes = b"") -> None:
            replies.append((s, dxl.build_status(s.servo_id, err | s.status_error(), params)))

        if inst == SYNC_WRITE and bcast and len(prm) >= 4:
            addr, size = _u16(prm, 0), _u16(prm, 2)
            for off in range(4, len(prm) - size, size + 1):
                for s in self._targets(prm[off]):
                    s.write(addr, prm[off + 1 : off + 1 + size])
            return []
        if inst == SYNC_READ and bcast and len(prm) >= 4:
            addr, size = _u16(prm, 0), _u16(prm, 2)
            for sid in prm[4:]:
                for s in self._targets(sid):
                    data = s.read(addr, size)
                    status(s, 0 if data is not None else ERR_ACCESS, data or b"")
            return replies
        for s in self._targets(p.servo_id):
            if inst == PING:
                status(s, 0, _le16(s.get("model_number")) + bytes((s.get("firmware"),)))
            elif inst == READ and len(prm) == 4 and not bcast:
                data = s.read(_u16(prm, 0), _u16(prm, 2))
                status(s, 0 if data is not None else ERR_ACCESS, data or b"")
            elif inst == WRITE and len(prm) >= 2:
                err = s.write(_u16(prm, 0), prm[2:])
                if not bcast:
                    status(s, err)
            elif inst == REBOOT:
                if not bcast:
                    status(s)
                s.reboot(self._faults, now)
            elif inst == FACTORY_RESET and len(prm) == 1:
                if not bcast:
                    status(s)
                s.factory_reset(prm[0])
            elif not bcast:
                status(s, ERR_INSTRUCTION)
        return replies

    # -- Feetech STS ------------------------------------------------------------------------------
    def _dispatch_ft(self, p: Packet, now: float) -> list[tuple[VirtualServo, bytes]]:
        inst, prm, bcast = p.instruction, p.params, p.servo_id == BROADCAST_ID
        replies: list[tuple[VirtualServo, bytes]] = []

        def status(s: VirtualServo, params: bytes = b"") -> None:
            replies.append((s, ft.build_status(s.servo_id, s.status_error(), params)))

        if inst == SYNC_WRITE and bcast and len(prm) >= 2:
            addr, size = prm[0], prm[1]
            for off in range(2, len(prm) - size, size + 1):
                for s in self._targets(prm[off]):
                    s.write(addr, prm[off + 1 : off + 1 + size])
            return []
        if inst == SYNC_READ and bcast and len(prm) >= 2:
            for sid in prm[2:]:
                for s in self._targets(sid):
                    data = s.read(prm[0], prm[1])
                    if data is not None:
                        status(s, data)
            return replies
        if inst == ACTION:
            self._action(p.servo_id, bcast, status)
            return replies
        for s in self._targets(p.servo_id):
            if inst == PING:
                status(s)
            elif inst == READ and len(prm) == 2 and not bcast:
                data = s.read(prm[0], prm[1])
                if data is not None:
                    status(s, data)
            elif inst == WRITE and len(prm) >= 1:
                s.write(prm[0], prm[1:])
                if not bcast:
                    status(s)
            elif inst == REG_WRITE and len(prm) >= 1:
                self._registered[s.servo_id] = (prm[0], prm[1:])
                if not bcast:
                    status(s)
        return replies

    # -- convenience -------------------------------------------------------------------------------
    def connect(self, config: BusConfig | None = None) -> ServoBus:
        """An opened driver (DynamixelBus / FeetechBus) talking to this bus in-process."""
        from hardware.bus.virtual.port import VirtualPort

        port = VirtualPort(self)
        bus: ServoBus
        if self.protocol == "dynamixel1":
            from hardware.bus.dynamixel import Dynamixel1Bus

            bus = Dynamixel1Bus(port, config)
        elif self.protocol == "dynamixel2":
            from hardware.bus.dynamixel import DynamixelBus

            bus = DynamixelBus(port, config)
        else:
            from hardware.bus.feetech import FeetechBus

            bus = FeetechBus(port, config)
        bus.open()
        return bus


def _u16(b: bytes, i: int) -> int:
    return b[i] | (b[i + 1] << 8)


def _le16(v: int) -> bytes:
    return bytes((v & 0xFF, (v >> 8) & 0xFF))


def _pose_ticks(robot: Any, pose_rad: Sequence[float]) -> dict[int, int]:
    joints = list(robot.joints)
    pose = [float(q) for q in pose_rad]
    if len(pose) != len(joints):
        raise ValueError(f"expected {len(joints)} joint angles, got {len(pose)}")
    out = {}
    for j, q in zip(joints, pose, strict=True):
        tick = round(j.angle_to_ticks(q))
        out[j.bus_id] = min(max(tick, j.servo.position_min_tick), j.servo.position_max_tick)
    return out


def _replace_plan(plan: FaultPlan, **changes: Any) -> FaultPlan:
    from dataclasses import replace

    return replace(plan, **changes)


def _replace(plan: FaultPlan, **changes: Iterable[int]) -> FaultPlan:
    from dataclasses import replace

    return replace(plan, **changes)  # type: ignore[arg-type]
