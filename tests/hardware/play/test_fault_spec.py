"""`--fault` specs: parsing onto `FaultPlan` fields, and timed faults applied once, in order."""

from __future__ import annotations

import pytest

import robots
from hardware.bus.virtual import FaultPlan
from hardware.play.fault_spec import FaultSchedule, FaultSpecError, parse_fault
from hardware.play.virtual_rig import virtual_robot_bus


def test_specs_map_onto_the_fault_plan() -> None:
    specs = [
        parse_fault(t, range(1, 13))
        for t in (
            "drop=0.01", "corrupt=0.2", "delay=0.004", "sag=1.5", "vanish=3", "overload=4",
            "overheat=5", "voltage_error=6", "Voltage-Error=7", " status-lost ",
        )
    ]  # fmt: skip
    plan = FaultSchedule(specs).initial
    assert plan == FaultPlan(
        drop_probability=0.01,
        corrupt_probability=0.2,
        delay_s=0.004,
        voltage_sag_v=1.5,
        vanished=frozenset({3}),
        overload=frozenset({4}),
        overheat=frozenset({5}),
        voltage_error=frozenset({6, 7}),
        drop_reads_of=frozenset({"present_temperature"}),
    )


def test_timed_faults_start_once_at_their_run_time_in_order() -> None:
    robot = robots.load("quad12")
    vbus = virtual_robot_bus(robot)
    sched = FaultSchedule(
        [parse_fault(t) for t in ("drop=0.3@2", "drop=0.01", "vanish=3@1.5", "vanish=4@1.5")]
    )
    sched.attach(vbus)
    assert vbus.faults == FaultPlan(drop_probability=0.01) and sched.timed
    sched.on_tick(0, 1.49)
    assert vbus.faults.vanished == frozenset()
    sched.on_tick(1, 1.5)
    assert vbus.faults.vanished == {3, 4} and vbus.faults.drop_probability == 0.01
    sched.on_tick(2, 2.5)  # a later value replaces the earlier one (escalation)
    assert vbus.faults.drop_probability == 0.3
    assert [t for _, t in sched.applied] == [1.5, 1.5, 2.5] and not sched.timed
    sched.on_tick(3, 3.0)
    assert len(sched.applied) == 3
    assert (
        sched.describe() == "drop=0.01 from the start; vanish=3 at 1.5 s; vanish=4 at 1.5 s; "
        "drop=0.3 at 2 s"
    )


@pytest.mark.parametrize("text", ["drop=1.5", "vanish=0x3", "sag=-1", "x", "overheat=3@", "@1"])
def test_bad_specs_raise_a_value_error_naming_them(text: str) -> None:
    with pytest.raises(FaultSpecError) as info:
        parse_fault(text, range(1, 13))
    assert isinstance(info.value, ValueError)
    assert str(info.value).startswith(f"--fault {text!r}: ") and "accepted: " in str(info.value)


@pytest.mark.parametrize("text", ["sag=1e308", "sag=1e308@0.5", "delay=1e9"])
def test_fault_values_beyond_the_fault_plans_bounds_are_one_line(text: str) -> None:
    with pytest.raises(FaultSpecError) as info:
        parse_fault(text)
    msg = str(info.value)
    assert ("outside" in msg or "must lie in" in msg) and "\n" not in msg
