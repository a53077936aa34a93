"""Inputs an independent fuzzer found to break the product, each now an answer.

A vehicle whose inertia nearly vanishes, one without quadratic drag, a run whose simulated plant
leaves the declared box while the composed certificate covers the design, and a refusal asked
for as JSON: every one gives a verdict (or a one-line error), never an internal error.
"""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from auv_hinf.certificate.run_plan import plan_run
from auv_hinf.cli.main import main
from auv_hinf.composed.loops import Errors, MissionBounds, OperatingBox, Plant, position_axes
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import config_from_dict
from auv_hinf.models.vehicle import bluerov2_heavy
from auv_hinf.robust.box import ParameterBox
from tests.helpers import DEPLOYED, to_toml


@pytest.mark.slow
def test_a_vanishing_sway_inertia_is_refused_not_an_internal_error(tmp_path, capsys):
    raw = preset_config("bluerov2-line").to_toml_dict()
    raw["vehicle"] = {**bluerov2_heavy().to_dict(), "m22": 1e-6}
    raw["vehicle"].pop("name", None)
    path = tmp_path / "tiny.toml"
    path.write_text(to_toml(raw), encoding="utf-8")
    assert main(["certify", "--config", str(path), "--json"]) == 1
    out, err = capsys.readouterr()
    record = json.loads(out)
    assert record["certified"] is False and record["reasons"]
    assert "internal error" not in err


def test_an_axis_without_quadratic_drag_gets_its_trim_cells():
    model = replace(bluerov2_heavy(), d11_quad=0.0, d11_lin=13.7)
    box = ParameterBox.from_ranges(model, (("d11_lin", (0.8, 1.2)), ("m11", (0.9, 1.1))))
    plant = Plant(model=model, box=box, current=0.05)
    mission = MissionBounds(
        speed=(0.4, 0.4), offset=0.0, yaw_rate=0.0, accel=0.0, jerk=0.0, yaw_accel=0.0, yaw_jerk=0.0
    )
    op = OperatingBox.of(mission, plant.current, Errors(0.1, 0.05, 0.01, 0.01))
    surge, _ = position_axes(plant, op, 0.0, straight=True)
    lo, hi = surge.damping
    # without quadratic drag the slope is -d_lin/m at every speed: its range is the box's
    assert lo == -13.7 * 1.2 / (model.m11 * 0.9) and hi == -13.7 * 0.8 / (model.m11 * 1.1)
    assert all(lo <= a <= b <= hi for a, b in surge.parts)


@pytest.mark.slow
def test_a_refusal_asked_for_as_json_is_one_json_object(tmp_path, capsys):
    raw = {
        **DEPLOYED,
        "implementation": {},
        "design": {"robust": True},
        "uncertainty": {"m11": [0.5, 1.5]},
        "disturbance": {"current_speed": 0.3},
    }
    path = tmp_path / "uncertified.toml"
    path.write_text(to_toml(raw), encoding="utf-8")
    assert main(["simulate", "--config", str(path), "--json"]) == 1
    out, err = capsys.readouterr()
    record = json.loads(out)
    assert record["ok"] is False and record["exit_code"] == 1 and "refusing to simulate" in record["message"]
    assert err.splitlines()[-1].startswith("auv-hinf: not certified: ")


@pytest.mark.slow
def test_certified_gains_are_simulated_when_the_run_leaves_the_box():
    # the composed certificate covers the design; the simulated plant is outside the declared box:
    # the run is not covered, but the gains are certified, so nothing refuses to run them
    cfg = preset_config("bluerov2-survey")
    raw = cfg.to_toml_dict()
    raw["simulation"] = {**raw["simulation"], "horizon": 5.0, "plant": {"d11_quad": 3.0}}
    plan = plan_run(config_from_dict(raw, "outside"))
    assert plan.uncertified_gains() is None
    composed = next(c for c in plan.checks if c.part == "composed")
    assert composed.certifies_gains and not composed.covers and "outside the declared box" in composed.reason
