"""Certificates, config files and the CLI."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from auv_hinf.actuation.limits import Actuators
from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import mission_reference
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import load_config
from auv_hinf.models.envelope import Envelope


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-triangle", "paper-hexagon"])
def test_presets_certify(name):
    c = certify(preset_config(name))
    assert c.certified, c.reasons
    assert c.lam == pytest.approx(-2.1)  # -(70 + 100*3.5)/200
    # sigma is an upper bound of independently sampled ||B - lam I|| over the envelope
    rng = np.random.default_rng(3)
    env, p = c.config.envelope, c.config.vehicle
    u, v, r = (rng.uniform(*rg, 100_000) for rg in (env.u, env.v, env.r))
    d11, d22 = p.d11_lin + p.d11_quad * np.abs(u), p.d22_lin + p.d22_quad * np.abs(v)
    blocks = np.stack(
        [
            np.stack([-d11 / p.m11 - c.lam, (p.m22 - p.m11) * r / p.m11], -1),
            np.stack([(p.m22 - p.m11) * r / p.m22, -d22 / p.m22 - c.lam], -1),
        ],
        -2,
    )
    assert c.sigma.upper >= np.linalg.norm(blocks, 2, axis=(-2, -1)).max()
    assert c.small_gain_margin > 0
    assert c.sigma_jacobi.upper >= c.sigma.upper
    loop = c.to_dict()["closed_loop"]
    slow_pole = min(-np.roots([1.0, c.alpha_used - c.lam, c.config.k1]).real)
    assert 0 < loop["decay_rate"] < slow_pole  # no certificate can promise more than the nominal slow pole
    assert loop["decay_rate"] < c.small_gain_margin  # the margin is not the closed loop's decay rate
    assert loop["reference_inside_envelope"] and loop["covers_shaped_start"]
    assert all(v > 0 for v in loop["region"].values())


def test_bad_design_not_certified_with_reasons():
    cfg = preset_config("paper-triangle")
    bad = replace(cfg, gamma=0.2, method="paper")  # below 1/sqrt(lambda^2 + 2) = 0.395 s
    c = certify(bad)
    assert not c.certified
    assert any("below the Theorem 1 bound" in r for r in c.reasons)


def test_minimal_with_gamma_equal_inverse_sigma_is_strictly_zero_margin():
    cfg = replace(
        preset_config("paper-triangle"), envelope=Envelope(u=(0, 1.5), v=(-1, 1), r=(-2, 2)), method="minimal"
    )
    c = certify(cfg)
    assert c.small_gain_margin == pytest.approx(0.0, abs=1e-9)
    assert not c.certified and any("small-gain margin" in r for r in c.reasons)


@pytest.mark.slow
def test_cli_certify_json(capsys, tmp_path):
    code = main(["certify", "--preset", "paper-triangle", "--json", "--out", str(tmp_path)])
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["certified"] is True
    for key in (
        "preset",
        "n",
        "lambda",
        "sigma",
        "sigma_jacobi",
        "gamma",
        "method",
        "alpha",
        "theorem1",
        "small_gain_margin",
        "position_loop_hinf",
        "crosscheck_ok",
    ):
        assert key in data
    assert data["sigma"]["coords"] == "vehicle"
    assert (tmp_path / "certificate.json").exists() and (tmp_path / "sigma_heatmap.png").exists()


def test_cli_design_json(capsys):
    code = main(["design", "--lam", "-1.2", "--gamma", "2.86", "--json"])
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["crosscheck_ok"]
    assert data["alpha"]["care"] == pytest.approx(0.330965, abs=1e-6)
    assert data["alpha"]["lmi"] == pytest.approx(data["alpha"]["stabilizing"], rel=1e-5)
    assert data["closed_loop_hinf"]["exact"] == pytest.approx(0.653183, abs=1e-6)


def test_cli_design_below_gamma_min_flags_infeasible(capsys):
    assert main(["design", "--lam", "-1.2", "--gamma", "0.3", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["alpha"]["paper"] is None and data["alpha"]["stabilizing"] is None
    assert any("infeasible" in f for f in data["paper_flags"])
    assert data["alpha"]["minimal"] == pytest.approx(1 / 0.3 - 1.2)


@pytest.mark.parametrize(
    "argv",
    [
        ["design", "--lam", "1", "--gamma", "1"],
        ["design", "--lam", "-1", "--gamma", "nan"],
        ["design", "--lam", "-1.2", "--gamma", "0"],
        ["design", "--lam", "x", "--gamma", "1"],
        ["certify", "--preset", "nope"],
        ["design", "--lam", "-1", "--gamma", "1", "--n", "1"],
    ],
)
def test_cli_bad_input_exit_2(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("auv-hinf: error:") and "Traceback" not in err and err.count("\n") == 1


@pytest.mark.parametrize(
    "text, pattern",
    [
        ("[formation]\nn = 1\n", "n must be >= 2"),
        ("[vehicle]\nm11 = -5\n", "missing keys"),
        ("[envelope]\nu = [3, 1]\n", "envelope u is empty"),
        ("[design]\nmethod = 'fast'\n", "design.method"),
        ("[design]\nk1 = 'a'\n", "design.k1 has the wrong type"),
        ("[formation\n", "invalid TOML"),
        ("[extra]\n", "unknown table"),
    ],
)
def test_bad_toml(tmp_path, text, pattern, capsys):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(ValueError, match=pattern):
        load_config(f)
    assert main(["certify", "--config", str(f)]) == 2


@pytest.mark.slow
def test_toml_round_trip(tmp_path):
    f = tmp_path / "remus.toml"
    f.write_text(
        "[vehicle]\npreset = 'remus100'\n[formation]\nn = 4\njacobi = 'orthonormal'\npolygon_radius = 8.0\n"
        "[envelope]\nu = [0.5, 2.0]\nv = [-0.3, 0.3]\nr = [-0.3, 0.3]\n[design]\nk1 = 0.3\n"
    )
    cfg = load_config(f)
    assert cfg.n == 4 and cfg.jacobi == "orthonormal" and cfg.k1 == 0.3
    c = certify(cfg)
    assert c.crosscheck.ok
    # Theorem 1 holds for this envelope, but the file keeps the default mission, the paper's sine,
    # whose ground speed peaks at sqrt(1 + (30 * 0.1)^2) = sqrt(10) m/s, above the envelope's
    # u <= 2 m/s: the reference itself leaves the envelope, so the closed loop cannot be certified.
    assert c.theorem1.all_ok and c.small_gain_margin is not None and c.small_gain_margin > 0
    assert mission_reference(cfg).bounds().speed_max == pytest.approx(np.sqrt(10.0))
    assert cfg.envelope.u[1] == 2.0
    assert not c.certified
    assert len(c.reasons) == 1 and "every vehicle (inertial frame" in c.reasons[0]
    assert "upper surge edge" in c.reasons[0] and "smallest turn radius that fits" in c.reasons[0]
    assert c.closed_loop is not None and c.closed_loop.certificate is None
    # the CLI verdict is the API verdict: not certified, exit code 1
    assert main(["certify", "--config", str(f)]) == 1


@pytest.mark.slow
def test_large_fleet_caps_the_crosscheck_size():
    """The cross-check size is capped (every channel is identical), and the Jacobi upper bound is cond(Phi) sigma."""
    from auv_hinf.certificate.parts.theorem1 import CROSSCHECK_MAX_N
    from auv_hinf.config.settings import config_from_dict

    cfg = config_from_dict({"formation": {"n": 40, "polygon_radius": 60.0}})
    c = certify(cfg)
    assert c.certified and c.crosscheck.n == CROSSCHECK_MAX_N
    assert c.sigma_jacobi.upper == pytest.approx(cfg.transform.cond * c.sigma.upper, rel=1e-9)


@pytest.mark.slow
def test_certify_json_closed_loop_keys_and_thrust_bound(capsys):
    """The closed_loop object has the documented keys, and its thrust bound covers a simulated run."""
    from auv_hinf.certificate.run_plan import plan_run
    from auv_hinf.simulation.engine import simulate

    assert main(["certify", "--preset", "paper-triangle", "--json"]) == 0
    loop = json.loads(capsys.readouterr().out)["closed_loop"]
    for key in (
        "decay_rate",
        "region",
        "reference_inside_envelope",
        "max_force",
        "max_moment",
        "covers_shaped_start",
        "method",
    ):
        assert key in loop
    assert set(loop["region"]) == {"position_error", "velocity_error", "heading_error", "yaw_rate_error"}
    assert isinstance(loop["method"], str) and loop["method"]
    plan = plan_run(preset_config("paper-triangle"), horizon=60.0)
    res = simulate(plan.scenario)
    assert np.abs(res.forces[..., :2]).max() <= loop["max_force"]
    assert np.abs(res.forces[..., 2]).max() <= loop["max_moment"]


SLOW_HEADING = {
    "vehicle": {
        "m11": 200.0,
        "m22": 200.0,
        "m33": 10.0,
        "d11_lin": 70.0,
        "d11_quad": 100.0,
        "d22_lin": 100.0,
        "d22_quad": 200.0,
        "d33_lin": 1000.0,
        "d33_quad": 0.0,
    },
    "formation": {"n": 2, "offsets": [[0.0, 0.0], [0.0, -10.0]]},
    "envelope": {"u": [0.0, 3.5], "v": [-1.5, 1.5], "r": [-0.5, 0.5]},
    "design": {"k1": 0.5, "heading_poles": [-0.5, -1.0]},
    "reference": {"kind": "circle", "speed": 1.0, "radius": 20.0},
    "simulation": {
        "horizon": 40.0,
        "start": "paper",
        "initial": [[0.0, -15.0, 0.0, 1.0, 0.0, 0.26], [0.0, -25.0, 0.0, 1.0, 0.0, 0.26]],
    },
}


@pytest.mark.slow
def test_moment_bound_with_negative_k2psi_covers_the_run():
    """Slow heading poles give k2psi < 0; the yaw-moment bound must still dominate the moment the run needs
    (regression: the bound once added k2psi * E_r without abs and came out negative)."""
    from auv_hinf.certificate.run_plan import plan_run, run_report
    from auv_hinf.config.settings import config_from_dict
    from auv_hinf.simulation.engine import simulate

    cfg = config_from_dict(SLOW_HEADING)
    plan = plan_run(cfg)
    assert plan.design.require_gains().k_psi[1] < 0
    report = run_report(plan, simulate(plan.scenario))
    assert plan.covered and report["stayed_in_envelope"]
    assert report["certified_thrust"]["moment"] >= report["max_moment"] > 0
    assert report["certified_thrust"]["force_x"] >= report["max_force"]
    # an actuator limit below the moment the mission needs can never be covered
    tight = replace(cfg, actuators=Actuators(1e5, 1e5, 5.0))
    assert not plan_run(tight).covered
    cert = certify(tight)
    assert not cert.certified and any("yaw moment" in r for r in cert.reasons)


def test_narrow_heading_range_is_not_certified():
    """The closed-loop certificate bounds u, v and r, not psi: a narrower heading range is refused, not ignored."""
    cfg = replace(
        preset_config("paper-triangle"), envelope=Envelope(u=(0.0, 3.5), v=(-1.5, 1.5), r=(-0.5, 0.5), psi=(0.0, 0.01))
    )
    c = certify(cfg)
    assert not c.certified and any("psi" in r for r in c.reasons)


@pytest.mark.parametrize(
    "argv",
    [["design", "--lam=-1e308", "--gamma", "1e-308"], ["design", "--lam", "-2.1", "--gamma", "0.5", "--k1", "1e308"]],
)
def test_extreme_numbers_are_bad_input(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err
