"""The remus-survey fleet: a path-frame V on a lawn-mower certifies and flies covered, facing forward.

The preset declares the REMUS 100's propeller and rudder and is refused (no sway actuator); the
path-frame machinery is checked on the same fleet with a sway actuator (:func:`fully_actuated`).
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.run_plan import plan_run, run_report
from auv_hinf.cli.args import EXIT_NEGATIVE
from auv_hinf.cli.main import main
from auv_hinf.config.presets import annotated_toml
from auv_hinf.config.settings import ReferenceConfig
from auv_hinf.simulation.engine import simulate
from tests.helpers import certificate_of, fully_actuated, fully_actuated_file


@pytest.mark.slow
def test_survey_certifies_and_a_simulation_is_covered_with_the_v_facing_forward_on_every_leg():
    cfg = fully_actuated("remus-survey")
    cert = certificate_of(cfg)
    assert cert.certified, cert.reasons
    assert cert.to_dict()["closed_loop"]["reference_inside_envelope"] == [True] * 5
    plan = plan_run(cfg)
    res = simulate(plan.scenario)
    report = run_report(plan, res)
    assert plan.covered and report["stayed_in_envelope"] and report["certificate_covers_run"]
    mission = design_point(cfg).mission
    _, qd, _, _ = mission(res.t)
    chi = np.arctan2(qd[:, 1], qd[:, 0])
    pos = res.states[:, :, :2]
    lead = pos[:, 0] - pos[:, 1:].mean(axis=1)  # the lead (vehicle 0) against the rest of the V
    ahead = lead[:, 0] * np.cos(chi) + lead[:, 1] * np.sin(chi)
    legs = np.abs(np.sin(chi)) < 1e-9  # straight legs along +x and -x
    for sign in (1.0, -1.0):
        on_leg = legs & (np.sign(np.cos(chi)) == sign)
        assert on_leg.sum() > 100 and ahead[on_leg].min() > 5.0  # 7 m ahead of the others' centroid
    assert report["shape_errors"]["frame"] == "path" and report["shape_errors"]["axes"] == ["along", "cross"]


@pytest.mark.slow
def test_cli_keys_and_a_too_tight_turn_is_refused_before_simulating(tmp_path, capsys):
    # the preset itself, with its rudder, is refused: the law needs a sway force
    assert main(["certify", "--preset", "remus-survey", "--json"]) == EXIT_NEGATIVE
    out = capsys.readouterr()
    data = json.loads(out.out)
    assert data["actuators"]["kind"] == "underactuated" and "sway actuator" in out.err
    loop = data["closed_loop"]
    assert loop["reference_inside_envelope"] == [True] * 5 and loop["binding"] is None
    cfg = fully_actuated("remus-survey")
    tight = replace(
        cfg,
        reference=ReferenceConfig(
            "lawnmower", (("speed", 1.5), ("leg_length", 400.0), ("spacing", 240.0), ("turn_radius", 25.0))
        ),
    )
    path = tmp_path / "tight.toml"
    path.write_text(annotated_toml(tight))
    assert main(["certify", "--config", str(path), "--json"]) == EXIT_NEGATIVE
    out = capsys.readouterr()
    loop = json.loads(out.out)["closed_loop"]
    assert loop["reference_inside_envelope"] == [False, True, True, False, False]
    assert set(loop["binding"]) >= {"vehicle", "time", "channel"} and loop["binding"]["vehicle"] in (0, 3, 4)
    # the smallest radius that fits (30.06... m), printed rounded up so that the printed radius fits
    smallest = loop["reference_fit"]["smallest_turn_radius"]
    assert 30.06 <= smallest < 30.07 and "smallest turn radius that fits: 30.07 m" in out.err
    assert main(["simulate", "--config", str(path), "--json"]) == EXIT_NEGATIVE
    err = capsys.readouterr().err
    assert "refusing to simulate" in err and "smallest turn radius that fits" in err and "Traceback" not in err
    assert (
        main(["simulate", "--config", str(fully_actuated_file("remus-survey", tmp_path)), "--horizon", "60", "--json"])
        == 0
    )
    summary = json.loads(capsys.readouterr().out)
    assert summary["shape_errors"]["frame"] == "path" and len(summary["shape_errors"]["max"]) == 2
