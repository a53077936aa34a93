"""The certified minimum distance between vehicles: sound against simulations and dense evaluation, refused
when the slots are too close, reported in the JSON, the text and the stored file."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from auv_hinf.certificate.assembly import Certificate, certify, load_certificate
from auv_hinf.certificate.parts.robust import figures_kept_inside, run_kept_inside, run_settings
from auv_hinf.certificate.reason import Reason, Setting
from auv_hinf.certificate.run_plan import plan_run, with_start
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.config.schema import DEFAULT_MIN_SEPARATION
from auv_hinf.config.settings import config_from_dict, with_settings
from auv_hinf.mission.fleet import H0_SUP, H1_SUP, FleetReference, shaped_start
from auv_hinf.mission.paths import CircleReference, SineReference
from auv_hinf.mission.separation import PAIRWISE_MAX_N, closest_approach, slot_separation
from auv_hinf.simulation.engine import simulate
from tests.helpers import certificate_of, fully_actuated, preset_certificate, starts_from_errors

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
FORMATION_KEYS = {"min_separation", "min_separation_certified", "closest_pair", "slot_distance", "position_bound"}


def _dense_min(fleet: FleetReference, horizon: float, count: int = 40001) -> tuple[float, tuple[int, int]]:
    """Brute force: the smallest desired distance of any pair on a dense grid (m), and the pair."""
    p = fleet.kinematics(np.linspace(0.0, horizon, count))[0][0]
    iu, ju = np.triu_indices(p.shape[1], 1)
    d = np.linalg.norm(p[:, iu] - p[:, ju], axis=-1).min(axis=0)
    k = int(np.argmin(d))
    return float(d[k]), (int(iu[k]), int(ju[k]))


@pytest.mark.parametrize("frame", ["inertial", "path"])
def test_the_closed_form_is_the_dense_slot_distance_without_shaping(frame):
    rng = np.random.default_rng(4)
    offsets = rng.uniform(-20.0, 20.0, (7, 2))
    fleet = FleetReference(CircleReference(speed=1.0, radius=60.0), offsets, None, frame)
    sep = slot_separation(fleet)
    dense, pair = _dense_min(fleet, 400.0, 4001)
    assert sep.distance == pytest.approx(dense, rel=1e-9) and sep.pair == pair and sep.shaping == 0.0


@pytest.mark.parametrize("frame", ["inertial", "path"])
def test_a_shaped_start_is_bounded_below_its_dense_minimum(frame):
    rng = np.random.default_rng(7)
    mission = SineReference()
    offsets = np.array([[0.0, 0.0], [6.0, 0.0], [0.0, 8.0], [-7.0, -5.0]])
    for _ in range(3):
        slots = FleetReference(mission, offsets, None, frame).motion(0.0).p
        initial = np.column_stack(
            [slots + rng.normal(0.0, 4.0, (4, 2)), rng.uniform(-0.5, 0.5, 4), np.ones(4), np.zeros(4), np.zeros(4)]
        )
        fleet = shaped_start(mission, offsets, initial, 30.0, turn_time=10.0, frame=frame)
        sep = slot_separation(fleet)
        dense, _ = _dense_min(fleet, 31.0)
        assert sep.distance <= dense + 1e-12
        assert sep.distance >= dense - 0.05  # the grid refinement is tight, not only sound
        # the triangle bound with the sups of |h0|, |h1| is sound too, and never above the refined one
        sh = fleet.shaping
        iu, ju = np.triu_indices(4, 1)
        triangle = (
            np.linalg.norm(offsets[iu] - offsets[ju], axis=-1)
            - H0_SUP[0] * np.linalg.norm(sh.dp[iu] - sh.dp[ju], axis=-1)
            - sh.th * H1_SUP[0] * np.linalg.norm(sh.dv[iu] - sh.dv[ju], axis=-1)
        ).min()
        assert triangle <= sep.distance <= dense + 1e-12
        i, j = sep.pair
        assert sep.slot_distance == pytest.approx(float(np.linalg.norm(offsets[i] - offsets[j])))


@pytest.mark.parametrize("n", [5, PAIRWISE_MAX_N + 36])
def test_the_measured_closest_approach_is_the_brute_force_one(n):
    rng = np.random.default_rng(n)
    p = rng.uniform(-50.0, 50.0, (1, n, 2)) + np.cumsum(rng.normal(0.0, 0.3, (120, n, 2)), axis=0)
    c = closest_approach(p)
    iu, ju = np.triu_indices(n, 1)
    d = np.linalg.norm(p[:, iu] - p[:, ju], axis=-1)
    k, m = np.unravel_index(int(np.argmin(d)), d.shape)
    assert c.distance == pytest.approx(float(d[k, m]), rel=1e-12)
    assert c.pair == (int(iu[m]), int(ju[m])) and c.sample == int(k)


def test_the_default_is_documented_once():
    assert preset_config("paper-hexagon").min_separation == DEFAULT_MIN_SEPARATION == 2.0
    assert "min_separation" in Path("docs/config.md").read_text(encoding="utf-8")


def test_json_keys_and_text():
    cert = preset_certificate("paper-hexagon")
    f = cert.to_dict()["formation"]
    assert FORMATION_KEYS <= set(f)
    assert f["min_separation"] == DEFAULT_MIN_SEPARATION and len(f["closest_pair"]) == 2
    assert f["min_separation_certified"] == pytest.approx(f["slot_distance"] - 2.0 * f["position_bound"])
    assert f["min_separation_certified"] >= f["min_separation"] and cert.certified
    assert cert.to_dict()["parts"]["separation"] == {"ok": True, "applies": True, "reasons": [], "key": "formation"}
    assert "min separation" in cert.summary() and " m certified (required 2 m" in cert.summary()


@pytest.mark.slow
def test_slots_closer_than_twice_the_bound_plus_the_requirement_are_refused_with_the_pair():
    """Vehicles 2 and 3 of a line 1.5 m apart (the others 10 m): refused, the pair and the distances named."""
    data = preset_config("paper-hexagon").to_toml_dict()
    data["formation"] = {"n": 3, "offsets": [[0.0, 0.0], [10.0, 0.0], [11.5, 0.0]]}
    data["simulation"].pop("initial", None)
    cert = certify(config_from_dict(data, "close-pair"))
    v = cert.verdict("separation")
    f = v.figures
    assert f["closest_pair"] == [1, 2] and f["slot_distance"] == pytest.approx(1.5)
    assert f["slot_distance"] < 2.0 * f["position_bound"] + f["min_separation"]
    assert not v.ok and not cert.certified and [r.part for r in cert.findings] == ["separation"]
    (why,) = v.reasons
    assert why.kind == "envelope" and why.vehicle == 1 and why.limit == 2.0
    assert why.value == pytest.approx(f["min_separation_certified"])
    assert "vehicles 2 and 3" in why.message and "1.5 m apart" in why.message and "min_separation = 2 m" in why.message
    setting, *removed = why.settings
    assert setting.key == "shape" and {r.key for r in removed} == {"offsets", "polygon_radius"}
    assert all(r.value is None for r in removed) and "[formation] shape = " in why.message
    # the advice, written back into the file's form (offsets here), certifies the separation
    again = certify(with_settings(cert.config, [(x.table, x.key, x.value) for x in why.settings]))
    assert again.verdict("separation").ok, again.reasons
    # the same slots with a smaller requirement hold
    assert certify(replace(cert.config, min_separation=1.0)).verdict("separation").ok


@pytest.mark.slow
def test_a_run_in_a_current_above_the_declared_bound_is_refused_for_it_and_the_advice_certifies():
    """The configured run's current is 20 % above [disturbance] current_speed: the refusal names
    the current (not the start, which is on the slots) and its setting, re-run, certifies."""
    box = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")
    bound = 0.1
    data = {
        "vehicle": {"preset": "paper2011"},
        "formation": {"n": 6, "polygon_radius": 15.0},
        "design": {"robust": True},
        "reference": {"kind": "sine", "speed": 1.0, "amplitude": 30.0, "omega": 0.1},
        "uncertainty": {k: [0.95, 1.05] for k in box},
        "disturbance": {"current_speed": bound},
        "simulation": {"current": [0.96 * bound, -0.72 * bound]},  # |c| = 1.2 x the bound
    }
    cert = certify(config_from_dict(data, "fast-current"))
    assert not cert.certified
    (why,) = cert.verdict("separation").reasons
    assert "current" in why.message and "exceeds the declared bound" in why.message
    assert "nearer its slots" not in why.message
    (setting,) = why.settings
    assert (setting.table, setting.key) == ("simulation", "current")
    assert bound * 0.999 <= float(np.hypot(*setting.value)) <= bound
    again = certify(with_settings(cert.config, [(setting.table, setting.key, setting.value)]))
    assert again.certified, again.reasons


def test_a_stored_certificate_round_trips_and_older_records_load(tmp_path):
    cert = preset_certificate("paper-hexagon")
    loaded = Certificate.load(cert.save(tmp_path / "c.json"))
    assert loaded.to_dict()["formation"] == json.loads(json.dumps(cert.to_dict()["formation"]))
    assert loaded.verdict("separation").ok and loaded.summary() == cert.summary()
    for path in sorted(FIXTURES.glob("certificate-*.json")):
        old = load_certificate(path)
        assert old.verdict("separation") is None and "formation" not in old.to_dict()
        assert "min separation" not in old.summary()


@pytest.mark.slow
def test_certify_json_has_the_formation_object(capsys):
    assert main(["certify", "--preset", "paper-hexagon", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert FORMATION_KEYS <= set(out["formation"])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-triangle", "paper-hexagon", "remus-survey", "remus-line"])
def test_the_certified_separation_is_below_every_simulated_one(name):
    # the REMUS presets declare a rudder, on which the law is refused: the same fleet with a sway actuator
    cert = certificate_of(fully_actuated(name)) if name.startswith("remus") else preset_certificate(name)
    certified = cert.to_dict()["formation"]["min_separation_certified"]
    assert cert.certified and certified is not None
    plan = plan_run(cert.config)
    assert plan.covered
    run = simulate(plan.scenario).summary()
    assert certified <= run["min_separation"]


@pytest.mark.slow
def test_random_starts_inside_the_certified_set_keep_the_certified_separation():
    cfg = preset_config("paper-hexagon")
    rng = np.random.default_rng(11)
    fleet = certify(cfg).verdict("closed_loop").detail.shaped.reference.unshaped()
    checked = 0
    for _ in range(3):
        errors = np.concatenate([rng.normal(0.0, 0.3, (6, 2)), rng.normal(0.0, 0.05, (6, 4))], axis=1)
        start = with_start(cfg, starts_from_errors(fleet, errors))
        cert = certify(start)
        certified = cert.to_dict()["formation"]["min_separation_certified"]
        plan = plan_run(start)
        if certified is None or not plan.covered:
            continue
        checked += 1
        assert certified <= simulate(plan.scenario).summary()["min_separation"]
    assert checked >= 1


def test_advice_below_the_configured_run_carries_the_runs_values():
    """Advice that lowers the declared current below the run's, or moves a box edge past the run's
    plant, adds the [simulation] values that keep the run inside; advice that leaves it inside adds none."""
    data = fully_actuated("remus-line").to_toml_dict()
    data["simulation"]["current"] = [0.12, -0.09]  # 0.15 m/s
    data["simulation"]["plant"] = {"m11": 1.04, "d22_quad": 0.9}
    cfg = config_from_dict(data, "run")
    lower = (Setting("disturbance", "current_speed", 0.05), Setting("uncertainty", "m11", [0.98, 1.02]))
    extra = run_settings(cfg, lower)
    (cur,) = [x for x in extra if x.key == "current"]
    assert cur.table == "simulation" and 0.0499 <= float(np.hypot(*cur.value)) <= 0.05
    assert np.sign(cur.value).tolist() == [1.0, -1.0]
    assert [(x.table, x.key, x.value) for x in extra if x.key != "current"] == [("simulation.plant", "m11", 1.02)]
    assert run_settings(cfg, (Setting("disturbance", "current_speed", 0.2),)) == ()
    # a removed range leaves the model's coefficient: the run's multiplier goes back to 1
    assert run_settings(cfg, (Setting("uncertainty", "d22_quad", None),)) == (
        Setting("simulation.plant", "d22_quad", 1.0),
    )
    (still,) = run_settings(cfg, (Setting("disturbance", "current_speed", 0.0),))
    assert still.value == [0.0, 0.0] and all(math.copysign(1.0, x) > 0 for x in still.value)  # no -0.0
    why = run_kept_inside(cfg, Reason("robust", "not_covered", "shrink", settings=lower))
    assert why.settings[:2] == lower and len(why.settings) == 4 and "keeps the configured run inside" in why.message
    figures = {"advice": [{"settings": [x.to_dict() for x in lower], "scale": 0.5}], "other": 1}
    kept = figures_kept_inside(cfg, figures)
    assert len(kept["advice"][0]["settings"]) == 4 and kept["other"] == 1 and len(figures["advice"][0]["settings"]) == 2


def test_a_spread_the_format_refuses_is_not_advised():
    """A required separation no formation within the format's coordinates reaches is refused without settings.

    The advice of a refusal is written back into the file; a spread beyond ``MAX_COORDINATE`` (found by
    an adversarial review: a shape of -1.5e6 m) would be refused as bad input on re-run.
    """
    line = {"offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, 30.0]], "n": 3, "frame": "inertial"}
    doc = preset_config("remus-transit-ilos").to_toml_dict()
    cfg = config_from_dict({**doc, "formation": {**line, "min_separation": 1e6}, "simulation": {"horizon": 10.0}})
    cert = certify(cfg)
    (why,) = [r for r in cert.findings if r.part == "separation"]
    assert not cert.certified and why.settings == () and "polygon_radius, offsets or shape" in why.message
    # a reachable requirement still gets its re-runnable spread, within the format
    near = certify(with_settings(cfg, [("formation", "min_separation", 40.0)]))
    (fix,) = [r for r in near.findings if r.part == "separation"]
    again = with_settings(near.config, [(x.table, x.key, x.value) for x in fix.settings])
    assert fix.settings and certify(again).certified


def test_a_start_in_a_current_outside_the_certified_set_is_refused_by_the_robust_part():
    """Without ``[simulation] initial`` the vehicles start on their slots at the mission's velocity through
    the water: every current up to the declared bound is a velocity error at the start. When the start set
    does not hold it in all of them, the robust part refuses it (a smaller configured current was the
    answer before, which left runs in the declared currents uncovered)."""
    data = {
        "vehicle": {"preset": "paper2011"},
        "formation": {"n": 5, "polygon_radius": 15.0, "min_separation": 1.0},
        "envelope": {"u": [0.0, 3.5], "v": [-1.5, 1.5], "r": [-0.5, 0.5]},
        "design": {"robust": True},
        "reference": {"kind": "sine", "speed": 1.5, "amplitude": 30.0, "omega": 0.1},
        "simulation": {"current": [0.05, 0.05]},
        "disturbance": {"current_speed": 0.1},
        "actuators": {"tau_x": 2000.0, "tau_y": 800.0, "tau_psi": 600.0},
    }
    cfg = config_from_dict(data)
    cert = certify(cfg)
    assert not cert.certified and not cert.verdict("robust").ok
    [why] = [r for r in cert.findings if r.part == "robust"]
    assert why.kind == "start" and "velocity error at t = 0" in why.message
    assert 0.0 < why.limit < 0.1
    # the robust design's start set shrinks with the declared current here: no smaller one is told, and
    # none is claimed (an answer, when given, certifies on re-run)
    written = [(s.table, s.key, s.value) for s in why.settings]
    if written:
        assert certify(with_settings(cfg, written)).certified
    else:
        assert "no smaller declared current tried certifies it" in why.message


@pytest.mark.slow
def test_a_shaped_start_that_brings_two_vehicles_too_close_is_refused_by_simulate_and_answered_with_the_slots(
    capsys, tmp_path
):
    """paper-triangle's shaped start from the paper's initial positions passes vehicles 2 and 3 about 1.1 m
    apart. With ``min_separation = 1.5`` certify refuses it, and so do simulate and campaign (not
    "covered" with a measured 1.1 m); the answer is to start on the slots, not to spread the formation
    (spreading moves the crossing paths little), and it certifies when re-run."""
    cfg = with_settings(preset_config("paper-triangle"), [("formation", "min_separation", 1.5)])
    cert = certify(cfg)
    assert not cert.certified
    (why,) = cert.verdict("separation").reasons
    assert "shaped start" in why.message and "spread" not in why.message
    (setting,) = why.settings
    assert (setting.table, setting.key, setting.value) == ("simulation", "initial", None)
    plan = plan_run(cfg)
    assert plan.uncertified_gains() is not None and "1.5 m" in plan.uncertified_gains()
    run = simulate(plan.scenario)
    assert closest_approach(run.states[..., :2]).distance < 1.5  # the refusal is right: they do come closer
    path = tmp_path / "close.toml"
    assert main(["init", "--preset", "paper-triangle", "--out", str(path)]) == 0
    path.write_text(path.read_text().replace("min_separation = 1.0", "min_separation = 1.5"))
    capsys.readouterr()
    assert main(["simulate", "--config", str(path)]) == 1
    assert "refusing to simulate" in capsys.readouterr().err
    again = certify(with_settings(cfg, [(setting.table, setting.key, setting.value)]))
    assert again.certified, again.reasons
