"""The ILOS cascade's certificate: sound against the simulated cascade, and its answers re-run.

Properties asserted:

* on plants at the box's vertices and interior, in currents at the bound in several directions,
  every one of the seven states of the certificate, computed from the simulated cascade at every
  sample, stays within the certified box; the commanded thrust and rudder within their bounds;
* the certified start bounds the states of the configured start in every current;
* a refused fleet's advised current (or box scale) certifies when re-run;
* what the certificate does not cover is refused with its reason: plain LOS, a varying delay, a
  rudder too small for the commands;
* ``certify --json`` and ``simulate --json`` carry the interface keys.
"""

from __future__ import annotations

import json
from dataclasses import replace
from itertools import product

import numpy as np
import pytest

from auv_hinf.campaign.guidance import run_guidance_campaign
from auv_hinf.cascade.certificate import STATES, cascade_states, start_states
from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import design_point, raw_fleet
from auv_hinf.certificate.parts.guidance import (
    cascade_problem,
    covers_run,
    fleet_refusal,
    guidance_certificate,
    guidance_summary,
    plant_multipliers,
)
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import config_from_dict, with_settings
from auv_hinf.guidance.law import SlotMotion
from auv_hinf.guidance.simulation import simulate_guidance, slot_motion
from auv_hinf.robust.box import PARAMETERS
from tests.helpers import to_toml

#: Three REMUS 100 in line abreast on a straight transit: a fleet the certificate covers.
TRANSIT = {
    "vehicle": {"preset": "remus100"},
    "formation": {"n": 3, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, -15.0]]},
    "reference": {"kind": "line", "speed": 1.5},
    "actuators": {"preset": "remus100"},
    "guidance": {"kind": "ilos"},
    "uncertainty": {
        "m11": [0.97, 1.03],
        "m22": [0.97, 1.03],
        "m33": [0.97, 1.03],
        "d11_quad": [0.8, 1.2],
        "d22_lin": [0.8, 1.2],
        "d22_quad": [0.8, 1.2],
    },
    "disturbance": {"current_speed": 0.04},
    "simulation": {"horizon": 200.0, "current": [0.0, 0.04]},
}


def transit(**tables: dict) -> object:
    """The transit fleet with some tables replaced."""
    return config_from_dict({**TRANSIT, **tables}, "transit")


def _states_along(cfg, run, current) -> np.ndarray:
    """The certificate's seven states of every vehicle at every sample of ``run``, shape (T, N, 7)."""
    summary = guidance_summary(cfg)
    slots = slot_motion(raw_fleet(cfg), run.t)
    out = []
    for k in range(run.t.size):
        slot = SlotMotion(p=slots.p[k], v=slots.v[k], a=slots.a[k])
        out.append(cascade_states(summary.problem, run.states[k], run.integral[k], slot, np.asarray(current)))
    return np.stack(out)


@pytest.mark.slow
def test_every_state_of_the_simulated_cascade_stays_in_the_certified_box():
    cfg = transit()
    summary = guidance_summary(cfg)
    assert summary.holds, summary.reason
    cert, problem = summary.certificate, summary.problem
    box = cert.errors[:7]
    lo, hi = np.asarray(problem.plant.box.lo), np.asarray(problem.plant.box.hi)
    declared = [k for k in range(9) if lo[k] < 1.0 or hi[k] > 1.0]
    rng = np.random.default_rng(7)
    runs = []
    for corner in list(product((0, 1), repeat=len(declared)))[::9]:  # every ninth vertex: 8 of 64
        m = np.ones(9)
        m[declared] = np.where(np.array(corner) == 1, hi[declared], lo[declared])
        runs.append(m)
    runs += [lo + rng.random(9) * (hi - lo) for _ in range(2)]
    worst = np.zeros(7)
    peaks = np.zeros(2)
    for i, m in enumerate(runs):
        angle = 2.0 * np.pi * i / len(runs)
        current = problem.plant.current * np.array([np.cos(angle), np.sin(angle)])
        plant = cfg.vehicle.__class__(**{n: getattr(cfg.vehicle, n) * m[k] for k, n in enumerate(PARAMETERS)})
        run = simulate_guidance(cfg.guidance, plant, cfg.vehicle, cfg.actuators, raw_fleet(cfg), 200.0, tuple(current))
        worst = np.maximum(worst, np.abs(_states_along(cfg, run, current)).max(axis=(0, 1)))
        peaks = np.maximum(peaks, [np.abs(run.thrust_cmd).max(), np.abs(run.rudder_cmd).max()])
    for name, w, b in zip(STATES, worst, box, strict=True):
        assert w <= b, f"{name}: simulated {w:.4g} above the certified {b:.4g}"
    assert peaks[0] <= cert.actuation.thrust and peaks[1] <= cert.actuation.rudder
    assert peaks[0] <= cfg.actuators.tau_x and peaks[1] <= cfg.actuators.rudder_max
    # the bounds are not vacuous: the along-track error (the surge drag's spread) reaches a fifth of its bound
    assert worst[0] >= 0.2 * box[0]


def test_the_certified_start_bounds_the_start_in_every_current():
    cfg = transit(
        simulation={
            "horizon": 50.0,
            "initial": [
                [0.3, 0.2, 0.05, 1.5, 0.0, 0.0],
                [0.0, 14.8, -0.02, 1.4, 0.01, 0.0],
                [0.1, -15.0, 0.0, 1.55, 0.0, 0.01],
            ],
        }
    )
    problem = cascade_problem(cfg, design_point(cfg))
    slots = slot_motion(raw_fleet(cfg), np.array([0.0]))
    slot = SlotMotion(p=slots.p[0], v=slots.v[0], a=slots.a[0])
    initial = np.asarray(cfg.simulation.initial)
    bound = np.asarray(problem.start)
    for angle in np.linspace(0.0, 2.0 * np.pi, 13):
        current = problem.plant.current * np.array([np.cos(angle), np.sin(angle)])
        exact = start_states(problem, initial, slot, current)
        assert np.all(exact <= bound + 1e-12), (angle, exact, bound)


@pytest.mark.slow
def test_a_refused_current_is_answered_with_one_that_certifies_on_re_run():
    cfg = transit(disturbance={"current_speed": 0.3})
    data = certify(cfg).to_dict()
    assert data["certified"] is False and data["guidance"]["certified"] is False
    why = data["parts"]["guidance"]["reasons"][0]
    settings = {(s["table"], s["key"]): s["value"] for s in why["settings"]}
    advised = settings[("disturbance", "current_speed")]
    assert 0.0 < advised < 0.3
    again = certify(transit(disturbance={"current_speed": advised})).to_dict()
    assert again["certified"] is True and again["guidance"]["certified"] is True


@pytest.mark.slow
@pytest.mark.parametrize(
    ("tables", "expected"),
    [
        ({"guidance": {"kind": "los"}}, [("guidance", "kind", "ilos")]),
        (
            {"implementation": {"sample_time": 0.1, "delay": 0.01, "varying_delay": True}},
            [("implementation", "varying_delay", False)],
        ),
    ],
    ids=["plain LOS", "a varying delay"],
)
def test_a_cascade_this_version_does_not_evaluate_is_answered_with_one_it_does_that_certifies(tables, expected):
    cert = certify(transit(**tables))
    reason = next(r for r in cert.findings if r.part == "guidance")
    assert [(s.table, s.key, s.value) for s in reason.settings] == expected
    supported = cert.to_dict()["guidance"]["largest_certifiable"]["supported"]
    assert supported is not None and supported["position_bound"] > 0.0
    again = certify(with_settings(transit(**tables), expected))
    assert again.certified and again.to_dict()["guidance"]["certified"] is True


@pytest.mark.parametrize(
    ("tables", "words"),
    [
        ({"guidance": {"kind": "los"}}, "plain LOS"),
        ({"implementation": {"sample_time": 0.1, "delay": 0.05, "varying_delay": True}}, "fixed [implementation]"),
        # a lookahead of a nanometre: the period map overflows, which is an unstable loop, not a crash
        ({"guidance": {"lookahead": 1e-9}}, "unstable"),
        pytest.param(
            {
                "actuators": {
                    "kind": "underactuated",
                    "tau_x": 67.0,
                    "rudder_max": 0.002,
                    "rudder_sway": 9.64,
                    "rudder_yaw": -6.15,
                }
            },
            "rudder",
            marks=pytest.mark.slow,
        ),
    ],
)
def test_what_is_not_covered_is_refused_with_its_reason(tables, words):
    data = certify(transit(**tables)).to_dict()
    assert data["certified"] is False and data["guidance"]["certified"] is False
    assert words in data["parts"]["guidance"]["reasons"][0]["message"]


@pytest.mark.slow
def test_cli_certify_and_simulate_carry_the_interface(tmp_path, capsys):
    path = tmp_path / "transit.toml"
    path.write_text(to_toml(TRANSIT))
    capsys.readouterr()
    assert main(["certify", "--config", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    g = data["guidance"]
    assert g["certified"] is True and set(g["error_bounds"]) == {"along_track", "cross_track", "heading"}
    assert data["actuators"]["certified_peak"] == g["certified_peak"] and set(g["certified_peak"]) == {
        "force_x",
        "rudder",
    }
    assert (
        data["formation"]["min_separation_certified"]
        >= 15.0 - 2.0 * np.hypot(g["error_bounds"]["along_track"], g["error_bounds"]["cross_track"]) - 1e-9
    )
    assert main(["simulate", "--config", str(path), "--json", "--horizon", "60"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["certificate_covers_run"] is True and rep["within_certified_bounds"] is True
    assert rep["certified_errors"] == g["error_bounds"]
    moved = {**TRANSIT, "simulation": {"horizon": 60.0, "current": [0.0, 0.04], "plant": {"m22": 1.2}}}
    path.write_text(to_toml(moved))
    assert main(["simulate", "--config", str(path), "--json"]) == 1
    rep = json.loads(capsys.readouterr().out)
    assert rep["certificate_covers_run"] is False and "box" in rep["coverage_reason"]


@pytest.mark.slow
def test_a_current_at_the_bound_written_with_twelve_digits_is_inside_and_one_part_in_ten_million_above_is_not():
    """A review swept currents at the bound in eight directions; the diagonal ones, written as 0.070710678119,
    have a norm 5e-12 above 0.1 m/s and were called outside. Ten significant digits are inside; 3e-7 above is not."""
    cfg = preset_config("remus-transit-ilos")
    summary = guidance_certificate(cfg)
    assert covers_run(cfg, summary, None, (0.070710678119, 0.070710678119), None)[0]
    covered, why = covers_run(cfg, summary, None, (0.0707107, 0.0707107), None)
    assert not covered and "exceeds [disturbance] current_speed" in why


def test_plant_multipliers_follow_the_parameter_order():
    cfg = transit(simulation={"plant": {"m33": 1.02, "d11_quad": 0.9}})
    m = plant_multipliers(cfg)
    assert m[PARAMETERS.index("m33")] == 1.02 and m[PARAMETERS.index("d11_quad")] == 0.9
    assert np.count_nonzero(m != 1.0) == 2


def test_a_design_point_without_guidance_has_no_guidance_figures():
    cfg = replace(transit(), guidance=None, actuators=None)
    data = certify(cfg).to_dict()
    assert data["parts"]["guidance"]["applies"] is False


@pytest.mark.slow
def test_gains_that_certify_the_declared_world_are_advised_first_and_certify_on_re_run():
    # in a 0.2 m/s current the default gains are refused, even in cells of the box and the current
    cfg = transit(disturbance={"current_speed": 0.2})
    data = certify(cfg).to_dict()
    assert data["certified"] is False
    settings = {(s["table"], s["key"]): s["value"] for s in data["parts"]["guidance"]["reasons"][0]["settings"]}
    # only the gains that change are named
    assert settings and set(settings) <= {("guidance", "heading_bandwidth"), ("guidance", "lookahead")}
    declared = cfg.guidance
    assert all(v != getattr(declared, k) for (_, k), v in settings.items())
    message = data["parts"]["guidance"]["reasons"][0]["message"]
    assert "rad/s (rad/s" not in message and "m (m)" not in message  # each value once with its unit
    gains = {k: v for (t, k), v in settings.items()}
    again = certify(transit(disturbance={"current_speed": 0.2}, guidance={"kind": "ilos", **gains})).to_dict()
    assert again["certified"] is True


@pytest.mark.slow
def test_the_transit_preset_certifies_a_torpedo_fleet_within_its_rudder():
    from auv_hinf.config.presets import preset_config

    data = certify(preset_config("remus-transit-ilos")).to_dict()
    assert data["certified"] is True
    g = data["guidance"]
    assert (
        g["certified_peak"]["rudder"] <= g["limits"]["rudder"]
        and g["certified_peak"]["force_x"] <= g["limits"]["force_x"]
    )
    assert data["formation"]["min_separation_certified"] > 2.0


def test_a_time_varying_current_is_not_evaluated():
    data = certify(transit(disturbance={"current_speed": 0.04, "current_rate": 0.001})).to_dict()
    assert data["certified"] is False
    assert "current_rate" in data["parts"]["guidance"]["reasons"][0]["message"]


def test_a_current_too_strong_for_the_start_is_refused_without_a_numerical_warning(recwarn):
    data = certify(transit(disturbance={"current_speed": 1.5})).to_dict()
    assert data["certified"] is False and "start" in data["parts"]["guidance"]["reasons"][0]["message"]
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


@pytest.mark.slow
def test_a_run_in_a_current_above_the_declared_bound_gets_no_separation_and_the_advice_certifies():
    """``remus-transit-ilos`` certifies currents up to 0.1 m/s; its configured run in 0.15 m/s is outside
    that (``simulate`` says so): certify names the run's current and its setting, re-run, certifies."""
    base = preset_config("remus-transit-ilos")
    cfg = replace(base, simulation=replace(base.simulation, current=(0.0, 0.15)))
    cert = certify(cfg)
    assert not cert.certified and cert.verdict("guidance").ok
    (why,) = cert.verdict("separation").reasons
    assert "current 0.15 m/s exceeds the declared bound 0.1 m/s" in why.message
    (setting,) = why.settings
    assert (setting.table, setting.key) == ("simulation", "current") and np.hypot(*setting.value) <= 0.1
    again = certify(with_settings(cfg, [(setting.table, setting.key, setting.value)]))
    assert again.certified, again.reasons


@pytest.mark.slow
def test_a_run_outside_in_plant_and_current_is_answered_with_both_values_at_once():
    """Plant (m33 0.9 against [0.97, 1.03]) and current (0.22 m/s against 0.1 m/s) both outside: one
    refusal with both values, which re-run certifies; and advice of another part (here: remove the
    time-varying current the cascade does not certify) carries the run's values too."""
    base = preset_config("remus-transit-ilos")
    sim = replace(base.simulation, current=(0.2, -0.1), plant=(("m33", 0.9),))
    cfg = replace(base, simulation=sim)
    cert = certify(cfg)
    (why,) = cert.verdict("separation").reasons
    assert {(x.table, x.key) for x in why.settings} == {("simulation", "current"), ("simulation.plant", "m33")}
    again = certify(with_settings(cfg, [(x.table, x.key, x.value) for x in why.settings]))
    assert again.certified, again.reasons
    varying = replace(cfg, disturbance=replace(cfg.disturbance, current_rate=0.001))
    (advice,) = certify(varying).verdict("guidance").reasons
    assert ("disturbance", "current_rate", None) in [(x.table, x.key, x.value) for x in advice.settings]
    assert {("simulation", "current"), ("simulation.plant", "m33")} <= {(x.table, x.key) for x in advice.settings}
    rerun = certify(with_settings(varying, [(x.table, x.key, x.value) for x in advice.settings]))
    assert rerun.certified, rerun.reasons


@pytest.mark.parametrize(
    ("reference", "envelope", "key"),
    [
        ({"kind": "line", "speed": 3.0}, {"u": [0.5, 2.5], "v": [-0.3, 0.3], "r": [-0.3, 0.3]}, "u"),
        (
            {"kind": "circle", "speed": 1.5, "radius": 300.0},
            {"u": [0.5, 2.5], "v": [-0.3, 0.3], "r": [-0.003, 0.003]},
            "r",
        ),
    ],
)
def test_a_certified_motion_outside_the_envelope_is_refused_and_the_widened_envelope_certifies(
    reference, envelope, key
):
    """The cascade's certified surge speed, sway speed and yaw rate lie inside the declared ``[envelope]``.

    The envelope says where the vehicle model holds: a cascade certified beyond it is refused, the
    advice widens exactly the range that binds (outwards, so that it contains the certified motion),
    a run is not covered, and a re-run with the advice certifies.
    """
    cfg = transit(reference=reference, envelope=envelope, uncertainty={}, disturbance={}, simulation={"horizon": 60.0})
    cert = certify(cfg)
    assert not cert.certified
    reason = next(r for r in cert.findings if r.part == "guidance")
    assert f"[envelope] {key} =" in reason.message, reason.message
    assert [(s.table, s.key) for s in reason.settings] == [("envelope", key)]
    widened = reason.settings[0].value
    motion = cert.to_dict()["guidance"]
    certified = {
        "u": motion["surge_speed"],
        "r": [-motion["yaw_rate"], motion["yaw_rate"]] if "yaw_rate" in motion else None,
    }[key]
    if certified is not None:
        assert widened[0] <= certified[0] and certified[1] <= widened[1]
    assert widened[0] <= envelope[key][0] and widened[1] >= envelope[key][1]
    assert not certify(cfg).to_dict()["guidance"]["certified"]
    again = certify(with_settings(cfg, [(s.table, s.key, s.value) for s in reason.settings]))
    assert again.certified, again.reasons


def test_a_fleet_whose_certified_bound_leaves_it_too_close_is_not_run_as_certified(tmp_path, capsys):
    """The cascade certifies, but its bound leaves two slots 6 m apart closer than min_separation: ``certify``
    refuses the fleet, and so do ``simulate`` and ``campaign`` (they used to run it as certified)."""
    offsets = {"n": 3, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 6.0], [0.0, -6.0]]}
    free = transit(formation=offsets, uncertainty={})
    summary = guidance_certificate(free)
    assert summary.holds and fleet_refusal(free) == ""  # the default separation is met
    bound = summary.certificate.position_bound
    # certified at least 6 - 2 x bound apart: a requirement between that and 6 m is refused
    cfg = transit(formation={**offsets, "min_separation": 6.0 - bound}, uncertainty={})
    assert guidance_certificate(cfg).holds and "min_separation" in fleet_refusal(cfg)
    assert not certify(cfg).certified
    path = tmp_path / "close.toml"
    path.write_text(to_toml(cfg.to_toml_dict()))
    capsys.readouterr()
    assert main(["simulate", "--config", str(path), "--horizon", "20", "--json"]) == 1
    assert "refusing to simulate" in capsys.readouterr()[0]
    assert main(["simulate", "--config", str(path), "--horizon", "20", "--json", "--uncertified"]) == 1
    report = json.loads(capsys.readouterr()[0])
    assert report["certificate_covers_run"] is False and "min_separation" in report["coverage_reason"]
    camp = run_guidance_campaign(cfg, 1, seed=0, horizon=20.0).summary()
    assert camp["certified"] is False and camp["ok"] is False


@pytest.mark.slow
def test_a_spread_of_a_path_frame_formation_is_answered_certified_as_written():
    """In the path frame the outer slots are faster in the turns, so spreading the formation raises the bound:
    the spread answered is the one whose re-run keeps the vehicles apart."""
    offsets = {"n": 3, "frame": "path", "offsets": [[0.0, 0.0], [0.0, 6.0], [0.0, -6.0]]}
    mission = {"kind": "lawnmower", "speed": 1.5, "leg_length": 300.0, "spacing": 600.0, "turn_radius": 150.0}
    free = transit(formation=offsets, reference=mission, uncertainty={})
    bound = guidance_certificate(free).certificate.position_bound
    cfg = transit(formation={**offsets, "min_separation": 6.0 - bound}, reference=mission, uncertainty={})
    cert = certify(cfg)
    assert not cert.certified
    (why,) = cert.verdict("separation").reasons
    assert why.settings and "(re-run with it" in why.message
    again = certify(with_settings(cert.config, [(x.table, x.key, x.value) for x in why.settings]))
    assert again.certified, again.reasons
    assert again.to_dict()["formation"]["min_separation_certified"] >= 6.0 - bound


def test_when_the_sample_time_allows_no_faster_heading_loop_a_longer_lookahead_alone_is_tried():
    from auv_hinf.certificate.parts.guidance import GAIN_CANDIDATES, MAX_BANDWIDTH_STEP, _gain_variants

    for bandwidth, lookahead in ((1.0, 8.0), (2.4, 8.0)):
        cfg = transit(guidance={"kind": "ilos", "heading_bandwidth": bandwidth, "lookahead": lookahead})
        problem = cascade_problem(cfg, design_point(cfg))
        variants = [(g.heading_bandwidth, g.lookahead) for g in _gain_variants(problem)]
        allowed = [
            (bandwidth * w, lookahead * k)
            for w, k in GAIN_CANDIDATES
            if bandwidth * w * problem.sample_time <= MAX_BANDWIDTH_STEP
        ]
        np.testing.assert_allclose(variants, allowed, rtol=1e-12)
        # the declared heading loop with twice the lookahead is always among them, last
        np.testing.assert_allclose(variants[-1], (bandwidth, 2.0 * lookahead), rtol=1e-12)
    assert len(variants) == 1  # at 2.4 rad/s and 10 Hz no faster heading loop is allowed
