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
