"""Servo actuator model: what a hobby/smart servo does with a goal position.

Model (one joint; a brushed DC motor behind a gearbox, driven by an H-bridge at PWM duty u):

    u    = clip(g_p·(q* − q) − g_d·q̇, −1, 1)                 position loop → duty cycle
    τ    = s·τ_stall·u − s·(τ_stall/ω₀)·q̇                      DC motor at the output shaft

with τ_stall, ω₀ the catalogue's stall torque and no-load speed (`robots/servos.toml`), s the
strength scale (1 = datasheet). At full duty τ = τ_stall·(1 − q̇/ω₀): the motoring side of the
servo's torque–speed line, exactly the planner's envelope |τ| ≤ τ_stall·(1 − |q̇|/ω₀).

Regenerative side (our documented choice): we keep the DC-motor physics, i.e. the envelope is the
point-symmetric band −τ_stall − b·q̇ ≤ τ ≤ τ_stall − b·q̇ (b = τ_stall/ω₀). When the load drives the
joint against the servo (τ·q̇ < 0, braking) the back-EMF adds to the drive and the servo can hold
up to τ_stall·(1 + |q̇|/ω₀), as a PWM-driven DC motor does ("plugging"). Neither Dynamixel X
(without current control) nor Feetech STS firmware limits current below that. Validation still
reports |τ| against τ_stall, so a gait that leans on the braking surplus shows up in the metrics.

In MuJoCo this is native and fast: a `position` actuator (kp = s·g_p·τ_stall, kv = s·g_d·τ_stall)
with forcerange ±s·τ_stall gives the clipped drive, and the back-EMF −b·q̇ is added to the joint's
damping (integrated implicitly). The armature (reflected rotor inertia) and gearbox damping are
already in the robot's MJCF.

Where the gains come from (duty per radian of error, `duty_per_rad`):

- Dynamixel X (Protocol 2.0): e-Manual "Position PID Gain": K_P = KPP(TBL)/128, default
  Position P Gain 800 (XL430-W250), output in PWM units with 885 = 100 % duty; error in encoder
  ticks. So g_p = 800/128 · ticks_per_rad / 885 ≈ 4.60 /rad for 4096 ticks/rev (full duty at
  12.4° of error); D gain default 0. XL430: kp ≈ 6.4 N·m/rad.
- Dynamixel Protocol 1.0 (AX-12A): compliance slope default 32 — torque rises from 0 to full over
  32 ticks of error: g_p = ticks_per_rad / 32 ≈ 6.1 /rad.
- Feetech STS: P coefficient default 32 (register 21); Duclusaud & Passault, "Extended friction
  models for the physics simulation of servo actuators" (2025, BAM, Rhoban), measured on an
  STS3215 with an oscilloscope: duty = 0.166 · P · error[rad] → g_p = 5.31 /rad (full duty at
  10.8°); their identified model uses no D term, so g_d = 0. STS3215 @7.4 V: kp ≈ 10.2 N·m/rad.

Targets reach the servo as the player streams them: one sample per tick at `rate_hz` (default
100 Hz), held between ticks (zero-order hold), each arriving `latency_s` after it was sent (bus
transfer + servo firmware); see `held_targets`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from robots.errors import RobotConfigError
from robots.servo import ServoModel, factory_gains
from sim.errors import SimConfigError, SimSetupError

DEFAULT_RATE_HZ = 100.0


@dataclass(frozen=True)
class ServoParams:
    """One servo at one joint (see the module docstring for the law and the gains' origin)."""

    name: str
    stall_torque_nm: float
    no_load_speed_rad_s: float
    duty_per_rad: float
    duty_s_per_rad: float = 0.0
    strength: float = 1.0
    latency_s: float = 0.0  # this servo's own goal delay, on top of the stream's (identified)

    def __post_init__(self) -> None:
        for key in ("stall_torque_nm", "no_load_speed_rad_s", "duty_per_rad", "strength"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0):
                raise SimConfigError(f"servo {self.name}: {key} must be positive, got {v!r}")
        if not (math.isfinite(self.duty_s_per_rad) and self.duty_s_per_rad >= 0):
            raise SimConfigError(f"servo {self.name}: duty_s_per_rad must be ≥ 0")
        if not (math.isfinite(self.latency_s) and 0.0 <= self.latency_s <= 1.0):
            raise SimConfigError(f"servo {self.name}: latency_s must lie in [0, 1] s")

    @property
    def drive_limit_nm(self) -> float:
        """Torque at full duty and standstill: s·τ_stall."""
        return self.strength * self.stall_torque_nm

    @property
    def kp_nm_per_rad(self) -> float:
        return self.drive_limit_nm * self.duty_per_rad

    @property
    def kd_nm_s_per_rad(self) -> float:
        return self.drive_limit_nm * self.duty_s_per_rad

    @property
    def back_emf_nm_s_per_rad(self) -> float:
        """Electrical damping b = s·τ_stall/ω₀ (slope of the torque–speed line)."""
        return self.drive_limit_nm / self.no_load_speed_rad_s

    @property
    def saturation_error_rad(self) -> float:
        """Position error at which the loop reaches full duty."""
        return 1.0 / self.duty_per_rad

    def with_strength(self, strength: float) -> ServoParams:
        return replace(self, strength=float(strength))

    def drive_nm(self, target_rad: ArrayLike, q_rad: ArrayLike, qd_rad_s: ArrayLike) -> np.ndarray:
        """The clipped position-loop part s·τ_stall·u (what MuJoCo's actuator force reports)."""
        raw = self.kp_nm_per_rad * (
            np.asarray(target_rad) - q_rad
        ) - self.kd_nm_s_per_rad * np.asarray(qd_rad_s)
        return np.clip(raw, -self.drive_limit_nm, self.drive_limit_nm)

    def torque_nm(self, target_rad: ArrayLike, q_rad: ArrayLike, qd_rad_s: ArrayLike) -> np.ndarray:
        """Servo output torque: clipped drive minus back-EMF."""
        return self.drive_nm(target_rad, q_rad, qd_rad_s) - self.back_emf_nm_s_per_rad * np.asarray(
            qd_rad_s
        )

    def envelope_nm(self, qd_rad_s: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(lowest, highest) output torque the servo can produce at joint speed `qd_rad_s`."""
        qd = np.asarray(qd_rad_s, dtype=float)
        emf = self.back_emf_nm_s_per_rad * qd
        return -self.drive_limit_nm - emf, self.drive_limit_nm - emf


def default_gains(servo: ServoModel) -> tuple[float, float]:
    """(duty_per_rad, duty_s_per_rad) of the servo's factory position loop (`robots.servo`)."""
    try:
        return factory_gains(servo)
    except RobotConfigError as exc:
        raise SimSetupError(f"servo {servo.name}: {exc.problem}") from None


def servo_params(
    servo: ServoModel, *, strength: float = 1.0, gain_scale: float = 1.0, latency_s: float = 0.0
) -> ServoParams:
    """ServoParams for a catalogue servo at its factory gains (`gain_scale` multiplies both;
    `robots.servo_params` holds identified gain scales, strengths and latencies)."""
    duty_p, duty_d = default_gains(servo)
    return ServoParams(
        name=servo.name,
        stall_torque_nm=servo.stall_torque_nm,
        no_load_speed_rad_s=servo.no_load_speed_rad_s,
        duty_per_rad=duty_p * gain_scale,
        duty_s_per_rad=duty_d * gain_scale,
        strength=strength,
        latency_s=latency_s,
    )


def held_targets(
    stream_rad: np.ndarray,
    *,
    rate_hz: float,
    latency_s: float | np.ndarray,
    dt_s: float,
    n_steps: int,
    initial_rad: np.ndarray,
    first_step: int = 0,
) -> np.ndarray:
    """Goal position seen by the servo during each physics step (zero-order hold + delay line).

    `stream_rad` (K, J): sample k is sent at t = k/rate_hz and arrives at k/rate_hz + latency_s;
    the servo holds the newest arrived sample until the next one arrives. Before the first arrival
    it holds `initial_rad`; after the stream ends it holds the last sample. `latency_s` is one
    delay for every joint or one per joint (J,). Returns
    (n_steps, J) for physics steps `first_step … first_step + n_steps − 1` (step i covers
    [i·dt, (i+1)·dt) and uses the goal present at its start).
    """
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise SimConfigError(f"stream rate must be positive, got {rate_hz!r} Hz")
    lat = np.asarray(latency_s, dtype=float)
    if not (np.all(np.isfinite(lat)) and np.all(lat >= 0)):
        raise SimConfigError(f"latency must be ≥ 0 s, got {latency_s!r}")
    stream = np.asarray(stream_rad, dtype=float)
    t = (first_step + np.arange(n_steps)) * dt_s
    if lat.ndim == 0:
        # newest sample with k/rate + latency ≤ t (a small tolerance absorbs float rounding)
        k = np.floor((t - float(lat)) * rate_hz + 1e-6).astype(np.int64)
        out = stream[np.clip(k, 0, len(stream) - 1)]
        out[k < 0] = np.asarray(initial_rad, dtype=float)
        return out
    kj = np.floor((t[:, None] - lat[None, :]) * rate_hz + 1e-6).astype(np.int64)
    cols = np.arange(stream.shape[1])
    out = stream[np.clip(kj, 0, len(stream) - 1), cols[None, :]]
    initial = np.broadcast_to(np.asarray(initial_rad, dtype=float), out.shape)
    return np.where(kj < 0, initial, out)
