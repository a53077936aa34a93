"""The runtime monitor on synthetic steps: each assumption trips on its own, on its vehicle, at its bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_hinf.deployment.monitor import ASSUMPTIONS, CURRENT_TIME_CONSTANT, Action, Monitor, MonitorConfig, StepInput
from auv_hinf.deployment.runtime import Assumptions
from auv_hinf.exceptions import ParameterError
from auv_hinf.implementation.model import MeasurementNoise
from auv_hinf.mission.margins import ErrorBounds
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import bluerov2_heavy

N = 3
ASSUMED = Assumptions(
    sample_time=0.1,
    delay=0.05,
    varying_delay=True,
    envelope=Envelope(u=(-0.2, 0.4), v=(-0.2, 0.2), r=(-0.2, 0.2)),
    force_limits=(86.0, 86.0, 23.0),
    current_bound=0.0,
    noise=MeasurementNoise(position=0.01, heading=0.01, yaw_rate=0.01),
    error_bounds=ErrorBounds(0.05, 0.076, 0.074, 0.08),
    invariant_source="implementation",
    certified=True,
    pilot_gain=1.0,
)


def _step(t: float = 0.0, period: float = 0.1, **change: object) -> StepInput:
    """A step on which every assumption holds; ``change`` replaces fields."""
    states = np.zeros((N, 6))
    states[:, 1] = [-2.0, 0.0, 2.0]
    states[:, 3] = 0.05  # surge at the reference speed
    reference = np.column_stack([states[:, 0:3], np.full(N, 0.05), np.zeros(N), np.zeros(N)])
    fields: dict[str, object] = {
        "time": t,
        "period": period,
        "states": states,
        "ages": np.full(N, 0.02),
        "nav_gap": np.full(N, 0.01),
        "heartbeat_gap": np.full(N, 0.5),
        "commanded": np.tile([1.06, 0.0, 0.0], (N, 1)),
        "saturated": np.zeros(N, dtype=bool),
        "reference": reference,
        "modes": np.full(N, 19),
        "gains": np.ones(N),
    }
    fields.update(change)
    return StepInput(**fields)  # type: ignore[arg-type]


def _found(step: StepInput, before: StepInput | None = None) -> set[tuple[int, str]]:
    mon = Monitor(ASSUMED, N, bluerov2_heavy())
    if before is not None:
        assert mon.check(before) == []
    return {(v.vehicle, v.assumption) for v in mon.check(step)}


def test_a_step_inside_every_assumption_has_no_violation():
    assert _found(_step(period=math.nan)) == set()
    assert _found(_step(t=0.1), before=_step(period=math.nan)) == set()


def test_age_and_lag_trip_on_the_old_vehicle():
    ages = np.array([0.02, 0.06, 0.02])
    assert _found(_step(ages=ages)) == {(1, "delay")}
    # 0.045 s old at the last step, held 0.11 s: the force now rests on a 0.155 s old measurement
    before = _step(period=math.nan, ages=np.array([0.02, 0.045, 0.02]))
    assert _found(_step(t=0.11, period=0.11), before=before) == {(1, "lag")}
    assert _found(_step(t=0.16, period=0.16), before=_step(period=math.nan)) >= {(-1, "period")}


def test_the_invariant_allows_the_noise_and_no_more():
    inside, outside = _step(), _step()
    inside.states[2, 0] += 0.05 + 0.01 - 1e-6  # bound plus the position noise
    outside.states[2, 0] += 0.05 + 0.01 + 1e-6
    assert _found(inside) == set() and _found(outside) == {(2, "invariant_position")}
    turned = _step()
    turned.states[0, 2] = 0.074 + 0.01 + 1e-3
    assert _found(turned) == {(0, "invariant_heading")}


def test_envelope_force_mapping_and_vehicle_checks():
    fast = _step()
    fast.states[0, 3] = 0.45  # beyond u <= 0.4 (and beyond the velocity bound of the invariant)
    assert (0, "envelope_u") in _found(fast)
    assert _found(_step(commanded=np.tile([90.0, 0.0, 0.0], (N, 1)))) == {(i, "force_x") for i in range(N)}
    assert _found(_step(saturated=np.array([False, True, False]))) == {(1, "deliverable")}
    assert _found(_step(modes=np.array([19, 19, 0]))) == {(2, "mode")}
    assert _found(_step(gains=np.array([0.5, 1.0, 1.0]))) == {(0, "pilot_gain")}
    assert _found(_step(nav_gap=np.array([0.01, 0.15, 0.01]))) == {(1, "stale")}
    assert _found(_step(heartbeat_gap=np.array([0.5, 0.5, 3.5]))) == {(2, "heartbeat")}
    missing = _step()
    missing.states[1] = np.nan
    assert (1, "missing") in _found(missing)


def test_the_current_estimator_finds_a_current_and_trips_its_bound():
    params = bluerov2_heavy()
    mon = Monitor(ASSUMED, N, params)
    water = 0.05  # m/s through the water; 0.1 m/s of current pushes vehicle 0 north
    current = np.array([0.1, 0.0, 0.0])
    drag = (params.d11_lin + params.d11_quad * water) * water
    found = []
    for k in range(90):
        step = _step(t=0.1 * k, period=math.nan if k == 0 else 0.1)
        step.states[:, 3] = water + current
        found = mon.check(step)
        mon.made(np.tile([drag, 0.0, 0.0], (N, 1)))
    # the low-pass filter after 89 updates of weight dt / (tc + dt)
    settled = 1.0 - (1.0 - 0.1 / (CURRENT_TIME_CONSTANT + 0.1)) ** 89
    assert mon.current_speed[0] == pytest.approx(0.1 * settled, rel=1e-9) and np.all(mon.current_speed[1:] < 1e-9)
    assert {(v.vehicle, v.assumption) for v in found if v.assumption == "current"} == {(0, "current")}


def test_actions_are_configurable_and_the_most_severe_wins():
    cfg = MonitorConfig.parse(None, ["delay=hold"])
    assert cfg.action_for("delay") is Action.HOLD and cfg.action_for("missing") is Action.STOP
    assert cfg.action_for("stale") is Action.WARN
    strict = MonitorConfig.parse("stop", [])
    assert all(strict.action_for(a) is Action.STOP for a in ASSUMPTIONS)
    mon = Monitor(ASSUMED, N, bluerov2_heavy())
    found = mon.check(_step(ages=np.array([0.06, 0.02, 0.02]), nav_gap=np.array([0.01, 0.2, 0.01])))
    assert cfg.most_severe(found) is Action.HOLD
    assert MonitorConfig.parse(None, ["stale=stop", "delay=hold"]).most_severe(found) is Action.STOP
    with pytest.raises(ParameterError, match="unknown assumption"):
        MonitorConfig.parse(None, ["latency=hold"])
    with pytest.raises(ParameterError, match="warn, hold, stop"):
        MonitorConfig.parse(None, ["delay=panic"])
