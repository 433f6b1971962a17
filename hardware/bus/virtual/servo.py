"""One emulated servo: a control-table memory image plus a simple, deterministic motion model.

Motion: with torque enabled the present position moves toward the goal at the servo's no-load
speed (catalogue `no_load_speed_rad_s` · `ticks_per_rad` [ticks/s]), evaluated lazily from the
injected bus clock — the same clock readings always give the same positions.
Load: 20 % in the direction of motion while moving, plus `external_load_pct`; ±100 % under an
injected overload. Voltage: catalogue nominal minus the plan's sag. Temperature: `ambient_c`, plus
what an injected heating rate has added while torque was on (overheating reported past the
catalogue limit), or above the catalogue limit under an injected overheat.

Families: Dynamixel X (Protocol 2.0: errors latch in Hardware Error Status until reboot),
Dynamixel AX/MX on Protocol 1.0 (no error register: the health bits go in every status packet's
error byte while the condition lasts; Shutdown bits turn the torque off; a goal outside the angle
limits is clamped and answered with the angle-limit bit), Feetech STS.
"""

from __future__ import annotations

import math

from hardware.bus.control_table import DYNAMIXEL_AX, DYNAMIXEL_X, ControlTable, Register
from hardware.bus.virtual.faults import FaultPlan
from robots.servo import ServoModel

# Dynamixel X Shutdown (addr 63) default 0x34: overheating | electrical shock | overload.
DXL_SHUTDOWN_DEFAULT = 0x34
DXL_FIRMWARE = 46
DXL_RETURN_DELAY_DEFAULT = 250  # X-series Return Delay Time: 250 × 2 µs = 500 µs
# AX-12A factory values (e-Manual control table): Shutdown / Alarm LED 36 = overheating |
# overload, Return Delay Time 250 (500 µs), Status Return Level 2, firmware version 24.
DXL1_SHUTDOWN_DEFAULT = 0x24
DXL1_RETURN_DELAY_DEFAULT = 250
DXL1_FIRMWARE = 24
DXL1_ANGLE_LIMIT = 0x02  # Protocol 1.0 status error bits
DXL1_RANGE = 0x08
FEETECH_FIRMWARE = (3, 10)
MOVING_LOAD_PCT = 20.0
ERR_ACCESS = 7  # Dynamixel status error number "access error"
ERR_DATA_LIMIT = 6


class VirtualServo:
    """A servo's memory image; `read`/`write` act on raw bytes like the real firmware."""

    def __init__(
        self,
        servo_id: int,
        model: ServoModel,
        table: ControlTable,
        now_s: float,
        position_tick: int | None = None,
        ambient_c: float = 30.0,
    ) -> None:
        self.model = model
        self.table = table
        self.is_dynamixel = table is DYNAMIXEL_X
        self.is_protocol1 = table is DYNAMIXEL_AX
        self._health = 0  # Protocol 1.0: health bits of the status error byte (no register)
        self.mem = bytearray(table.size)
        self.ambient_c = ambient_c
        self.external_load_pct = 0.0
        mid = (model.position_min_tick + model.position_max_tick + 1) // 2
        self._pos = float(mid if position_tick is None else position_tick)
        self._goal = round(self._pos)
        self._t = now_s
        self._latched_error = 0
        self._heat_k = 0.0  # temperature added by an injected heating rate [K]
        self._driven: tuple[float, float] | None = None  # (ticks, ticks/s) imposed by a plant
        self._readonly = [r for r in table.registers.values() if not r.writable]
        self._factory_defaults(servo_id)

    # -- register helpers --------------------------------------------------------------------
    def get(self, name: str) -> int:
        reg = self.table[name]
        return reg.decode(bytes(self.mem[reg.addr : reg.addr + reg.size]))

    def _set(self, name: str, value: int) -> None:
        reg = self.table[name]
        self.mem[reg.addr : reg.addr + reg.size] = reg.encode(value)

    @property
    def servo_id(self) -> int:
        return self.get("id")

    @property
    def return_delay_s(self) -> float:
        """The servo's Return Delay Time [s]: how long it waits before answering."""
        reg = self.table["return_delay"]
        return self.get("return_delay") * reg.unit * 1e-6

    @property
    def torque_enabled(self) -> bool:
        return self.get("torque_enable") != 0

    @property
    def position_tick(self) -> float:
        return self._pos

    @property
    def goal_tick(self) -> int:
        """The goal position the servo is acting on [ticks] (after its own limit handling)."""
        return self._goal

    def drive(self, position_tick: float, velocity_ticks_s: float = 0.0) -> None:
        """Impose the present position [ticks] and speed [ticks/s] from an external plant (e.g.
        the MuJoCo twin `sim.twin`, via `VirtualServoBus.plant`); from then on the built-in
        motion model is bypassed and `update` only refreshes the registers."""
        self._driven = (float(position_tick), float(velocity_ticks_s))

    def _factory_defaults(self, servo_id: int, keep_baud: int | None = None) -> None:
        self.mem[:] = bytes(self.table.size)
        self._set("model_number", self.model.model_number)
        self._set("id", servo_id)
        self._set("min_position_limit", self.model.position_min_tick)
        self._set("max_position_limit", self.model.position_max_tick)
        if self.is_dynamixel:
            self._set("firmware", DXL_FIRMWARE)
            self._set("baud_rate", 1 if keep_baud is None else keep_baud)  # 1 = 57600 bps
            self._set("operating_mode", 3)  # position control
            self._set("temperature_limit", int(self.model.max_temperature_c))
            self._set("max_voltage_limit", round(self.model.voltage_max_v * 10))
            self._set("min_voltage_limit", round(self.model.voltage_min_v * 10))
            self._set("shutdown", DXL_SHUTDOWN_DEFAULT)
            self._set("return_delay", DXL_RETURN_DELAY_DEFAULT)
        elif self.is_protocol1:
            self._set("firmware", DXL1_FIRMWARE)
            self._set("baud_rate", 1 if keep_baud is None else keep_baud)  # 1 = 1 Mbps
            self._set("return_delay", DXL1_RETURN_DELAY_DEFAULT)
            self._set("temperature_limit", int(self.model.max_temperature_c))
            self._set("max_voltage_limit", round(self.model.voltage_max_v * 10))
            self._set("min_voltage_limit", round(self.model.voltage_min_v * 10))
            self._set("max_torque", 1023)
            self._set("status_return_level", 2)
            self._set("alarm_led", DXL1_SHUTDOWN_DEFAULT)
            self._set("shutdown", DXL1_SHUTDOWN_DEFAULT)
            self._set("torque_limit", 1023)
        else:
            self._set("firmware_major", FEETECH_FIRMWARE[0])
            self._set("firmware_minor", FEETECH_FIRMWARE[1])
            self._set("baud_rate", 0 if keep_baud is None else keep_baud)  # 0 = 1 Mbps
            self._set("max_temperature_limit", int(self.model.max_temperature_c))
            self._set("max_voltage_limit", round(self.model.voltage_max_v * 10))
            self._set("min_voltage_limit", round(self.model.voltage_min_v * 10))
        self._goal = round(self._pos)
        self._set("goal_position", self._goal)
        self._latched_error = 0

    # -- physics ------------------------------------------------------------------------------
    def update(self, now_s: float, faults: FaultPlan) -> None:
        """Advance the motion model to `now_s` and refresh the present-value registers."""
        dt = max(0.0, now_s - self._t)
        self._t = max(self._t, now_s)
        velocity = 0.0
        if self._driven is not None:
            self._pos, velocity = self._driven
            velocity = velocity if abs(velocity) > 1.0 else 0.0  # below 1 tick/s: at rest
        elif self.torque_enabled:
            speed = self.model.no_load_speed_rad_s * self.model.ticks_per_rad  # ticks/s
            err = self._goal - self._pos
            step = min(abs(err), speed * dt)
            self._pos += math.copysign(step, err)
            if abs(self._goal - self._pos) > 0.5 and dt > 0:
                velocity = math.copysign(speed, err)
        moving = velocity != 0.0
        sid = self.servo_id
        load = self.external_load_pct + (math.copysign(MOVING_LOAD_PCT, velocity) if moving else 0)
        if sid in faults.overload:
            load = math.copysign(100.0, load or 1.0)
        volts = self.model.nominal_voltage_v - faults.voltage_sag_v
        if self.torque_enabled:
            self._heat_k += faults.heating_k_per_s.get(sid, 0.0) * dt
        temp = self.ambient_c + self._heat_k
        hot = sid in faults.overheat or temp > self.model.max_temperature_c
        if sid in faults.overheat:
            temp = self.model.max_temperature_c + 5.0
        bits = self.table.hardware_error_bits
        inv = {name: bit for bit, name in bits.items()}
        error = 0
        dxl = self.is_dynamixel or self.is_protocol1
        if sid in faults.voltage_error or volts < self.model.voltage_min_v:
            error |= inv["input_voltage" if dxl else "voltage"]
        if hot:
            error |= inv["overheating" if dxl else "overheat"]
        if sid in faults.overload:
            error |= inv["overload"]
        if self.is_dynamixel:  # X-series latch hardware errors until reboot; shutdown = torque off
            self._latched_error |= error
            error = self._latched_error
            if error & self.get("shutdown") and self.torque_enabled:
                self._set("torque_enable", 0)
        if self.is_protocol1:  # no latch: the bits last as long as the condition
            self._health = error
            if error & self.get("shutdown") and self.torque_enabled:
                self._set("torque_enable", 0)
        self._set("present_position", round(self._pos))
        self._set("present_load", _clamp_int(load * 10, 1000))
        self._set("present_voltage", max(0, round(volts * 10)))
        self._set("present_temperature", max(0, round(temp)))
        self._set("present_velocity", _velocity_raw(self.table, velocity, self.model.ticks_per_rev))
        self._set("moving", 1 if moving else 0)
        if not self.is_protocol1:
            self._set("hardware_error", error)

    # -- firmware behaviour ---------------------------------------------------------------------
    def status_error(self) -> int:
        """The error/status byte this servo puts in its status packets."""
        if self.is_protocol1:
            return self._health
        hw = self.get("hardware_error")
        if self.is_dynamixel:
            return 0x80 if hw else 0
        return hw

    def read(self, addr: int, length: int) -> bytes | None:
        """Bytes at [addr, addr+length), or None when outside the table."""
        if addr < 0 or length < 0 or addr + length > self.table.size:
            return None
        return bytes(self.mem[addr : addr + length])

    def write(self, addr: int, data: bytes) -> int:
        """Apply a write; returns a Dynamixel 2.0 error number or Protocol 1.0 error bits
        (0 = done)."""
        end = addr + len(data)
        refused = DXL1_RANGE if self.is_protocol1 else ERR_ACCESS
        if addr < 0 or end > self.table.size:
            return refused
        if any(r.addr < end and addr < r.addr + r.size for r in self._readonly):
            return refused
        if addr < self.table.ram_start and self.torque_enabled and not self.is_protocol1:
            return ERR_ACCESS  # X-series: EEPROM is locked while torque is on
        answer = 0
        new = bytearray(self.mem)
        new[addr:end] = data
        goal_reg = self.table["goal_position"]
        if addr < goal_reg.addr + goal_reg.size and goal_reg.addr < end:
            goal = goal_reg.decode(bytes(new[goal_reg.addr : goal_reg.addr + goal_reg.size]))
            lo, hi = self.get("min_position_limit"), self.get("max_position_limit")
            if not lo <= goal <= hi:
                if self.is_dynamixel:
                    return ERR_DATA_LIMIT
                if self.is_protocol1:
                    answer = DXL1_ANGLE_LIMIT  # AX/MX: clamped, and the status says so
                goal = min(max(goal, lo), hi)  # Feetech clamps to its angle limits
                new[goal_reg.addr : goal_reg.addr + goal_reg.size] = goal_reg.encode(goal)
            self._goal = goal
        torque = self.table["torque_enable"]
        if addr <= torque.addr < end and new[torque.addr] and not self.torque_enabled:
            if self.is_dynamixel and self._latched_error & self.get("shutdown"):
                return ERR_ACCESS  # a shut-down X-series servo refuses torque until reboot
            if not addr <= goal_reg.addr < end:  # torque on holds the present position
                self._goal = round(self._pos)
                new[goal_reg.addr : goal_reg.addr + goal_reg.size] = goal_reg.encode(self._goal)
        self.mem[:] = new
        return answer

    def reboot(self, faults: FaultPlan, now_s: float) -> None:
        """Dynamixel reboot: RAM back to defaults (torque off), latched errors cleared."""
        self._set("torque_enable", 0)
        self._latched_error = 0
        self.update(now_s, faults)

    def factory_reset(self, option: int) -> None:
        """Dynamixel factory reset: 0xFF all, 0x01 all but ID, 0x02 all but ID and baud."""
        sid, baud = self.servo_id, self.get("baud_rate")
        self._factory_defaults(1 if option == 0xFF else sid, baud if option == 0x02 else None)


def _clamp_int(value: float, limit: int) -> int:
    return int(max(-limit, min(limit, round(value))))


def _velocity_raw(table: ControlTable, ticks_per_s: float, ticks_per_rev: float) -> int:
    reg: Register = table["present_velocity"]
    if table is DYNAMIXEL_X:  # 0.229 rpm per LSB
        return _clamp_int(ticks_per_s / ticks_per_rev * 60.0 / reg.unit, 1 << 30)
    if table is DYNAMIXEL_AX:  # 0.111 rpm per LSB, magnitude below bit 10
        return _clamp_int(ticks_per_s / ticks_per_rev * 60.0 / reg.unit, 1023)
    return _clamp_int(ticks_per_s, (1 << 15) - 1)  # Feetech: steps/s
