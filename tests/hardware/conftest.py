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


#: The vendor SDKs' packet timeout is 2·LATENCY_TIMER + 2 ms + the bytes' wire time (their
#: `port_handler`, LATENCY_TIMER = 16 ms for an FTDI adapter): 34 ms. A pty is served by a
#: thread of this process, and on a loaded 2-core CI machine one reply came later than that
#: (COMM_RX_TIMEOUT in the middle of a write loop). The pty tests check bytes, not timing, so
#: they give the SDKs this latency instead (a 202 ms packet timeout).
PTY_SDK_LATENCY_MS = 100


@pytest.fixture
def patient_sdk_timeouts(monkeypatch: pytest.MonkeyPatch) -> None:
    """Raise both vendor SDKs' adapter-latency term for tests that run them on a pty."""
    import dynamixel_sdk.port_handler as dxl_port
    import scservo_sdk.port_handler as ft_port

    monkeypatch.setattr(dxl_port, "LATENCY_TIMER", PTY_SDK_LATENCY_MS)
    monkeypatch.setattr(ft_port, "LATENCY_TIMER", PTY_SDK_LATENCY_MS)
