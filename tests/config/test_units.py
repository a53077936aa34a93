"""Numbers in the wrong unit: every key with an angle, a rate or a speed refuses a value that looks like
degrees, deg/s or cm/s, with one line naming the key, the value, the likely unit and the value converted."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import pytest

from auv_hinf.config.presets import PRESETS, preset_config
from auv_hinf.config.schema import MAX_ANGLE, MAX_RATE, MAX_SPEED, SPEED_FACTOR
from auv_hinf.config.settings import ReferenceConfig, SimulationConfig, config_from_dict
from auv_hinf.exceptions import ConfigError
from auv_hinf.models.envelope import Envelope


def _rows(column: int, value: float) -> list[list[float]]:
    """Three start rows [x, y, psi, u, v, r] of the default triangle, ``column`` of the first set to ``value``."""
    rows = [[0.0, 0.0, 0.1, 1.0, 0.0, 0.0], [20.0, 0.0, 0.0, 1.0, 0.0, 0.0], [10.0, 15.0, 0.0, 1.0, 0.0, 0.0]]
    rows[0][column] = value
    return rows


def _noise(key: str, value: float) -> dict[str, Any]:
    return {"implementation": {"sample_time": 0.1, "noise": {key: value}}}


#: (TOML document with one value in the wrong unit, the key the line names, the likely unit, the value converted)
ANGLES_AND_RATES = {
    "envelope.psi": ({"envelope": {"psi": [-180.0, 180.0]}}, "envelope.psi", "degrees", "[-3.142, 3.142] rad"),
    "envelope.r": ({"envelope": {"r": [-30.0, 30.0]}}, "envelope.r", "deg/s", "[-0.5236, 0.5236] rad/s"),
    "reference.heading": (
        {"reference": {"kind": "line", "heading": 90.0}},
        "reference.heading",
        "degrees",
        "1.571 rad",
    ),
    "reference.heading<0": (
        {"reference": {"kind": "line", "heading": -270.0}},
        "reference.heading",
        "degrees",
        "-4.712 rad",
    ),
    "reference.omega": ({"reference": {"kind": "sine", "omega": 5.73}}, "reference.omega", "deg/s", "0.1 rad/s"),
    "simulation.initial psi": (
        {"simulation": {"initial": _rows(2, 45.0)}},
        "simulation.initial: row 0 (vehicle 1), psi = 45 rad",
        "degrees",
        "0.7854 rad",
    ),
    "simulation.initial r": (
        {"simulation": {"initial": _rows(5, 10.0)}},
        "simulation.initial: row 0 (vehicle 1), r = 10 rad/s",
        "deg/s",
        "0.1745 rad/s",
    ),
    "implementation.noise.heading": (_noise("heading", 5.0), "implementation.noise.heading", "degrees", "0.08727 rad"),
    "implementation.noise.yaw_rate": (
        _noise("yaw_rate", 3.0),
        "implementation.noise.yaw_rate",
        "deg/s",
        "0.05236 rad/s",
    ),
}


SPEEDS = {
    "reference.speed": ({"reference": {"speed": 150.0}}, "reference.speed", "cm/s", "1.5 m/s"),
    "reference.speed vs envelope.u": (
        {"reference": {"speed": 5.4}, "envelope": {"u": [0.0, 2.0]}},
        "reference.speed = 5.4 m/s is 2.7 times the fastest surge speed of envelope.u (2 m/s)",
        "km/h",
        "1.5 m/s",
    ),
    "envelope.u": ({"envelope": {"u": [0.0, 250.0]}}, "envelope.u", "cm/s", "[0, 2.5] m/s"),
    "envelope.v": ({"envelope": {"v": [-50.0, 50.0]}}, "envelope.v", "cm/s", "[-0.5, 0.5] m/s"),
    "simulation.initial u": (
        {"simulation": {"initial": _rows(3, 150.0)}},
        "simulation.initial: row 0 (vehicle 1), u = 150 m/s",
        "cm/s",
        "1.5 m/s",
    ),
    "simulation.initial v": (
        {"simulation": {"initial": _rows(4, -30.0)}},
        "simulation.initial: row 0 (vehicle 1), v = -30 m/s",
        "cm/s",
        "-0.3 m/s",
    ),
    "simulation.current": ({"simulation": {"current": [30.0, 0.0]}}, "simulation.current", "cm/s", "[0.3, 0] m/s"),
    "disturbance.current_speed": (
        {"disturbance": {"current_speed": 50.0}},
        "disturbance.current_speed",
        "cm/s",
        "0.5 m/s",
    ),
    "implementation.noise.velocity": (
        _noise("velocity", 25.0),
        "implementation.noise.velocity",
        "cm/s",
        "0.25 m/s",
    ),
}


def _error(data: dict[str, Any]) -> str:
    with pytest.raises(ConfigError) as info:
        config_from_dict(data)
    return str(info.value)


@pytest.mark.parametrize("case", [*ANGLES_AND_RATES, *SPEEDS])
def test_a_value_in_another_unit_is_one_line_naming_key_value_unit_and_conversion(case):
    data, key, likely, converted = {**ANGLES_AND_RATES, **SPEEDS}[case]
    (line,) = _error(data).splitlines()
    assert line.startswith(key), line
    assert f"it looks like {likely}" in line and line.endswith(converted), line


@pytest.mark.parametrize(
    "data",
    [
        {"envelope": {"psi": [-MAX_ANGLE / 2, MAX_ANGLE / 2]}},
        {"envelope": {"r": [-MAX_RATE, MAX_RATE]}},
        {"reference": {"kind": "line", "heading": MAX_ANGLE}},
        {"reference": {"kind": "line", "heading": -MAX_ANGLE}},
        {"reference": {"kind": "sine", "omega": MAX_RATE}},
        {"simulation": {"initial": _rows(2, -MAX_ANGLE)}},
        {"simulation": {"initial": _rows(5, MAX_RATE)}},
        {"simulation": {"current": [0.6 * MAX_SPEED, 0.8 * MAX_SPEED]}},  # |current| = MAX_SPEED
        {"disturbance": {"current_speed": MAX_SPEED}},
        {"reference": {"speed": SPEED_FACTOR * 3.5}},  # the default envelope's u <= 3.5 m/s
        {"reference": {"speed": MAX_SPEED}, "envelope": {"u": [0.0, MAX_SPEED]}},
    ],
)
def test_values_at_the_limits_are_accepted(data):
    config_from_dict(data)


def test_the_python_objects_refuse_the_same_values():
    cfg = preset_config("paper-triangle")
    with pytest.raises(ConfigError, match=r"envelope\.r: \[-30, 30\] rad/s .* it looks like deg/s"):
        replace(cfg, envelope=Envelope(u=(0.0, 3.5), v=(-1.0, 1.0), r=(-30.0, 30.0)))
    with pytest.raises(ConfigError, match=r"reference\.heading .* it looks like degrees; 90 degrees is 1\.571 rad"):
        ReferenceConfig("line", (("heading", 90.0),))
    with pytest.raises(ConfigError, match=r"simulation\.initial: row 0 \(vehicle 1\), psi = 45 rad"):
        SimulationConfig(initial=tuple(map(tuple, _rows(2, 45.0))))
    with pytest.raises(ConfigError, match=r"reference\.speed = 9 m/s .* it looks like km/h; 9 km/h is 2\.5 m/s"):
        replace(cfg, reference=ReferenceConfig("sine", (("speed", 9.0),)))


def test_a_speed_no_unit_explains_says_what_to_change():
    (line,) = _error({"reference": {"speed": 19.0}, "envelope": {"u": [0.0, 0.1]}}).splitlines()
    assert "190 times" in line and line.endswith("lower the speed or widen envelope.u")


@pytest.mark.parametrize("name", PRESETS)
def test_every_preset_is_within_the_unit_limits(name):
    cfg = preset_config(name)
    assert config_from_dict(cfg.to_toml_dict()) == cfg
    assert max(abs(x) for x in cfg.envelope.r) <= MAX_RATE and max(abs(x) for x in cfg.envelope.psi) <= MAX_ANGLE
    speed = cfg.reference.kwargs()["speed"]
    assert speed <= SPEED_FACTOR * max(abs(x) for x in cfg.envelope.u) and speed <= MAX_SPEED
    assert all(abs(row[2]) <= math.pi for row in cfg.simulation.initial or ())
