"""Half-cycle mirror symmetry: the second half of a straight gait is the first half mirrored.

A straight walk or run of a left–right symmetric body on a schedule whose feet swap with their
mirror images half a cycle later (a biped's walk and run, a quadruped's trot or pace, a
hexapod's tripod) has a mirror-symmetric optimum — but IPOPT may return an asymmetric local one:
a biped run whose left and right hip pitch differ by 17.5° of a 28° swing, or a walk whose legs'
mean hip pitch differ by 14° (docs/results/biped_sweep.md, biped_walk_robustness.md), which
then turns or limps in MuJoCo. `PlannerOptions.half_cycle_mirror` imposes the symmetry as
equality rows (Wampler & Popović 2009 §3 plan one cycle; the half-cycle mirror is the usual
bilateral-symmetry reduction of gait optimisation):

    q_j(k + N/2) = s_j · q_m(j)(k),       base (x, z, pitch)(k + N/2) = (x, z, pitch)(k),
    base (y, roll, yaw)(k + N/2) = −(y, roll, yaw)(k),      k = 0 … N/2 − 1,

with m(j) joint j's mirror image under the reflection M = diag(1, −1, 1) of the body's sagittal
plane and s_j = ±1 its sign. A hinge's rotation is an axial vector, so under M it maps to
−M·a; with a' the mirror joint's axis, s_j = a'·(−M·a) (pitch joints keep their sign, roll and
yaw joints flip it when the two legs' axes are modelled alike). Joint images are found at the
stance pose from the joints' world anchors and axes, so no left/right names are assumed. The
velocities, forces and torques are not constrained: they follow from the poses through the
dynamics rows, and the cost picks among what is left.

The rows hold only for a straight command (vy = 0, yaw rate = 0) and a schedule that is
half-cycle mirror symmetric at the planner's knots; `check_schedule` refuses anything else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import PlannerConfigError
from robots import ContactSchedule, Robot

_REFLECT = np.array([1.0, -1.0, 1.0])


@dataclass(frozen=True)
class JointMirror:
    """Joint j's mirror image `image[j]` and sign `sign[j]` (`module docstring`)."""

    image: tuple[int, ...]
    sign: tuple[float, ...]


def joint_mirror(robot: Robot) -> JointMirror:
    """Each joint's mirror image at the stance pose, or PlannerConfigError naming the joint
    that has none (the model is not left–right symmetric)."""
    from planner.stance import stance_kinematics

    stance = stance_kinematics(robot)
    ids = list(stance.joint_ids)
    anchors = np.array(stance.data.xanchor[ids], dtype=float)
    axes = np.array(stance.data.xaxis[ids], dtype=float)
    tol_m = 0.02 * robot.leg_length_m
    image: list[int] = []
    sign: list[float] = []
    for a, (anchor, axis) in enumerate(zip(anchors, axes, strict=True)):
        mirrored_anchor = anchor * _REFLECT
        mirrored_axis = -axis * _REFLECT
        found = []
        for b, (other_anchor, other_axis) in enumerate(zip(anchors, axes, strict=True)):
            align = float(np.dot(other_axis, mirrored_axis))
            if np.linalg.norm(other_anchor - mirrored_anchor) < tol_m and abs(align) > 0.99:
                found.append((b, 1.0 if align > 0 else -1.0))
        if len(found) != 1:
            raise PlannerConfigError(
                f"--mirror: joint {robot.joints[a].name} has {len(found)} mirror images under "
                "y → −y at the stance pose (need exactly one): the model is not left–right "
                "symmetric; plan without --mirror"
            )
        image.append(found[0][0])
        sign.append(found[0][1])
    for a, (b, s) in enumerate(zip(image, sign, strict=True)):
        stance_a, stance_b = robot.joints[a].stance_rad, robot.joints[b].stance_rad
        if abs(stance_a - s * stance_b) > 1e-3:
            raise PlannerConfigError(
                f"--mirror: the stance of joint {robot.joints[a].name} ({stance_a:.4f} rad) is "
                f"not the mirror of {robot.joints[b].name}'s ({stance_b:.4f} rad); make the "
                "stance symmetric in robot.toml or plan without --mirror"
            )
    return JointMirror(tuple(image), tuple(sign))


def mirror_rows(mirror: JointMirror, held: tuple[int, ...], base: Any, q: Any, n_knots: int
                ) -> tuple[Any, np.ndarray]:
    """The equality rows (module docstring) and each row's scale group: 0 for base positions
    [m], 1 for angles [rad]. Held joints (fixed at their stance) get no rows."""
    if n_knots % 2:
        raise PlannerConfigError(
            f"--mirror needs an even number of knots (half a cycle on knots), got {n_knots}"
        )
    half = n_knots // 2
    keep = [j for j in range(len(mirror.image)) if j not in held]
    rows, kinds = [], []
    base_sign = (1.0, -1.0, 1.0, -1.0, 1.0, -1.0)  # x y z roll pitch yaw
    for k in range(half):
        k2 = k + half
        for d, s in enumerate(base_sign):
            rows.append(base[d, k2] - s * base[d, k])
            kinds.append(0 if d < 3 else 1)
        for j in keep:
            rows.append(q[j, k2] - mirror.sign[j] * q[mirror.image[j], k])
            kinds.append(1)
    return ca.vertcat(*rows), np.array(kinds)


def mirror_labels(robot: Robot, n_knots: int) -> list[str]:
    """Row labels of `mirror_rows`, for reports."""
    held = {j.name for j in robot.joints if j.held}
    names = [j.name for j in robot.joints if j.name not in held]
    out = []
    for k in range(n_knots // 2):
        out += [f"base {d}@knot {k}" for d in ("x", "y", "z", "roll", "pitch", "yaw")]
        out += [f"{name}@knot {k}" for name in names]
    return out


def schedule_symmetric(schedule: ContactSchedule, foot_image: tuple[int, ...], n_knots: int
                       ) -> bool:
    """Is the contact pattern at the knots the same half a cycle later with every foot swapped
    for its mirror image `foot_image` (N even)?"""
    if n_knots % 2:
        return False
    contact = schedule.contact_matrix(n_knots)  # N × F
    shifted = np.roll(contact, -(n_knots // 2), axis=0)[:, list(foot_image)]
    return bool(np.array_equal(contact, shifted))


def check_schedule(schedule: ContactSchedule, foot_image: tuple[int, ...] | None,
                   n_knots: int, vy_m_s: float, yaw_rate_rad_s: float) -> None:
    """PlannerConfigError unless the command is straight and the schedule at the knots is the
    same after half a cycle with every foot swapped for its mirror image."""
    if vy_m_s != 0.0 or yaw_rate_rad_s != 0.0:
        raise PlannerConfigError(
            "--mirror holds for straight gaits only (vy 0, yaw rate 0); plan turns and "
            "side-steps without it"
        )
    if foot_image is None:
        raise PlannerConfigError(
            "--mirror: the stance feet are not left–right symmetric; plan without --mirror"
        )
    if not schedule_symmetric(schedule, foot_image, n_knots):
        raise PlannerConfigError(
            "--mirror: the schedule is not half-cycle mirror symmetric at "
            f"{n_knots} knots (each foot must do half a cycle later what its mirror image "
            "does); use a symmetric gait (e.g. biped_walk, biped_run, trot, pace, tripod) or "
            "plan without --mirror"
        )


def check_mirror(robot: Robot, schedule: ContactSchedule, n_knots: int, vy_m_s: float,
                 yaw_rate_rad_s: float) -> None:
    """`check_schedule` with the robot's own foot images
    (`planner.templates.mirror_permutation`)."""
    from planner.templates import mirror_permutation

    check_schedule(schedule, mirror_permutation(robot), n_knots, vy_m_s, yaw_rate_rad_s)
