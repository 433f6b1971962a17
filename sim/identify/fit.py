"""Fit each servo's position gain, goal latency and strength to an excitation record.

The record is the telemetry CSV of `gaitsmith-play identify` (`hardware.play.identify`): per
tick the goal sent, the present angle read right after it, and the phase — ``excite<g>`` (the
training part of joint group g) or ``check<g>`` (held back). For each group the joints that moved
are found from the goals (the others held their centre); the other joints' angles are taken at
their mean over the group's window, and each moving joint is simulated as a `lifted_joint`
from the group's first tick (at rest, at the measured angle) through its training part.

Per joint, θ = (ln gain_scale, latency [ms], ln strength) minimises the training residual
Σ (q_sim(t_k; θ) − q_meas(t_k))² by Levenberg–Marquardt (Marquardt 1963; Madsen, Nielsen &
Tingleff, "Methods for non-linear least squares problems", 2004, eq. 3.13 and the gain-ratio
update of §3.2) on a forward-difference Jacobian, all joints of a group and all perturbed
parameter sets in one batched simulation. It starts from the best point of a coarse grid over
latency (factory gain and strength), since the residual is not convex in the delay. Then the
same simulation, run on through the held-back ticks without reset, gives the held-back RMS.

No scipy: numpy only (the batch simulation is the cost: ≈ 0.1 s per evaluation of a group).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hardware.play.telemetry import Telemetry, read_telemetry
from robots.robot import Robot
from robots.servo_params import MAX_GAIN_SCALE, MAX_LATENCY_MS, MAX_STRENGTH, ServoSetting
from sim.errors import SimConfigError
from sim.identify.lifted_joint import GoalRecord, JointPlant, joint_plants, simulate

PHASE = re.compile(r"^(excite|check)(\d+)$")
MOVED_RAD = 1e-3  # a joint whose goal spread exceeds this in a group's window was excited
LATENCY_GRID_MS = (0.0, 5.0, 10.0, 20.0, 40.0, 80.0)
FD_STEP = np.array([1e-3, 0.05, 1e-3])  # θ units: ln, ms, ln
MAX_ITERATIONS = 40
MIN_TRAIN_SAMPLES = 50
POOR_FIT_DEG = 0.5  # held-back RMS above this: the fit is flagged
POOR_SD_FRACTION = 0.05  # a parameter's standard error above 5 % of it: flagged
LATENCY_SD_FLOOR_MS = 10.0  # latency: 5 % of at least this (a 0 ms latency is not "poor")
CONTACT_EVERY = 5  # ticks between the contact checks of the measured poses


@dataclass(frozen=True)
class JointFit:
    """The fitted servo of one joint and how well it reproduces the record."""

    name: str
    setting: ServoSetting
    kp_nm_per_rad: float
    drive_limit_nm: float
    train_rms_rad: float
    held_out_rms_rad: float
    samples: int  # training samples
    iterations: int
    sd: tuple[float, float, float] = (math.nan, math.nan, math.nan)  # see `standard_errors`
    contacts: tuple[str, ...] = ()  # "bodyA/bodyB" touching while this joint was excited

    @property
    def trusted(self) -> bool:
        """No contact during its excitation and a held-back RMS within `POOR_FIT_DEG`: the
        fitted servo may be used (`gaitsmith identify` writes only these)."""
        return not self.contacts and math.degrees(self.held_out_rms_rad) <= POOR_FIT_DEG

    @property
    def warnings(self) -> tuple[str, ...]:
        """Why this joint's fit should not be trusted (empty: no reason found)."""
        out = []
        if self.contacts:
            out.append(
                f"{self.name}: links touched during its excitation ({', '.join(self.contacts)}); "
                "the one-joint model has no contacts — record it again with a smaller "
                "--amplitude-deg"
            )
        if math.degrees(self.held_out_rms_rad) > POOR_FIT_DEG:
            out.append(
                f"{self.name}: held-back RMS {math.degrees(self.held_out_rms_rad):.2f}° — the "
                "model does not explain this joint (contact, backlash, friction, a loose link?)"
            )
        if not self.trusted:
            return tuple(out)  # its parameters mean nothing: no need to say how uncertain
        st = self.setting
        scales = (st.gain_scale, max(st.latency_ms, LATENCY_SD_FLOOR_MS), st.strength)
        for name, sd, scale in zip(("gain", "latency", "strength"), self.sd, scales, strict=True):
            if not sd <= POOR_SD_FRACTION * scale:  # NaN / inf: undetermined
                shown = f"±{100 * sd / scale:.0f} %" if math.isfinite(sd) else "undetermined"
                out.append(
                    f"{self.name}: {name} poorly determined by this record ({shown}); "
                    "excite it harder (larger --amplitude-deg) or longer (--duration-s)"
                )
        return tuple(out)

    def info(self, servo_name: str) -> dict[str, float | int | str]:
        """The informative keys of the servo-parameters file."""
        return {
            "servo": servo_name,
            "kp_nm_per_rad": self.kp_nm_per_rad,
            "drive_limit_nm": self.drive_limit_nm,
            "train_rms_deg": math.degrees(self.train_rms_rad),
            "held_out_rms_deg": math.degrees(self.held_out_rms_rad),
            "samples": self.samples,
        }


@dataclass(frozen=True, eq=False)
class GroupTrace:
    """One group's window: times, measured and simulated angles of its joints (for plots)."""

    joints: tuple[int, ...]
    t_s: np.ndarray  # (S,)
    held_out: np.ndarray  # (S,) bool: a held-back tick
    goal_rad: np.ndarray  # (n, S)
    measured_rad: np.ndarray  # (n, S)
    simulated_rad: np.ndarray  # (n, S)


@dataclass(frozen=True, eq=False)
class IdentifyResult:
    fits: tuple[JointFit, ...]
    traces: tuple[GroupTrace, ...]


def _groups(tel: Telemetry, source: str) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """{group: (training tick indices, held-back tick indices)}."""
    out: dict[int, tuple[list[int], list[int]]] = {}
    for k, phase in enumerate(tel.phase):
        m = PHASE.match(phase)
        if m:
            train, check = out.setdefault(int(m.group(2)), ([], []))
            (train if m.group(1) == "excite" else check).append(k)
    if not out:
        raise SimConfigError(
            f"{source}: no excitation ticks (phases excite<g>/check<g>); record one with "
            "`gaitsmith-play identify`"
        )
    return {g: (np.array(a, int), np.array(b, int)) for g, (a, b) in sorted(out.items())}


def _residual_rms(sim: np.ndarray, meas: np.ndarray) -> np.ndarray:
    ok = np.isfinite(meas)
    err = np.where(ok, sim - meas, 0.0)
    return np.sqrt(np.sum(err**2, axis=-1) / np.maximum(ok.sum(axis=-1), 1))


def _params(theta: np.ndarray) -> np.ndarray:
    """(…, 3) θ → (gain_scale, latency_s, strength), inside the file's bounds."""
    gain = np.clip(np.exp(theta[..., 0]), 1e-3, MAX_GAIN_SCALE)
    lat = np.clip(theta[..., 1], 0.0, MAX_LATENCY_MS) / 1000.0
    strength = np.clip(np.exp(theta[..., 2]), 1e-3, MAX_STRENGTH)
    return np.stack([gain, lat, strength], axis=-1)


class _GroupProblem:
    """The batched residuals of one group's joints over its training ticks."""

    def __init__(
        self,
        plants: list[JointPlant],
        cols: list[int],
        goals: GoalRecord,
        t0: float,
        t_s: np.ndarray,
        q0: np.ndarray,
        measured: np.ndarray,
    ) -> None:
        self.plants, self.cols, self.goals = plants, cols, goals
        self.t0, self.t_s, self.q0, self.measured = t0, t_s, q0, measured
        self.mask = np.isfinite(measured)

    def run(self, theta: np.ndarray) -> np.ndarray:
        """θ (M, n, 3) → simulated angles (M, n, S)."""
        m, n = theta.shape[:2]
        sims = simulate(
            self.plants * m, self.cols * m, self.goals, _params(theta).reshape(m * n, 3),
            self.t0, self.t_s, np.tile(self.q0, m),
        )  # fmt: skip
        return sims.reshape(m, n, -1)

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """θ (M, n, 3) → residuals (M, n, S) (zero where the read failed)."""
        return np.where(self.mask, self.run(theta) - self.measured, 0.0)


def _levenberg_marquardt(problem: _GroupProblem, theta: np.ndarray) -> tuple[np.ndarray, int]:
    """Minimise Σ r² per joint (the joints are independent; one batch per iteration)."""
    n = theta.shape[0]
    mu = np.full(n, -1.0)
    nu = np.full(n, 2.0)
    done = np.zeros(n, bool)
    iterations = 0
    while iterations < MAX_ITERATIONS:
        iterations += 1
        batch = np.repeat(theta[None], 4, axis=0)
        for i in range(3):
            batch[i + 1, :, i] += FD_STEP[i]
        r = problem.residuals(batch)
        r0 = r[0]
        jac = np.stack([(r[i + 1] - r0) / FD_STEP[i] for i in range(3)], axis=-1)  # (n, S, 3)
        a = np.einsum("nsi,nsj->nij", jac, jac)
        g = np.einsum("nsi,ns->ni", jac, r0)
        if np.all(mu < 0):
            mu = 1e-3 * np.max(np.diagonal(a, axis1=1, axis2=2), axis=1)
        step = np.linalg.solve(a + mu[:, None, None] * np.eye(3), -g[..., None])[..., 0]
        step[done] = 0.0
        trial = theta + step
        r1 = problem.residuals(trial[None])[0]
        f0, f1 = np.sum(r0**2, axis=1), np.sum(r1**2, axis=1)
        predicted = np.einsum("ni,ni->n", step, mu[:, None] * step - g)  # 2·(L(0) − L(h))/1
        rho = (f0 - f1) / np.maximum(predicted, 1e-30)
        better = (rho > 0) & ~done
        theta = np.where(better[:, None], trial, theta)
        mu = np.where(better, mu * np.maximum(1 / 3, 1 - (2 * rho - 1) ** 3), mu * nu)
        nu = np.where(better, 2.0, nu * 2.0)
        small = np.linalg.norm(step / FD_STEP, axis=1) < 0.05
        done |= (better & small) | (np.max(np.abs(g), axis=1) < 1e-12) | (nu > 1e6)
        if np.all(done):
            break
    return theta, iterations


def standard_errors(problem: _GroupProblem, theta: np.ndarray) -> np.ndarray:
    """(n, 3) standard errors of θ (ln gain, latency [ms], ln strength) per joint from the
    Gauss–Newton covariance σ²·(JᵀJ)⁻¹, σ² = Σr²/(S − 3) (Madsen et al. 2004, §3.6). They
    reflect the measurement noise and how well the record determines each parameter (a
    parameter the motion hardly depends on gets a large one), not model error."""
    batch = np.repeat(theta[None], 4, axis=0)
    for i in range(3):
        batch[i + 1, :, i] += FD_STEP[i]
    r = problem.residuals(batch)
    jac = np.stack([(r[i + 1] - r[0]) / FD_STEP[i] for i in range(3)], axis=-1)
    count = problem.mask.sum(axis=1)
    sigma2 = np.sum(r[0] ** 2, axis=1) / np.maximum(count - 3, 1)
    out = np.full(theta.shape, math.inf)
    for n in range(theta.shape[0]):
        a = jac[n].T @ jac[n]
        if np.linalg.cond(a) < 1e14:
            out[n] = np.sqrt(np.maximum(np.diag(np.linalg.inv(a)) * sigma2[n], 0.0))
    return out


def contacts_beyond_joints(
    robot: Robot, cols: list[int], poses_rad: np.ndarray
) -> list[tuple[str, ...]]:
    """Per moving joint, the body pairs in contact at any of the measured poses (lifted model)
    where one body is beyond that joint."""
    import mujoco

    from sim.model import SimConditions, build_sim_model

    sim = build_sim_model(robot, SimConditions(lifted=True))
    model, data = sim.model, mujoco.MjData(sim.model)
    beyond = []
    for j in cols:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, robot.joints[j].name)
        top = int(model.jnt_bodyid[jid])
        below = set()
        for b in range(model.nbody):
            x = b
            while x > 0 and x != top:
                x = int(model.body_parentid[x])
            if x == top:
                below.add(b)
        beyond.append(below)
    found: list[set[str]] = [set() for _ in cols]
    for pose in poses_rad:
        if not np.all(np.isfinite(pose)):
            continue
        data.qpos[sim.qpos_adr] = pose
        mujoco.mj_forward(model, data)
        for c in data.contact[: data.ncon]:
            b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
            names = [
                mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or str(b) for b in (b1, b2)
            ]
            for n, below in enumerate(beyond):
                if (b1 in below) != (b2 in below):  # one side moves with the joint
                    found[n].add("/".join(sorted(names)))
    return [tuple(sorted(f)) for f in found]


def identify(telemetry_path: str | Path, robot: Robot) -> IdentifyResult:
    """Fit every excited joint of the record (see the module docstring)."""
    source = str(telemetry_path)
    try:
        tel = read_telemetry(telemetry_path)
    except OSError as exc:
        raise SimConfigError(f"{source}: cannot read it: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise SimConfigError(str(exc)) from None
    if tel.joint_names != robot.joint_names:
        raise SimConfigError(
            f"{source}: recorded joints {', '.join(tel.joint_names)} are not robot "
            f"{robot.name}'s ({', '.join(robot.joint_names)}); give the robot it was recorded on"
        )
    t_all, goal_all = tel.t_actual_s, tel.target_rad
    if not (np.all(np.isfinite(t_all)) and np.all(np.diff(t_all) > 0)):
        raise SimConfigError(f"{source}: t_actual_s is not finite and increasing")
    goals = GoalRecord(t_all, goal_all)
    fits: list[JointFit] = []
    traces: list[GroupTrace] = []
    for train, check in _groups(tel, source).values():
        window = np.concatenate([train, check])
        moved = np.ptp(goal_all[window], axis=0) > MOVED_RAD
        cols = [int(j) for j in np.flatnonzero(moved)]
        if not cols or len(train) < MIN_TRAIN_SAMPLES:
            continue
        held = np.nanmean(tel.present_rad[window], axis=0)
        plants = joint_plants(robot, cols, held)
        start = int(window[0])
        q0 = tel.present_rad[start, cols]
        if not np.all(np.isfinite(q0)):
            q0 = np.where(np.isfinite(q0), q0, goal_all[start, cols])
        t0 = float(t_all[start])
        problem = _GroupProblem(
            plants, cols, goals, t0, t_all[train], q0, tel.present_rad[train][:, cols].T
        )
        grid = np.zeros((len(LATENCY_GRID_MS), len(cols), 3))
        grid[:, :, 1] = np.array(LATENCY_GRID_MS)[:, None]
        costs = np.sum(problem.residuals(grid) ** 2, axis=-1)  # (grid, n)
        theta = grid[np.argmin(costs, axis=0), np.arange(len(cols))]
        theta, iterations = _levenberg_marquardt(problem, theta)
        sds = standard_errors(problem, theta)
        touching = contacts_beyond_joints(robot, cols, tel.present_rad[window][::CONTACT_EVERY])
        full = _GroupProblem(
            plants, cols, goals, t0, t_all[window], q0, tel.present_rad[window][:, cols].T
        )
        sim_all = full.run(theta[None])[0]
        is_check = np.isin(window, check)
        meas = full.measured
        train_rms = _residual_rms(sim_all[:, ~is_check], meas[:, ~is_check])
        check_rms = _residual_rms(sim_all[:, is_check], meas[:, is_check])
        params = _params(theta)
        for n, j in enumerate(cols):
            gain, lat_s, strength = (float(x) for x in params[n])
            p = plants[n]
            drive = strength * p.stall_torque_nm
            fits.append(
                JointFit(
                    name=robot.joints[j].name,
                    setting=ServoSetting(gain, lat_s * 1000.0, strength),
                    kp_nm_per_rad=gain * p.duty_per_rad * drive,
                    drive_limit_nm=drive,
                    train_rms_rad=float(train_rms[n]),
                    held_out_rms_rad=float(check_rms[n]),
                    samples=int(np.sum(np.isfinite(meas[n, ~is_check]))),
                    iterations=iterations,
                    sd=(
                        gain * float(sds[n, 0]),  # d gain = gain · d ln gain
                        float(sds[n, 1]),
                        strength * float(sds[n, 2]),
                    ),
                    contacts=touching[n],
                )
            )
        traces.append(
            GroupTrace(
                joints=tuple(cols), t_s=t_all[window], held_out=is_check,
                goal_rad=goal_all[window][:, cols].T, measured_rad=meas, simulated_rad=sim_all,
            )
        )  # fmt: skip
    if not fits:
        raise SimConfigError(
            f"{source}: no joint moved enough in its excitation window to be identified"
        )
    order = {n: i for i, n in enumerate(robot.joint_names)}
    return IdentifyResult(tuple(sorted(fits, key=lambda f: order[f.name])), tuple(traces))
