"""A propeller and a rudder: what the saturation model delivers, against the rudder's closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_hinf.actuation.limits import MAX_RUDDER, RudderActuation, vehicle_actuators
from auv_hinf.config.settings import config_from_dict
from auv_hinf.exceptions import ConfigError, ParameterError

REMUS = vehicle_actuators("remus100")


def random_rudders(rng: np.random.Generator, count: int) -> list[RudderActuation]:
    """Rudders with figures spread over a decade around the REMUS 100's, either sign of lever arm."""
    return [
        RudderActuation(
            float(rng.uniform(5.0, 200.0)),
            float(rng.uniform(0.05, MAX_RUDDER)),
            float(rng.uniform(1.0, 30.0) * rng.choice([-1, 1])),
            float(rng.uniform(1.0, 30.0) * rng.choice([-1, 1])),
        )
        for _ in range(count)
    ]


def test_the_delivered_sway_and_yaw_lie_on_the_rudder_line_within_its_deflection():
    rng = np.random.default_rng(7)
    for rudder in random_rudders(rng, 20):
        tau = rng.normal(scale=[100.0, 30.0, 10.0], size=(500, 3))
        surge = rng.uniform(-0.5, 3.0, size=500)
        applied, active = rudder.saturate(tau, surge)
        q = surge**2
        moving = q > 0
        delta = applied[moving, 2] / (rudder.rudder_yaw * q[moving])
        assert np.all(np.abs(delta) <= rudder.rudder_max * (1 + 1e-12))
        assert np.allclose(applied[moving, 1], rudder.rudder_sway * q[moving] * delta, rtol=1e-12, atol=1e-12)
        assert np.all(applied[~moving, 1:] == 0.0)  # no speed through the water: no rudder force
        assert np.all(np.abs(applied[:, 0]) <= rudder.tau_x)
        # a command the rudder can make (on its line, within the deflection and the thrust) comes out unchanged
        delta = rng.uniform(-rudder.rudder_max, rudder.rudder_max, size=500)
        made = np.stack(
            [
                rng.uniform(-rudder.tau_x, rudder.tau_x, 500),
                rudder.rudder_sway * q * delta,
                rudder.rudder_yaw * q * delta,
            ],
            axis=-1,
        )
        applied, active = rudder.saturate(made, surge)
        assert np.allclose(applied[moving], made[moving], rtol=1e-12, atol=1e-12) and not active[moving].any()


def test_a_yaw_command_within_the_rudders_authority_is_delivered_exactly_with_its_sway_force():
    u = np.array([0.5, 1.5, 2.5])
    _, n_max = np.array([REMUS.authority(x) for x in u]).T
    tau = np.stack([np.full(3, 10.0), REMUS.lever_arm**-1 * 0.5 * n_max, 0.5 * n_max], axis=-1)
    applied, active = REMUS.saturate(tau, u)
    assert np.allclose(applied, tau, rtol=1e-12) and not active.any()
    # the same yaw moment without its sway force is not deliverable: the sway force comes anyway
    alone = tau * np.array([1.0, 0.0, 1.0])
    applied, active = REMUS.saturate(alone, u)
    assert active.all() and np.allclose(applied[:, 1], tau[:, 1], rtol=1e-12)


def test_the_rudder_needs_the_surge_speed():
    with pytest.raises(ParameterError, match="surge speed"):
        REMUS.saturate(np.zeros((2, 3)))


@pytest.mark.parametrize(
    "table, match",
    [
        (
            {"kind": "underactuated", "tau_x": 67.0, "rudder_max": 13.6, "rudder_sway": 9.64, "rudder_yaw": -6.15},
            "rudder_max",
        ),
        (
            {"kind": "underactuated", "tau_x": 67.0, "rudder_max": 0.2, "rudder_sway": 0.0, "rudder_yaw": -6.15},
            "rudder_sway must be nonzero",
        ),
        ({"kind": "underactuated", "tau_x": 67.0, "rudder_max": 0.2}, "give all of tau_x, rudder_max"),
        (
            {
                "kind": "underactuated",
                "tau_x": 67.0,
                "tau_y": 5.0,
                "rudder_max": 0.2,
                "rudder_sway": 9.6,
                "rudder_yaw": -6.0,
            },
            "tau_y do not apply",
        ),
        ({"preset": "remus100", "kind": "underactuated"}, "either preset or the limits"),
    ],
)
def test_bad_rudder_tables_are_refused_by_key(table, match):
    with pytest.raises(ConfigError, match=match):
        config_from_dict({"actuators": table})


def test_the_remus100_preset_is_prestero_s_rudder():
    assert isinstance(REMUS, RudderActuation) and REMUS.kind == "underactuated"
    assert (REMUS.rudder_sway, REMUS.rudder_yaw) == (9.64, -6.15)
    assert math.degrees(REMUS.rudder_max) == pytest.approx(13.6, rel=1e-12)
    assert REMUS.lever_arm == pytest.approx(-0.638, abs=5e-4)
