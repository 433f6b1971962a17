"""Defaults for a compliant stance: how close a flat-footed robot's single support is to the
limit its ankle servo can hold, and the planner/entry defaults that follow from it.

A position servo is a spring (`planner.nlp.servo_loop`): τ = kp·(goal − q). A robot standing on
one flat foot is an inverted pendulum of mass m whose centre of mass is h above the sole, held
about the stance ankle's pitch axis by that spring. A lean δ moves the centre of mass h·δ
forward, which asks the ankle for m·g·h·δ more torque, which the servo delivers only by sagging
m·g·h·δ/kp further: the quasi-static loop gain of the stance is

    λ = m·g·h / kp                                    (inverted pendulum on a torsion spring)

and a torque mismatch at the ankle is amplified A = 1/(1 − λ) times into lean (λ → 1: the
servo's stiffness equals the body's gravity "anti-stiffness", the stance is neutral; λ ≥ 1: it
cannot hold the body at all). The same spring sets the lean's natural frequency,
ω = √((kp − m·g·h)/(m·h²)) = √(g/h)·√((1 − λ)/λ), so a stance near the limit also sways slowly
and settles slowly after a disturbance such as the gait's entry (docs/results/zoo_gaits.md,
"Session 25", finding 4: humanoid20 leans back 6° in single support at λ ≈ 0.6 — ≈ 0.9 with the
knee's sag added — and stands up at 1.5× servo strength; "Session 26" for this rule).

The figure is taken at the nominal stance (`planner.stance`): m = `Robot.mass_kg`, h = the
height of the whole robot's centre of mass above the foot site, kp = the factory P gain
(`robots.servo.factory_gains`, through `planner.nlp.servo_loop.servo_loops`) of the pitch joint
nearest the sole (the ankle pitch: the joint whose axis is the world y axis at stance, lowest
of its leg's). Only flat feet carry a moment about the ankle; a point foot's stance is held by
the support polygon and the other legs, not by one servo's stiffness, so robots without flat
feet have no figure and the rule leaves them alone.

The rule (`compliant_stance_defaults`), the same for every robot:

- λ < `COMPLIANT_LOOP_GAIN` (0.5, lean amplification A < 2): nothing changes.
- λ ≥ 0.5: the entry blend lasts K = ⌈A⌉ cycles (`robots.ramp`: the gait's stride ramps up
  over K cycles, so the slow lean mode is not kicked by a full stride at once), the objective's
  body-bounce weight (W&P eq 15, `CostWeights.bounce_s2_m2`) is K times its default (a flatter
  body height: less vertical load swing for the compliant ankle and knee to turn into lean), and
  the normal-force rate is bounded at `COMPLIANT_FORCE_RATE` body weights per √(L/g)
  (`planner.nlp.force_rate`: the load builds over several knots, as a soft servo can follow).

The threshold and the scalings are physically motivated but were checked on few robots: the
built-in biped (λ ≈ 0.20) and humanoid20 (λ ≈ 0.61) sit on either side; ρ = 10 is the value
session 25 found passing on humanoid20, not a derived one. Every user flag overrides its part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.nlp.config import GRAVITY_M_S2, CostWeights
from planner.nlp.servo_loop import servo_loops
from planner.stance import stance_kinematics
from robots import Robot
from robots.gait import MAX_ENTRY_CYCLES
from robots.servo_params import ServoSetting

#: λ at and above which the stance counts as compliant (lean amplification 1/(1 − λ) ≥ 2)
COMPLIANT_LOOP_GAIN = 0.5
#: `PlannerOptions.normal_force_rate_weights_per_t0` for a compliant stance (session 25's value)
COMPLIANT_FORCE_RATE = 10.0
#: |world y component| of a joint axis that counts as a pitch axis at stance
PITCH_AXIS_COSINE = 0.9


@dataclass(frozen=True)
class StanceCompliance:
    """The single-support loop gain λ = m·g·h/kp of a flat-footed robot (module docstring)."""

    mass_kg: float
    com_height_m: float  # centre of mass above the sole, at the nominal stance
    ankle_joint: str  # the pitch joint nearest the sole whose servo holds the stance
    ankle_kp_nm_per_rad: float

    @property
    def loop_gain(self) -> float:
        """λ = m·g·h/kp (dimensionless)."""
        return self.mass_kg * GRAVITY_M_S2 * self.com_height_m / self.ankle_kp_nm_per_rad

    @property
    def lean_amplification(self) -> float:
        """A = 1/(1 − λ): how many times an ankle torque mismatch is amplified into lean
        (inf at λ ≥ 1, where the servo cannot hold the stance)."""
        lam = self.loop_gain
        return math.inf if lam >= 1.0 else 1.0 / (1.0 - lam)


@dataclass(frozen=True)
class CompliantStanceDefaults:
    """What the rule asks of the planner for one robot (None / 1: leave the default)."""

    compliance: StanceCompliance | None  # None: no flat foot
    force_rate_weights_per_t0: float | None
    bounce_s2_m2: float | None
    entry_cycles: int

    @property
    def applies(self) -> bool:
        return self.entry_cycles > 1

    def summary(self) -> str:
        c = self.compliance
        if c is None:
            return "no flat foot: no stance-compliance defaults"
        head = (f"stance loop gain m·g·h/kp = {c.loop_gain:.2f} ({c.mass_kg:.2f} kg, h "
                f"{c.com_height_m * 1000:.0f} mm, {c.ankle_joint} kp "
                f"{c.ankle_kp_nm_per_rad:.2f} N·m/rad)")
        if not self.applies:
            return f"{head} < {COMPLIANT_LOOP_GAIN:g}: no stance-compliance defaults"
        return (f"{head} ≥ {COMPLIANT_LOOP_GAIN:g}: compliant stance, entry blend "
                f"{self.entry_cycles} cycles, bounce weight {self.bounce_s2_m2:g}, force rate "
                f"{self.force_rate_weights_per_t0:g}")

    def as_metadata(self) -> dict[str, object]:
        """The gait file's record of the figure and what the rule asked for."""
        c = self.compliance
        return {
            "loop_gain": None if c is None else c.loop_gain,
            "threshold": COMPLIANT_LOOP_GAIN,
            "mass_kg": None if c is None else c.mass_kg,
            "com_height_m": None if c is None else c.com_height_m,
            "ankle_joint": None if c is None else c.ankle_joint,
            "ankle_kp_nm_per_rad": None if c is None else c.ankle_kp_nm_per_rad,
            "applies": self.applies,
            "entry_cycles": self.entry_cycles,
            "bounce_s2_m2": self.bounce_s2_m2,
            "normal_force_rate_weights_per_t0": self.force_rate_weights_per_t0,
        }


def stance_compliance(robot: Robot, settings: tuple[ServoSetting, ...] | None = None
                      ) -> StanceCompliance | None:
    """λ's ingredients for `robot` at its nominal stance; None if no leg has a flat foot.
    With several flat feet the most compliant one (highest λ) is taken. `settings`: identified
    servos (`robots.servo_params`), else the factory gains."""
    flat = [leg for leg in robot.legs if leg.is_flat]
    if not flat:
        return None
    kin = stance_kinematics(robot)
    model, data = kin.model, kin.data
    mass = np.asarray(model.body_mass)[1:]  # every body but the world
    com_z = float(mass @ np.asarray(data.xipos)[1:, 2] / mass.sum())
    kp = {j.name: loop.kp_nm_per_rad
          for j, loop in zip(robot.joints, servo_loops(robot, settings), strict=True)}
    jid = dict(zip((j.name for j in robot.joints), kin.joint_ids, strict=True))
    best: StanceCompliance | None = None
    for leg in flat:
        site = model.site(leg.foot_site).id
        sole_z = float(data.site_xpos[site][2])
        pitch = [n for n in leg.joints
                 if abs(float(np.asarray(data.xaxis[jid[n]])[1])) >= PITCH_AXIS_COSINE]
        if not pitch:
            continue
        ankle = min(pitch, key=lambda n: float(data.xanchor[jid[n]][2]))
        c = StanceCompliance(robot.mass_kg, com_z - sole_z, ankle, kp[ankle])
        if best is None or c.loop_gain > best.loop_gain:
            best = c
    return best


def defaults_for_compliance(compliance: StanceCompliance | None) -> CompliantStanceDefaults:
    """The rule (module docstring) on a computed figure."""
    if compliance is None or compliance.loop_gain < COMPLIANT_LOOP_GAIN:
        return CompliantStanceDefaults(compliance, None, None, 1)
    amp = compliance.lean_amplification
    k = MAX_ENTRY_CYCLES if not math.isfinite(amp) else min(MAX_ENTRY_CYCLES,
                                                            math.ceil(amp - 1e-9))
    return CompliantStanceDefaults(compliance, COMPLIANT_FORCE_RATE,
                                   k * CostWeights().bounce_s2_m2, k)


def compliant_stance_defaults(robot: Robot, settings: tuple[ServoSetting, ...] | None = None
                              ) -> CompliantStanceDefaults:
    """The planner and entry defaults `robot`'s stance compliance asks for (module docstring)."""
    return defaults_for_compliance(stance_compliance(robot, settings))
