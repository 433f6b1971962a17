"""The `validation` block a gait file carries after `--simulate` (`plan`, `library`).

The verdict of `sim.validate`, plus what the player's pre-flight reads from it: the heating
prediction over the simulated steady cycles and the supply margin of their peak torques.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from robots import Gait, Robot

if TYPE_CHECKING:
    from sim.thermal_report import ThermalPrediction
    from sim.validate import ValidationResult


def validation_record(
    result: ValidationResult, gait: Gait, robot: Robot
) -> tuple[dict[str, Any], ThermalPrediction | None]:
    """(the gait file's validation block, the heating prediction; None without a trajectory)."""
    from robots.voltage import nominal_supply_v, voltage_margin
    from sim.metrics import steady_mask  # lazy: MuJoCo only when a gait is simulated
    from sim.thermal_report import predict_from_trajectory

    v: dict[str, Any] = result.to_dict()
    if result.trajectory is None:
        return v, None
    warmup = result.criteria.warmup_cycles
    thermal = predict_from_trajectory(result.trajectory, robot, warmup_cycles=warmup)
    v["thermal"] = thermal.to_dict()  # the player's heating prediction
    steady = steady_mask(result.trajectory, warmup)
    v["supply"] = voltage_margin(  # the simulated peak torques, for pre-flight
        robot, result.trajectory.torque_nm[steady],
        float(gait.planner.get("supply_v") or nominal_supply_v(robot)),
    ).to_dict()
    return v, thermal
