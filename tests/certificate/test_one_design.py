"""One design per command: the gains that run are the gains printed, saved, loaded and exported."""

from __future__ import annotations

import json

import numpy as np
import pytest

from auv_hinf.certificate import design_point as design_module
from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.run_plan import plan_run
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from tests.helpers import certificate_of, fully_actuated, fully_actuated_file


@pytest.fixture(scope="module")
def remus() -> Certificate:
    return certificate_of(fully_actuated("remus-line"))


@pytest.mark.slow
def test_robust_preset_runs_the_robust_gains_everywhere(remus, tmp_path, capsys):
    g = remus.gains
    assert g is not None and remus.gain_source == "robust"
    # the robust gains are not Theorem 1's: printing alpha_used as "used" was the 0.2.0 defect
    assert g.alpha != pytest.approx(remus.alpha_used)
    # printed
    assert g.describe() in remus.summary() and "(robust design)" in remus.summary()
    assert "<- used" not in next(line for line in remus.summary().splitlines() if "alpha[stabilizing]" in line)
    # JSON
    data = remus.to_dict()["gains"]
    assert (data["alpha"], data["k1"], tuple(data["k_psi"]), data["source"]) == (g.alpha, g.k1, g.k_psi, "robust")
    # exported: the python-control controller applies these gains
    assert remus.law().gains == g
    ctrl = remus.controller()
    fleet = remus.mission_fleet()
    m = fleet.motion(3.0)
    rng = np.random.default_rng(5)
    states = np.column_stack([m.p, m.psi, np.full(3, 1.5), np.zeros(3), np.zeros(3)]) + 0.01 * rng.standard_normal(
        (3, 6)
    )
    out = np.asarray(ctrl.output(3.0, [], states.ravel())).reshape(3, 3)
    vel = np.column_stack(
        [
            states[:, 3] * np.cos(states[:, 2]) - states[:, 4] * np.sin(states[:, 2]),
            states[:, 3] * np.sin(states[:, 2]) + states[:, 4] * np.cos(states[:, 2]),
        ]
    )
    np.testing.assert_allclose(out, remus.law().forces(states, vel, m), rtol=1e-12)
    assert remus.closed_loop_system().nstates == 3 * 6
    # simulated: plan_run uses the same gains
    plan = plan_run(fully_actuated("remus-line"), horizon=1.0, samples=11)
    assert plan.scenario.law.gains == g and plan.design.gains == g
    # saved by `certify --out` and loaded back
    code = main(["certify", "--config", str(fully_actuated_file("remus-line", tmp_path)), "--out", str(tmp_path)])
    capsys.readouterr()
    assert code == 0
    loaded = Certificate.load(tmp_path / "certificate.json")
    assert loaded.gains == g and loaded.gain_source == "robust"
    assert json.loads((tmp_path / "certificate.json").read_text())["certificate"]["gains"]["alpha"] == g.alpha


@pytest.mark.slow
def test_certify_computes_the_design_once(monkeypatch):
    calls = {"sigma": 0, "robust": 0}
    sigma, robust = design_module.vehicle_sigma, design_module.design_robust

    def count_sigma(*args, **kw):
        calls["sigma"] += 1
        return sigma(*args, **kw)

    def count_robust(*args, **kw):
        calls["robust"] += 1
        return robust(*args, **kw)

    monkeypatch.setattr(design_module, "vehicle_sigma", count_sigma)
    monkeypatch.setattr(design_module, "design_robust", count_robust)
    design_module._design.cache_clear()
    cfg = fully_actuated("remus-line")
    certify(cfg)
    plan_run(cfg, horizon=1.0, samples=11)  # a later command on the same design reuses it
    assert calls == {"sigma": 1, "robust": 1}
    design_module._design.cache_clear()


@pytest.mark.slow
def test_theorem1_preset_runs_its_theorem1_gains():
    cert = certify(preset_config("paper-triangle"))
    point = design_point(preset_config("paper-triangle"))
    assert cert.gain_source == point.source == "theorem1"
    assert cert.gains == point.gains and cert.gains is not None
    assert cert.gains.alpha == cert.alpha_used and cert.gains.k1 == cert.config.k1
