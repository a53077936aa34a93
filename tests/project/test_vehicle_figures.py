"""docs/vehicles.md agrees with the presets, figure by figure.

Each number of the page's tables that the code also holds is read from the page and compared with the
code: the nine model parameters of every vehicle preset (:mod:`auv_hinf.models.vehicle`), the actuator
limits of every actuator preset (:mod:`auv_hinf.actuation.limits`), the BlueROV2 Heavy's thrusters and
their channel limits (:mod:`auv_hinf.actuation.thrusters`), and the mission of ``remus-survey``. A figure
agrees when it is the code's value rounded to the digits printed.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from auv_hinf.actuation.limits import VEHICLE_ACTUATORS, RudderActuation
from auv_hinf.actuation.thrusters import (
    BENZON2022_THRUST,
    T200_FORWARD_16V,
    T200_REVERSE_16V,
    bluerov2_heavy_thrusters,
)
from auv_hinf.config.presets import SURVEY_V, preset_config
from auv_hinf.config.schema import PARAMETERS
from auv_hinf.mission.paths import lawnmower_min_spacing
from auv_hinf.models.vehicle import PRESETS

PAGE = Path(__file__).resolve().parents[2] / "docs" / "vehicles.md"
NUMBER = r"-?\d+(?:\.\d+)?"
#: The page writes the BlueROV2's damping as Fossen's derivatives (magnitudes): their parameters.
DERIVATIVES = {
    "X_u": "d11_lin",
    "Y_v": "d22_lin",
    "N_r": "d33_lin",
    "X_u\\|u\\|": "d11_quad",
    "Y_v\\|v\\|": "d22_quad",
    "N_r\\|r\\|": "d33_quad",
}


def agrees(printed: str, value: float) -> bool:
    """``printed`` is ``value`` rounded to the digits printed (half a unit of the last digit, and round-off)."""
    decimals = len(printed.partition(".")[2])
    return abs(float(printed) - value) <= 0.5 * 10.0**-decimals * (1 + 1e-9)


def section(title: str) -> str:
    """The part of the page under the ``##`` heading that names `title`, up to the next ``##`` heading."""
    text = PAGE.read_text(encoding="utf-8")
    start = re.search(rf"\n## [^\n]*`{re.escape(title)}`", text).start()  # type: ignore[union-attr]
    end = text.find("\n## ", start + 1)
    return text[start : end if end > 0 else len(text)]


def rows(text: str) -> list[list[str]]:
    """The cells of every table row of ``text`` (separator rows left out)."""
    out = []
    for line in text.splitlines():
        if line.startswith("| ") and not re.fullmatch(r"[|\s:-]+", line):
            out.append([c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]])
    return out


def parameter_figures(text: str) -> dict[str, str]:
    """``{parameter: printed value}`` of the rows naming one of the nine parameters (left of any ``=``)."""
    out: dict[str, str] = {}
    for field, value, *_ in rows(text):
        names = re.findall(r"`([^`]+)`", field)
        params = [n.split("=")[0].strip() for n in names if n.split("=")[0].strip() in PARAMETERS]
        params = params or [DERIVATIVES[n] for n in names if n in DERIVATIVES]
        at_design_speed = re.search(rf"\(({NUMBER}) at", value)  # `28.6 u0 (42.9 at 1.5 m/s)`
        numbers = [at_design_speed.group(1)] if at_design_speed else re.findall(NUMBER, value)
        if params and len(numbers) == len(params):
            out.update(zip(params, numbers))
    return out


@pytest.mark.parametrize("name", PRESETS)
def test_every_model_parameter_on_the_page_is_the_presets(name):
    figures = parameter_figures(section(name))
    assert set(figures) == set(PARAMETERS), f"{name}: the page gives {sorted(figures)}"
    vehicle = PRESETS[name]()
    wrong = {k: (v, getattr(vehicle, k)) for k, v in figures.items() if not agrees(v, getattr(vehicle, k))}
    assert wrong == {}, f"{name}: page vs code {wrong}"


#: The vehicle presets whose actuation is a propeller and a rudder.
RUDDER_PRESETS = [name for name, a in VEHICLE_ACTUATORS.items() if isinstance(a, RudderActuation)]


@pytest.mark.parametrize("name", RUDDER_PRESETS)
def test_every_propeller_and_rudder_on_the_page_is_the_presets(name):
    text = section(name)
    preset = VEHICLE_ACTUATORS[name]
    assert isinstance(preset, RudderActuation)
    bold = {
        m.group(1): m.group(2) for m in re.finditer(rf"\*\*`(\w+)(?: = [^`]+)?`(?: limit)?\*\* \| \*\*({NUMBER})", text)
    }
    code = {
        "tau_x": preset.tau_x,
        "rudder_max": preset.rudder_max,
        "rudder_sway": preset.rudder_sway,
        "rudder_yaw": preset.rudder_yaw,
    }
    assert set(bold) == set(code), f"the page's bold figures: {sorted(bold)}"
    wrong = {k: (v, code[k]) for k, v in bold.items() if not agrees(v, code[k])}
    assert wrong == {}, f"page vs code {wrong}"
    (row,) = [r for r in rows(text) if r[0].startswith("rudder authority")]
    printed = [float(x) for x in re.findall(NUMBER, row[1])]
    forces, speeds = printed[: len(printed) // 2], printed[len(printed) // 2 :]
    assert forces and all(agrees(f"{f:.1f}", preset.authority(u)[0]) for f, u in zip(forces, speeds, strict=True)), row
    (arm,) = [r for r in rows(text) if r[0].startswith("rudder lever arm")]
    assert agrees(re.match(NUMBER, arm[1]).group(), preset.lever_arm)  # type: ignore[union-attr]


def test_the_rudder_limits_are_the_published_degrees():
    assert math.isclose(math.degrees(VEHICLE_ACTUATORS["remus100"].rudder_max), 13.6, rel_tol=1e-12)
    assert math.isclose(math.degrees(VEHICLE_ACTUATORS["nps-auv2"].rudder_max), 20.0, rel_tol=1e-12)


def _channel_row(text: str, label: str) -> list[str]:
    (row,) = [r for r in rows(text) if r[0].startswith(label)]
    return [re.match(NUMBER, cell).group() for cell in row[1:]]  # type: ignore[union-attr]


def test_the_bluerov2_channel_limits_and_the_preset_on_the_page_are_the_codes():
    text = section("bluerov2-heavy")
    assert "(the default)" not in text, "the preset is the paper's curve, not the datasheet"
    preset = VEHICLE_ACTUATORS["bluerov2-heavy"]
    for label, thrusters in (
        ("16 V datasheet", bluerov2_heavy_thrusters()),
        ("the paper's curve", bluerov2_heavy_thrusters(BENZON2022_THRUST, BENZON2022_THRUST)),
    ):
        *channels, scale = _channel_row(text, label)
        limits = thrusters.channel_limits()
        assert all(agrees(p, v) for p, v in zip(channels, limits)), (label, channels, limits)
        assert agrees(scale, thrusters.largest_box_scale(limits))
    (row,) = [r for r in rows(text) if r[0].startswith("the paper's curve")]
    assert '`[actuators] preset = "bluerov2-heavy"`' in row[0]  # the row the preset is
    paper = bluerov2_heavy_thrusters(BENZON2022_THRUST, BENZON2022_THRUST)
    assert preset.thrusters == paper
    assert [math.floor(v) for v in paper.channel_limits()] == list(preset.limits())  # rounded down
    (heading,) = re.findall(r'### Actuation: `\[actuators\] preset = "bluerov2-heavy"` is \(([^)]*)\)', text)
    assert [float(x) for x in heading.split(",")] == list(preset.limits())
    assert "paper2011" not in VEHICLE_ACTUATORS and "Actuator limits: none" in section("paper2011")


def test_the_bluerov2_thrusters_on_the_page_are_the_codes():
    text = section("bluerov2-heavy")
    t = bluerov2_heavy_thrusters()
    (positions,) = [r[1] for r in rows(text) if r[0].startswith("positions")]
    printed = [tuple(map(float, p)) for p in re.findall(rf"\(({NUMBER}), ({NUMBER})\)", positions)]
    assert printed == [tuple(p) for p in np.asarray(t.positions).tolist()]
    (arm,) = [r[1] for r in rows(text) if r[0].startswith("moment arm")]
    d, p = np.asarray(t.directions[0]), np.asarray(t.positions[0])
    assert agrees(re.findall(NUMBER, arm)[-1], abs(p[0] * d[1] - p[1] * d[0]))
    for label, value in (("T200 forward", T200_FORWARD_16V), ("T200 reverse", T200_REVERSE_16V)):
        (cell,) = [r[1] for r in rows(text) if r[0].startswith(label)]
        assert agrees(re.search(rf"= ({NUMBER}) N", cell).group(1), value)  # type: ignore[union-attr]
    assert f"`BENZON2022_THRUST = {BENZON2022_THRUST:g}`" in text


def test_the_remus_survey_mission_on_the_page_is_the_presets():
    text = section("remus-survey")
    cfg = preset_config("remus-survey")
    path = cfg.reference.kwargs()
    table = {r[0]: re.findall(NUMBER, r[1]) for r in rows(text)}
    assert [float(x) for x in table["survey speed"]] == [path["speed"]]
    assert [float(x) for x in table["leg length, leg spacing"]] == [path["leg_length"], path["spacing"]]
    assert [float(x) for x in table["turn radius"]] == [path["turn_radius"]]
    across, back = (float(x) for x in table["V: lead ahead, arms"])
    offsets = np.asarray(SURVEY_V)
    assert np.allclose(np.abs(offsets[1:, 1]) / np.repeat([1, 2], 2), across)
    assert np.allclose(-offsets[1:, 0] / np.repeat([1, 2], 2), back)
    for key, lo, hi in re.findall(rf"`(\w)` in \[({NUMBER}), ({NUMBER})\]", text):
        assert getattr(cfg.envelope, key) == (float(lo), float(hi))
    need = lawnmower_min_spacing(path["speed"], path["turn_radius"])
    assert need <= path["spacing"] < need + 10.0  # "the smallest multiple of 10 m that holds two turns"
