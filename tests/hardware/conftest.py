"""Fixtures: virtual buses of 12 servos for both protocols."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from hardware.bus.virtual import VirtualServoBus
from robots.servo import servo_model

IDS = list(range(1, 13))
MODELS = {"dynamixel2": "XL430_W250", "feetech_sts": "STS3215_7V4"}


class ManualClock:
    """Deterministic bus clock for the servo motion model."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t

    def advance(self, dt: float) -> None:
        self.t += dt


@pytest.fixture
def clock() -> ManualClock:
    return ManualClock()


@pytest.fixture
def make_vbus(clock: ManualClock) -> Callable[[str], VirtualServoBus]:
    def make(protocol: str, ids: list[int] = IDS) -> VirtualServoBus:
        model = servo_model(MODELS[protocol])
        return VirtualServoBus({i: model for i in ids}, protocol, clock=clock)

    return make
