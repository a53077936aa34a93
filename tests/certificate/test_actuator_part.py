"""Actuator limits: the certified force, the start region shrunk to fit, verdicts and the CLI."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from auv_hinf.actuation.limits import Actuators, RudderActuation, actuator_shortfall, vehicle_actuators
from auv_hinf.actuation.thrust import thrust_bounds
from auv_hinf.certificate import assembly as certificate_module
from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.document import json_safe
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.run_plan import plan_run, with_start
from auv_hinf.certificate.text import certificate_text
from auv_hinf.cli.main import main
from auv_hinf.closed_loop.actuator_fit import actuator_fraction, mission_thrust, within_actuators
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import (
    UncertaintyConfig,
    config_from_dict,
    load_config,
    with_settings,
)
from auv_hinf.exceptions import ConfigError, DesignError
from auv_hinf.mission.margins import ErrorBounds, inflate_envelope
from auv_hinf.models.vehicle import preset as vehicle_preset
from auv_hinf.robust.box import PARAMETERS
from auv_hinf.simulation.engine import simulate_batch
from auv_hinf.simulation.scenario import ScenarioBatch
from tests.helpers import certificate_of, preset_certificate, starts_from_errors

#: Limits between what the paper triangle's mission needs at zero error and what its
#: envelope-limited start region needs, so the region must shrink (N, N, N m).
TRIANGLE_LIMITS = Actuators(1400.0, 800.0, 300.0)


def test_actuators_validate_and_report():
    act = Actuators(10.0, 5.0, 2.0)
    assert act.admits((10.0, 5.0, 2.0)) and not act.admits((10.0, 5.1, 1.0))
    assert act.binding((5.0, 10.0, 1.0)) == ("force_y", 2.0)
    applied, active = act.saturate(np.array([[20.0, -1.0, 0.5], [1.0, 1.0, 1.0]]))
    np.testing.assert_array_equal(applied, [[10.0, -1.0, 0.5], [1.0, 1.0, 1.0]])
    assert active.tolist() == [True, False]
    assert "sway force" in actuator_shortfall(act, (1.0, 50.0, 1.0)) and "10x" in actuator_shortfall(act, (1, 50, 1))
    with pytest.raises(Exception, match="tau_y"):
        Actuators(1.0, 0.0, 1.0)


@pytest.mark.slow
def test_region_shrinks_to_the_largest_fraction_that_fits():
    cfg = preset_config("paper-triangle")
    point = design_point(cfg)
    free = closed_loop_for(point)
    gains = point.require_gains()
    env = cfg.envelope
    kappa = actuator_fraction(free, cfg.vehicle, env, point.tube, gains, TRIANGLE_LIMITS)
    assert kappa is not None and 0.0 < kappa < 1.0
    fitted = within_actuators(free, cfg.vehicle, env, point.tube, gains, TRIANGLE_LIMITS)
    assert fitted is not None and TRIANGLE_LIMITS.admits(fitted.thrust.as_tuple())
    np.testing.assert_allclose(fitted.region.region.as_array(), kappa * free.region.region.as_array(), rtol=1e-12)
    assert fitted.region.margins.ok and fitted.rate == free.rate
    # kappa is the supremum: a region 1e-4 larger needs more than some limit
    b = free.region.bounds
    k = kappa * (1.0 + 1e-4)
    bigger = ErrorBounds(k * b.position, k * b.velocity, k * b.heading, k * b.yaw_rate)
    over = thrust_bounds(cfg.vehicle, inflate_envelope(env), point.tube, bigger, gains)
    assert not TRIANGLE_LIMITS.admits(over.as_tuple())
    # below what the mission needs at zero error nothing fits, and the design says why
    need = mission_thrust(cfg.vehicle, env, point.tube, gains).as_tuple()
    tight = Actuators(need[0] * 0.99, 1e4, 1e4)
    assert within_actuators(free, cfg.vehicle, env, point.tube, gains, tight) is None
    with pytest.raises(DesignError, match="surge force"):
        closed_loop_for(design_point(replace(cfg, actuators=tight)))


@pytest.mark.slow
def test_starts_in_the_fitted_region_never_command_more_than_the_limits():
    cfg = replace(preset_config("paper-triangle"), actuators=TRIANGLE_LIMITS)
    point = design_point(cfg)
    cert = closed_loop_for(point)
    fleet = point.fleet()
    rng = np.random.default_rng(20)
    r = cert.region.region
    count = 24
    # random starts inside the simultaneous region, a quarter of them on its corners
    frac = rng.uniform(-1.0, 1.0, (count, cfg.n, 6))
    frac[: count // 4] = np.sign(frac[: count // 4])
    scale = np.array([r.position, r.position, r.velocity, r.velocity, r.heading, r.yaw_rate]) / np.sqrt(
        [2, 2, 2, 2, 1, 1]
    )
    starts = starts_from_errors(fleet, frac * scale)
    plan = plan_run(with_start(cfg, starts[0]), start="paper", horizon=60.0, samples=601)
    assert plan.covered, plan.notes
    runs = simulate_batch(ScenarioBatch([replace(plan.scenario, initial=x) for x in starts]), systems="scenario")
    peaks = np.array([run.commanded_peak for run in runs])
    limit = np.array(TRIANGLE_LIMITS.limits())
    assert np.all(peaks <= np.array(cert.thrust.as_tuple())) and np.all(peaks <= limit)
    assert not any(run.saturated.any() for run in runs)
    # how tight the bound is: certified over the worst sampled run (measured 1.1, 3.2 and 1.9 on
    # this sample; 24 starts only bound the true worst case from below)
    ratio = np.array(cert.thrust.as_tuple()) / peaks.max(axis=0)
    assert ratio.min() >= 1.0 and ratio.max() <= 4.0, ratio


def test_old_thrust_limit_key_is_refused_with_the_new_name():
    with pytest.raises(ConfigError, match=r"\[actuators\]"):
        config_from_dict({"simulation": {"thrust_limit": [1.0, 1.0, 1.0]}})
    with pytest.raises(ConfigError, match="give all of tau_x, tau_y, tau_psi"):
        config_from_dict({"actuators": {"tau_x": 1.0}})
    cfg = config_from_dict({"vehicle": {"preset": "bluerov2-heavy"}, "actuators": {"preset": "bluerov2-heavy"}})
    assert cfg.actuators is not None and cfg.actuators.kind == "fully-actuated"
    again = config_from_dict(cfg.to_toml_dict())
    assert again.actuators == cfg.actuators


@pytest.mark.parametrize(
    ("hull", "act", "hint"),
    [
        ("remus100", "nps-auv2", "give actuators.preset = 'remus100'"),
        ("bluerov2-heavy", "remus100", "give actuators.preset = 'bluerov2-heavy'"),
        ("paper2011", "bluerov2-heavy", "it has no published actuation"),
    ],
)
def test_another_vehicles_actuator_preset_is_refused(hull: str, act: str, hint: str):
    with pytest.raises(ConfigError, match=f"vehicle.preset = '{hull}'.*{re.escape(hint)}"):
        config_from_dict({"vehicle": {"preset": hull}, "actuators": {"preset": act}})
    # a custom hull may borrow a preset's actuation (a perturbed REMUS with the REMUS rudder, say)
    custom = {k: getattr(vehicle_preset(hull), k) for k in PARAMETERS}
    cfg = config_from_dict({"vehicle": custom, "actuators": {"preset": act}})
    assert cfg.actuators == vehicle_actuators(act)


@pytest.fixture(scope="module")
def remus_rudder() -> Certificate:
    """``remus-line``: three REMUS 100 with their propeller and rudder (``[actuators] preset = "remus100"``)."""
    cfg = preset_config("remus-line")
    assert cfg.actuators == vehicle_actuators("remus100")
    return certificate_of(cfg)


@pytest.mark.slow
def test_remus_with_its_rudder_refuses_the_fully_actuated_law_naming_sway(remus_rudder, tmp_path):
    cert = remus_rudder
    rudder = cert.config.actuators
    assert isinstance(rudder, RudderActuation) and not cert.certified
    act = cert.to_dict()["actuators"]
    assert act["kind"] == "underactuated" and act["certified"] is False
    assert act["limits"] == {"force_x": 67.0, "rudder": math.radians(13.6)}
    peak = act["certified_peak"]
    assert peak["rudder"] is None and peak["force_y"] > 0.0  # the law needs a sway force: none is deliverable
    (why,) = [r for r in cert.findings if r.part == "actuators"]
    assert why.kind == "unsupported" and why.channel == "force_y" and why.value == peak["force_y"] and why.limit == 0.0
    assert "sway actuator" in why.message and "only together" in why.message
    assert '[guidance] kind = "ilos"' in why.message  # the law that runs on a rudder, as a setting that exists
    # what the rudder gives at the envelope's top speed, in closed form: Y = Y_uu_delta u^2 delta_max
    top = cert.config.envelope.u[1]
    auth = act["rudder_authority"]
    assert auth["speed"] == top
    assert "force_y" not in auth  # a rudder has no sway force: its side force comes with its moment
    assert auth["side_force"] == pytest.approx(9.64 * top**2 * math.radians(13.6), rel=1e-12)
    assert auth["moment"] == pytest.approx(6.15 * top**2 * math.radians(13.6), rel=1e-12)
    # saved and loaded with its actuator verdict
    path = cert.save(tmp_path / "c.json")
    stored = Certificate.load(path).to_dict()["actuators"]
    assert stored == json.loads(json.dumps(json_safe(cert.to_dict()["actuators"])))


@pytest.mark.slow
def test_cli_remus_rudder_exit_1_naming_sway(remus_rudder, tmp_path, capsys, monkeypatch):
    path = tmp_path / "remus.toml"
    assert main(["init", "--preset", "remus-line", "--out", str(path)]) == 0
    capsys.readouterr()
    # the configuration the CLI reads is the fixture's: reuse its certificate (the API test above
    # computes it) and check what the command line makes of it
    assert load_config(path).actuators == remus_rudder.config.actuators
    monkeypatch.setattr(certificate_module, "certify", lambda cfg, **kw: remus_rudder)
    code = main(["certify", "--config", str(path), "--json"])
    out = capsys.readouterr()
    data = json.loads(out.out)
    assert code == 1 and data["certified"] is False
    assert "sway actuator" in out.err
    assert data["actuators"]["limits"]["rudder"] == math.radians(13.6)
    # simulate refuses the uncertified gains unless asked
    code = main(["simulate", "--config", str(path), "--horizon", "2"])
    err = capsys.readouterr().err
    assert code == 1 and "--uncertified" in err and "rudder cannot make" in err
    code = main(["simulate", "--config", str(path), "--horizon", "2", "--json", "--uncertified"])
    run = json.loads(capsys.readouterr().out)
    assert code == 1 and run["certificate_covers_run"] is False
    assert run["actuator_limits"] == {"force_x": 67.0, "rudder": math.radians(13.6)}
    assert set(run["commanded_peak"]) == {"force_x", "force_y", "moment"}
    assert run["saturation_fraction"] > 0.5  # the commanded sway force is never the delivered one
    # and so does a campaign
    code = main(["campaign", "--config", str(path), "--runs", "2", "--horizon", "2", "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert code == 1 and "refusing to run a campaign of gains that no certificate covers" in err
    assert "--uncertified" in err and not (tmp_path / "c" / "runs.parquet").exists()


@pytest.mark.slow
def test_simulate_reports_commanded_peak_before_saturation(capsys):
    code = main(["simulate", "--preset", "paper-triangle", "--horizon", "20", "--json"])
    run = json.loads(capsys.readouterr().out)
    assert code == 0 and run["actuator_limits"] is None and run["saturation_fraction"] == 0.0
    assert run["commanded_peak"]["force_x"] == pytest.approx(run["max_force"], rel=1e-12) or (
        run["commanded_peak"]["force_y"] == pytest.approx(run["max_force"], rel=1e-12)
    )


@pytest.mark.slow
def test_bluerov2_line_answers_and_the_answer_certifies():
    """Not certifiable as declared: the answer is a box scale and a current that, re-run, certify.
    The text names them as the settings a user writes (no "box scale", which is not a key)."""
    cfg = preset_config("bluerov2-line")
    cert = preset_certificate("bluerov2-line")
    act = cert.to_dict()["actuators"]
    (line,) = [x for x in certificate_text(cert.to_dict()).splitlines() if "largest certifiable within" in x]
    assert "[uncertainty] m11 = [" in line and "[disturbance] current_speed = " in line, line
    assert "box scale" not in line.split("(")[0], line
    assert not cert.certified and act["certified"] is False and act["binding_ratio"] > 1.0
    best = act["largest_certifiable"]
    assert 0.0 < best["box_scale"] < 1.0 and 0.0 <= best["current_speed"] <= cfg.disturbance.current_speed
    # the refusal's own line names the values (short decimals, the box rounded inwards), and they are its settings
    (why,) = cert.to_dict()["parts"]["actuators"]["reasons"]
    written = [(x["table"], x["key"], x["value"]) for x in why["settings"]]
    assert {k for _, k, _ in written} == {*best["uncertainty"], "current_speed"}
    assert all(f"{k} = " in why["message"] for _, k, _ in written) and "within the limits:" in why["message"]
    for _, key, value in written:
        if key in best["uncertainty"]:
            lo, hi = best["uncertainty"][key]
            assert lo <= value[0] <= value[1] <= hi and all(len(repr(v)) <= 10 for v in value), (key, value)
    redo = certify(with_settings(cfg, written))
    assert redo.certified, redo.reasons
    peak, limits = redo.to_dict()["actuators"]["certified_peak"], redo.to_dict()["actuators"]["limits"]
    assert all(peak[k] <= limits[k] for k in limits)
    # the key stays in the JSON when nothing binds, with no answer in it
    assert redo.to_dict()["actuators"]["largest_certifiable"] is None


def test_the_thrusters_take_each_certificates_force_box_on_its_own():
    """Two certificates' boxes, one surge-heavy and one sway-heavy, each inside the BlueROV2's thruster
    polytope: the fleet fits, although the box of their elementwise largest (its corners mix one
    certificate's surge with the other's sway) does not; the report still gives that elementwise peak."""
    from auv_hinf.certificate.parts.actuators import check_actuators

    cfg = replace(preset_config("bluerov2-line"), robust=False, uncertainty=UncertaintyConfig(()))
    point = design_point(cfg)
    act = cfg.actuators
    surge, sway = (60.0, 5.0, 1.0), (5.0, 60.0, 1.0)
    assert act.admits(surge) and act.admits(sway) and not act.admits((60.0, 60.0, 1.0))
    got = check_actuators(point, [surge, sway], answers=False)
    assert got.certified and got.certified_peak == (60.0, 60.0, 1.0)
    assert not check_actuators(point, [surge, sway, (60.0, 60.0, 1.0)], answers=False).certified


def test_an_advised_current_is_written_short_and_rounded_down():
    from auv_hinf.certificate.answers import advice

    for found in (0.009228515625, 0.0050634765625000005, 0.1):
        (written,) = [x.value for x in advice({"current_speed": found, "uncertainty": {}}) if x.key == "current_speed"]
        assert written <= found and written == pytest.approx(found, rel=1e-3) and len(repr(written)) <= 8, written


@given(
    st.floats(min_value=0.0, max_value=1.0, allow_nan=False),
    st.floats(min_value=0.0, max_value=1.0, allow_nan=False),
    st.floats(min_value=1e-6, max_value=1.0),
)
def test_an_advised_box_is_written_short_and_inside_the_certified_one(a, b, scale):
    from auv_hinf.certificate.answers import inwards as _inwards

    lo, hi = 1.0 - scale * a, 1.0 + scale * b  # a box scaled by a bisection, about the model (1)
    got = _inwards([lo, hi])
    assert lo <= got[0] <= 1.0 <= got[1] <= hi  # inside what was certified: a re-run covers it
    # 4 significant digits of each offset from the model (an offset under 1e-9 is the model itself)
    assert 1.0 - got[0] >= (1.0 - lo) * (1.0 - 1e-3) - 1e-9 and got[1] - 1.0 >= (hi - 1.0) * (1.0 - 1e-3) - 1e-9
    assert all(len(repr(x)) <= 14 for x in got)  # a short decimal, not a bisection's 17 digits
