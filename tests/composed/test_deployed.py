"""The composed certificate of the deployed loop: sound against simulation, wired into certify, advice that re-runs.

A BlueROV2 Heavy line at 0.4 m/s, run at 10 Hz with a 0.1 s delay and small DVL-like noise:
the composed certificate covers it with gains designed for it, supersedes the continuous and
nominal implementation certificates, and the toolbox's own sampled simulation (noise at its
bound, delay at its bound) stays inside its bounds. With a box and a current it does not cover,
and its advice, written back into the configuration, certifies.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from auv_hinf.campaign.setup import prepare
from auv_hinf.certificate.assembly import certify, waived
from auv_hinf.certificate.part import Verdict
from auv_hinf.certificate.run_plan import force_floor, plan_run, run_report
from auv_hinf.cli.main import main
from auv_hinf.composed.certificate import DeployedProblem
from auv_hinf.composed.loops import Errors
from auv_hinf.config.settings import config_from_dict, with_settings
from auv_hinf.exceptions import DesignError
from auv_hinf.implementation.model import Implementation
from auv_hinf.numerics.integrators import FORCE_FLOOR
from auv_hinf.simulation.engine import simulate
from tests.helpers import DEPLOYED, DEPLOYED_BOXED, to_toml


@pytest.fixture(scope="module")
def deployed():
    cfg = config_from_dict(DEPLOYED, "deployed")
    return cfg, certify(cfg)


@pytest.mark.slow
def test_the_deployed_fleet_is_covered_and_supersedes_the_idealised_certificates(deployed):
    _, cert = deployed
    d = cert.to_dict()
    c = d["composed"]
    assert cert.certified and c["covers"]
    assert {"sample_time", "delay", "noise"} <= set(c["parts"])
    assert set(c["error_bounds"]) == {"position", "velocity", "heading", "yaw_rate"}
    assert c["decay_rate"] is not None and c["decay_rate"] > 0.0
    assert d["design"]["method"] == "deployed" and d["design"]["value"] == pytest.approx(c["error_bounds"]["position"])
    for name in ("closed_loop", "robust", "implementation"):
        part = d["parts"][name]
        assert not part["applies"] and part["ok"] and "superseded" in part["note"]
    # the implementation object still says the declared implementation is covered, and by what
    impl = d["implementation"]
    assert impl["covers"] and impl["covered_by"] == "composed" and impl["error_bounds"] == c["error_bounds"]
    assert impl["sample_time"] == 0.1 and impl["delay"] == 0.1
    # its timing: the certified (declared) values, within the exact nominal limits, and their ratio
    assert impl["max_sample_time"] == 0.1 and impl["max_delay"] == 0.1
    assert 0.1 < impl["exact_max_sample_time"] and 0.1 < c["timing"]["exact_max_delay"]
    assert impl["tightness"] == pytest.approx(0.1 / impl["exact_max_sample_time"]) == c["tightness"]
    # the robust object: covered by the composed certificate (nothing declared here), its thrust the composed one
    rob = d["robust"]
    assert rob["covers"] and rob["covered_by"] == "composed" and not rob["declared"]
    assert rob["thrust"] == c["certified_peak"] and rob["ultimate_bounds"] == c["error_bounds"]
    # the actuator part holds the composed force bound, and the separation part reads its position bound
    assert d["actuators"]["certified_peak"] == pytest.approx(c["certified_peak"])
    assert d["actuators"]["certified"]
    assert d["formation"]["min_separation_certified"] >= 4.0 - 2.0 * c["error_bounds"]["position"] - 1e-9


@pytest.mark.slow
def test_a_simulated_deployed_run_stays_inside_the_composed_bounds(deployed):
    """The toolbox's sampled loop (uniform noise at its bound, the delay at its bound) against the certificate."""
    cfg, cert = deployed
    bounds = cert.to_dict()["composed"]
    plan = plan_run(cfg)
    assert plan.covered
    report = run_report(plan, simulate(plan.scenario))
    measured, certified = report["measured_errors"], report["certified_errors"]
    assert certified == pytest.approx({f"{k}_error": v for k, v in bounds["error_bounds"].items()})
    for k, v in measured.items():
        assert v <= certified[k], (k, v, certified[k])
    peak = report["commanded_peak"]
    floor = force_floor(cfg.vehicle, plan.design.require_gains(), cfg.envelope)  # a computed trajectory's floor
    assert report["certified_thrust"] == pytest.approx({k: v + floor[k] for k, v in bounds["certified_peak"].items()})
    for k in ("force_x", "force_y", "moment"):
        assert peak[k] <= bounds["certified_peak"][k]
    # not vacuous: the run's force is within 20 % of the certified peak (the drag at 0.4 m/s dominates it)
    assert peak["force_x"] >= 0.8 * bounds["certified_peak"]["force_x"]


@pytest.mark.slow
@pytest.mark.parametrize("pattern", ["against-error", "slow"])
def test_noise_chosen_against_the_loop_stays_inside_and_comes_closer(deployed, pattern):
    """Errors at their bounds, opposing the measured error or switching slowly: inside the bounds, and
    above 0.3 of the position bound (random noise stays near a seventh of it)."""
    cfg, cert = deployed
    bounds = cert.to_dict()["composed"]["error_bounds"]
    plan = plan_run(with_settings(cfg, [("simulation", "noise_pattern", pattern)]))
    report = run_report(plan, simulate(plan.scenario))
    assert report["implementation"]["noise_pattern"] == pattern
    for k, v in report["measured_errors"].items():
        assert v <= report["certified_errors"][k], (k, v)
    assert report["measured_errors"]["position_error"] >= 0.3 * bounds["position"]


def test_the_composed_certificate_is_about_a_sampled_law():
    from auv_hinf.composed.loops import MissionBounds, Plant
    from auv_hinf.law.gains import Gains
    from auv_hinf.models.envelope import Envelope
    from auv_hinf.models.vehicle import bluerov2_heavy
    from auv_hinf.robust.box import ParameterBox

    mdl = bluerov2_heavy()
    with pytest.raises(DesignError, match="sample_time"):
        DeployedProblem(
            Plant(mdl, ParameterBox.from_ranges(mdl, ())),
            MissionBounds((0.4, 0.4), 0.0, 0.0, 0.0, 0.0, 0.0),
            Envelope((-0.5, 1.0), (-0.5, 0.5), (-0.5, 0.5)),
            Implementation(delay=0.1),
            Gains(2.0, 1.0, (1.0, 1.5)),
            Errors(0.0, 0.0, 0.0, 0.0),
        )


@pytest.mark.slow
def test_advice_written_back_into_the_configuration_certifies():
    """With a box and a current the deployed BlueROV2 line is refused; the advice, re-run, certifies."""
    data = {
        **DEPLOYED,
        "uncertainty": {"m11": [0.9, 1.1], "d11_quad": [0.8, 1.2], "d22_quad": [0.8, 1.2]},
        "disturbance": {"current_speed": 0.1},
    }
    cfg = config_from_dict(data, "boxed")
    cert = certify(cfg)
    assert not cert.certified
    reason = next(r for r in cert.findings if r.part == "composed")
    assert reason.settings, reason.message
    # every setting names a table and key that exist, and nothing that is not declared
    tables = {s.table for s in reason.settings}
    assert tables <= {"implementation", "implementation.noise", "disturbance", "uncertainty"}
    # advice that needs several settings at once says so (not "each alone")
    advice = cert.to_dict()["composed"]["advice"]
    if any(a["setting"] == "together" for a in advice):
        assert "together do" in reason.message and "each alone" not in reason.message
    again = certify(with_settings(cfg, [(s.table, s.key, s.value) for s in reason.settings]))
    assert again.verdict("composed").ok and again.to_dict()["composed"]["covers"]


@pytest.mark.slow
def test_the_actuators_judge_the_sampled_laws_force_not_the_continuous_ones(deployed):
    """Thrusters too weak for the deployed loop's certified surge force: the composed part refuses for the force,
    and the actuators part says the same with the same peak. Before, it held the continuous law's start-region
    force (fitted to the limits) and said "the peaks fit" beside the composed refusal."""
    _, cert = deployed
    surge = cert.to_dict()["composed"]["certified_peak"]["force_x"]
    weak = {**DEPLOYED, "actuators": {"tau_x": 0.85 * surge, "tau_y": 86.0, "tau_psi": 23.0}}
    out = certify(config_from_dict(weak, "weak")).to_dict()
    act, comp = out["actuators"], out["composed"]
    assert not out["certified"] and not comp["covers"] and act["certified"] is False
    assert act["certified_peak"] == pytest.approx(comp["certified_peak"]) and act["binding"] == "force_x"
    assert act["largest_certifiable"] is None  # the continuous law's answer is not the deployed loop's
    # with no fixed point for the deployed loop, no certificate bounds its force
    loud = {**weak, "implementation": {**DEPLOYED["implementation"], "noise": {"position": 2.0}}}
    out = certify(config_from_dict(loud, "loud")).to_dict()
    assert out["composed"]["certified_peak"] is None and out["actuators"]["certified_peak"] is None
    assert out["actuators"]["certified"] is False and "sampled law" in out["actuators"]["reason"]


def test_a_failing_superseding_part_is_waived_when_the_parts_it_supersedes_hold():
    verdicts = {
        "composed": Verdict("composed", False, True),
        "closed_loop": Verdict("closed_loop", True, True),
        "robust": Verdict("robust", True, False),
        "implementation": Verdict("implementation", True, True),
    }
    out = waived(verdicts)
    assert out["composed"].ok and not out["composed"].applies and "not needed" in out["composed"].note
    verdicts["implementation"] = Verdict("implementation", False, True)
    assert not waived(verdicts)["composed"].ok
    del verdicts["implementation"]  # the other route not evaluated yet: nothing is waived
    assert not waived(verdicts)["composed"].ok


def test_settings_are_written_into_nested_tables_and_validated():
    cfg = config_from_dict(DEPLOYED, "deployed")
    out = with_settings(cfg, [("implementation.noise", "position", 0.5), ("disturbance", "current_speed", 0.05)])
    assert out.implementation.noise.position == 0.5 and out.disturbance.current_speed == 0.05
    assert np.isclose(out.implementation.delay, 0.1)
    with pytest.raises(Exception, match="sample_time"):
        with_settings(cfg, [("implementation", "sample_time", -1.0)])


@pytest.mark.slow
def test_the_bluerov2_survey_preset_certifies_as_deployed_and_its_turn_stays_inside():
    """The lawn-mower preset: certified by the composed certificate; a run through its first turn,
    the noise opposing the error, stays inside every bound without saturating."""
    from auv_hinf.config.presets import preset_config

    cfg = preset_config("bluerov2-survey")
    cert = certify(cfg)
    assert cert.certified, cert.reasons
    c = cert.to_dict()["composed"]
    assert c["covers"] and cert.to_dict()["formation"]["min_separation_certified"] >= cfg.min_separation
    run = with_settings(cfg, [("simulation", "horizon", 600.0), ("simulation", "noise_pattern", "against-error")])
    plan = plan_run(run)
    report = run_report(plan, simulate(plan.scenario))
    assert report["certificate_covers_run"] and report["saturation_fraction"] == 0.0
    for k, v in report["measured_errors"].items():
        assert v <= report["certified_errors"][k], (k, v)
    for k in ("force_x", "force_y", "moment"):
        assert report["commanded_peak"][k] <= c["certified_peak"][k]


@pytest.mark.slow
def test_a_run_with_a_declared_box_and_current_is_judged_by_the_composed_certificate():
    """simulate's robust_covers_run, for a sampled run of a declared box and current: the composed verdict."""
    cfg = config_from_dict(DEPLOYED_BOXED, "boxed")
    plan = plan_run(with_settings(cfg, [("simulation", "horizon", 10.0)]))
    report = run_report(plan, simulate(plan.scenario))
    assert report["certificate_covers_run"] and report["robust_covers_run"] is True
    assert report["robust_bounds"] == {k.removesuffix("_error"): v for k, v in report["certified_errors"].items()}
    assert "composed" in report["robust_reason"]


def test_a_run_outside_the_box_of_certified_gains_is_told_why_by_the_composed_certificate_alone():
    """The plant 10 % heavier than the box allows: the composed certificate (which covers the gains) says
    why the run is not covered; the idealised parts it supersedes, evaluated because it does not cover
    this run, add nothing (the implementation certificate of the model as the plant would mislead)."""
    cfg = config_from_dict({**DEPLOYED_BOXED, "simulation": {"horizon": 5.0, "plant": {"m11": 1.1}}}, "heavy")
    plan = plan_run(cfg)
    checks = {c.part: c for c in plan.checks}
    assert checks["composed"].certifies_gains and not checks["composed"].covers
    assert {"closed_loop", "robust", "implementation"} <= set(checks) and plan.judged >= {"robust", "implementation"}
    assert len(plan.notes) == 1 and plan.notes[0].startswith("composed certificate:") and "m11 = 1.1" in plan.notes[0]
    assert plan.uncertified_gains() is None  # the gains are certified: the run is simulated


@pytest.mark.slow
def test_a_channel_the_mission_never_loads_is_certified_above_the_simulations_round_off():
    """Exact measurements on a straight line in still water: sway force and yaw moment are zero by symmetry,
    and the simulation commands round-off there; the certified peak carries the force floor, and every
    commanded channel of the run stays within the certified peak."""
    exact = {"sample_time": 0.1, "delay": 0.1, "noise": {"position": 0.0, "velocity": 0.0, "heading": 0.0}}
    cfg = config_from_dict({**DEPLOYED, "simulation": {"horizon": 20.0}, "implementation": exact}, "exact")
    cert = certify(cfg)
    peak = cert.to_dict()["actuators"]["certified_peak"]
    assert cert.certified and min(peak.values()) >= FORCE_FLOOR
    assert cert.to_dict()["composed"]["certified_peak"] == pytest.approx(peak)
    plan = plan_run(cfg)
    report = run_report(plan, simulate(plan.scenario))
    assert report["certificate_covers_run"]
    for channel, commanded in report["commanded_peak"].items():
        assert commanded <= peak[channel], (channel, commanded, peak[channel])


@pytest.mark.slow
def test_a_heading_range_narrower_than_the_circle_is_refused_with_the_full_circle():
    """The composed certificate bounds the heading *error*: a declared ``envelope.psi`` narrower than
    the full circle is refused (a line heading 3 rad with psi in [-0.1, 0.1] starts outside it),
    and the answer is the full circle."""
    data = {**DEPLOYED, "envelope": {**DEPLOYED["envelope"], "psi": [-0.1, 0.1]}}
    data["reference"] = {"kind": "line", "speed": 0.4, "heading": 3.0}
    cert = certify(config_from_dict(data, "narrow heading"))
    assert not cert.certified
    reason = next(r for r in cert.findings if r.part == "composed")
    assert "narrower than the full circle" in reason.message
    assert [(s.table, s.key) for s in reason.settings] == [("envelope", "psi")]


@pytest.mark.slow
def test_a_run_in_a_current_the_composed_certificate_does_not_cover_is_not_certified():
    """The deployed fleet, certified in still water, with its configured run in a 0.02 m/s current:
    the composed bound is not about that run, so no separation is certified for it (before, certify
    said yes while simulate said the run was not covered); the advice, re-run, certifies."""
    cfg = config_from_dict({**DEPLOYED, "simulation": {"horizon": 40.0, "current": [0.02, 0.0]}}, "deployed")
    cert = certify(cfg)
    assert not cert.certified and cert.verdict("composed").ok
    (why,) = cert.verdict("separation").reasons
    assert "current 0.02 m/s exceeds the declared bound 0 m/s" in why.message
    assert [(x.table, x.key, x.value) for x in why.settings] == [("simulation", "current", [0.0, 0.0])]
    again = certify(with_settings(cfg, [(x.table, x.key, x.value) for x in why.settings]))
    assert again.certified, again.reasons
    assert not plan_run(cfg).covered


@pytest.mark.slow
def test_the_preset_noise_with_a_small_box_and_current_certifies_and_its_corners_stay_inside():
    """``bluerov2-deployed`` (10 Hz, 0.1 s delay, its DVL/USBL noise) with a twentieth of the
    ``bluerov2-line`` box (+-0.5 % mass, +-1 % damping) and a 0.003 m/s current: certified, which
    the body-frame position loops could not (their turn ``r epsilon`` coupled the axes; the box alone
    covered to 0.047 of the line's). The box's corners in that current across and against the line,
    the noise opposing the error, stay inside every bound."""
    from auv_hinf.config.presets import BLUEROV_BOX, preset_config

    box = [("uncertainty", k, [1.0 - 0.05 * (1.0 - lo), 1.0 + 0.05 * (hi - 1.0)]) for k, (lo, hi) in BLUEROV_BOX]
    cfg = with_settings(
        preset_config("bluerov2-deployed"),
        [*box, ("disturbance", "current_speed", 0.003), ("simulation", "noise_pattern", "against-error")],
    )
    cert = certify(cfg)
    assert cert.certified, cert.reasons
    c = cert.to_dict()["composed"]
    assert c["covers"] and {"box", "current"} <= set(c["parts"])
    for corner, current in ((1, [0.0, 0.003]), (0, [-0.003, 0.0])):
        plant = [("simulation.plant", k, rng[corner]) for _, k, rng in box]
        plan = plan_run(with_settings(cfg, [*plant, ("simulation", "current", current)]))
        report = run_report(plan, simulate(plan.scenario))
        assert report["certificate_covers_run"] and report["saturation_fraction"] == 0.0
        for k, v in report["measured_errors"].items():
            assert v <= report["certified_errors"][k], (corner, k, v)
        for k in ("force_x", "force_y", "moment"):
            assert report["commanded_peak"][k] <= c["certified_peak"][k], (corner, k)


@pytest.mark.slow
def test_a_declared_start_that_alone_binds_is_answered_with_the_start_on_the_slots():
    """One vehicle starts turned 0.3 rad off its course: the composed certificate does not cover that start
    and no declared setting, shrunk, covers it either; the answer removes ``[simulation] initial`` (every
    vehicle on its slot), keeping the hardware and the world as declared, and re-run it certifies."""
    initial = [[0.0, -6.0, 0.3, 0.4, 0.0, 0.0]] + [[0.0, y, 0.0, 0.4, 0.0, 0.0] for y in (-2.0, 2.0, 6.0)]
    cfg = config_from_dict({**DEPLOYED, "simulation": {"horizon": 40.0, "initial": initial}}, "turned")
    cert = certify(cfg)
    assert not cert.certified
    reason = next(r for r in cert.findings if r.part == "composed")
    assert [(s.table, s.key, s.value) for s in reason.settings] == [("simulation", "initial", None)]
    assert "the declared start binds" in reason.message
    [entry] = cert.to_dict()["composed"]["advice"]
    assert entry["setting"] == "start"
    again = certify(with_settings(cfg, [("simulation", "initial", None)]))
    assert again.certified
    assert again.to_dict()["composed"]["error_bounds"]["position"] == pytest.approx(entry["position_bound"])


@pytest.mark.slow
def test_gains_the_composed_certificate_refuses_from_the_slots_are_not_run_unless_asked(tmp_path, capsys):
    """Position noise of 1.5 m (150x the deployed fleet's): no certificate covers the gains, so
    ``simulate`` and ``campaign`` refuse them without ``--uncertified`` (the composed certificate judges the deployed
    loop; no continuous part refuses them here: no box, no current). A start the certificate does not
    cover, with gains it covers from the slots, is the run's matter: that run is simulated."""
    noisy = {**DEPLOYED, "implementation": {**DEPLOYED["implementation"], "noise": {"position": 1.5}}}
    path = tmp_path / "noisy.toml"
    path.write_text(to_toml(noisy))
    assert not certify(config_from_dict(noisy, "noisy")).certified
    code = main(["simulate", "--config", str(path), "--horizon", "2"])
    err = capsys.readouterr().err
    assert code == 1 and "refusing to simulate gains that no certificate covers" in err
    assert "composed certificate of the deployed loop does not cover them" in err and "--uncertified" in err
    code = main(["campaign", "--config", str(path), "--runs", "2", "--horizon", "2", "--out", str(tmp_path / "c")])
    assert code == 1 and "refusing to run a campaign" in capsys.readouterr().err
    code = main(["simulate", "--config", str(path), "--horizon", "2", "--json", "--uncertified"])
    assert code == 1 and json.loads(capsys.readouterr().out)["certificate_covers_run"] is False
    # a campaign of them says the same: its runs are not covered, so it does not pass (it used to exit 0)
    out = tmp_path / "u"
    args = ["campaign", "--config", str(path), "--runs", "2", "--horizon", "2", "--out", str(out), "--uncertified"]
    code = main(args)
    assert code == 1 and "2 runs not covered" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"]["certificate_applies"] == 0 and summary["ok"] is False and summary["certificate"] is None
    initial = [[0.0, -6.0, 0.3, 0.4, 0.0, 0.0]] + [[0.0, y, 0.0, 0.4, 0.0, 0.0] for y in (-2.0, 2.0, 6.0)]
    turned = tmp_path / "turned.toml"
    turned.write_text(to_toml({**DEPLOYED, "simulation": {"horizon": 2.0, "initial": initial}}))
    code = main(["simulate", "--config", str(turned), "--json"])
    run = json.loads(capsys.readouterr().out)
    assert "refusing" not in json.dumps(run) and run["certificate_covers_run"] is False


@pytest.mark.slow
def test_a_run_whose_certified_bound_breaks_min_separation_is_not_covered_and_its_gains_are_refused():
    """Position noise of 0.4 m (the other channels the deployed preset's): the composed certificate covers
    the tracking errors, but its bound leaves the closest pair below ``[formation] min_separation``.
    ``certify`` refuses it for that, and so does a run: not covered, and ``simulate``/``campaign`` refuse
    the gains without ``--uncertified``, as ``certify`` refuses them."""
    noisy = {
        **DEPLOYED,
        "implementation": {
            **DEPLOYED["implementation"],
            "noise": {"position": 0.4, "velocity": 0.004, "heading": 0.004, "yaw_rate": 0.002},
        },
    }
    cfg = config_from_dict({**noisy, "simulation": {"horizon": 2.0}}, "close")
    cert = certify(cfg)
    assert not cert.certified and [r.part for r in cert.findings] == ["separation"]
    plan = plan_run(cfg)
    checks = {c.part: c for c in plan.checks}
    assert checks["composed"].covers and not checks["separation"].covers and not plan.covered
    bound = checks["composed"].bounds["position"]
    slots = 4.0  # the closest slots of DEPLOYED's line abreast
    assert slots - 2.0 * bound < cfg.min_separation  # the condition's own arithmetic
    assert "min_separation" in (plan.uncertified_gains() or "")
    report = run_report(plan, simulate(plan.scenario))  # as simulate --uncertified reports it
    assert report["certificate_covers_run"] is False and report["covered_by"] == []
    assert "min_separation" in report["coverage_reason"]
    calm = plan_run(config_from_dict({**DEPLOYED, "simulation": {"horizon": 2.0}}, "calm"))
    assert calm.covered and {c.part: c for c in calm.checks}["separation"].covers
    # a campaign of it (run with --uncertified) checks no run against those bounds, and says why
    setup, _ = prepare(cfg, horizon=2.0)
    assert not setup.certificate_applies and "min_separation" in (setup.separation or "")
    assert prepare(config_from_dict(DEPLOYED, "calm"), horizon=2.0)[0].separation is None


def test_less_measurement_noise_never_loses_the_cover():
    """A review's fleet (the deployed BlueROV2 line with a 0.3 s delay, gentle gains): certified with velocity
    and heading noise of 1e-5, refused at 1e-11 before the small-gain solve lifted the components its round-off
    left short (a tiny channel beside metres); the bound decreases with the noise down to 1e-13."""
    from dataclasses import replace

    from auv_hinf.certificate.deployed import deployed_problem
    from auv_hinf.certificate.design_point import design_point
    from auv_hinf.composed.certificate import certify_deployed
    from auv_hinf.config.presets import preset_config
    from auv_hinf.implementation.model import MeasurementNoise
    from auv_hinf.law.gains import Gains

    cfg = preset_config("bluerov2-deployed")
    cfg = replace(cfg, implementation=replace(cfg.implementation, delay=0.3))
    point = design_point(cfg)
    base = deployed_problem(cfg, point.mission, point.tube, point.offsets, Gains(1.5, 0.28125, (1.0, 1.5), 0.0))
    bounds = []
    for v in (1e-5, 1e-9, 1e-11, 1e-13):
        noise = MeasurementNoise(0.00975, v, v, 4.04e-5)
        cert = certify_deployed(replace(base, implementation=replace(base.implementation, noise=noise)))
        assert cert.covers and cert.errors is not None, (v, cert.reasons)
        bounds.append(cert.errors.position)
    assert bounds == sorted(bounds, reverse=True)


def test_a_heading_range_narrower_than_the_circle_is_refused_by_certify_and_by_the_run_alike():
    """The composed certificate bounds the heading error, not the heading: a narrowed ``[envelope] psi``
    is refused by ``certify`` with the full circle as the answer, and the run of the same file is not
    covered (the composed part's run check applies the same gate)."""
    data = {**DEPLOYED, "envelope": {**DEPLOYED["envelope"], "psi": [1.0, 2.0]}}
    cfg = config_from_dict(data, "narrow heading")
    out = certify(cfg).to_dict()
    assert out["certified"] is False
    why = out["parts"]["composed"]["reasons"][0]
    assert [(s["table"], s["key"]) for s in why["settings"]] == [("envelope", "psi")]
    assert "[envelope] psi = [" in why["message"]
    assert plan_run(cfg).covered is False
    full = with_settings(cfg, [(s["table"], s["key"], s["value"]) for s in why["settings"]])
    assert plan_run(full).covered is True


@pytest.mark.slow
def test_with_actuators_the_composed_part_is_not_waived_and_its_answer_certifies():
    """The nominal design at 10 Hz with a varying 0.1 s delay: the closed-loop and implementation parts hold, the
    composed one does not. Without actuators that route certifies the errors; with them only the composed certificate
    bounds the sampled law's force, so it is not waived: it refuses with its advice (which re-run certifies) and the
    actuators part agrees, where a review found the composed part "not needed" beside an actuators refusal."""
    table = {
        **DEPLOYED,
        "design": {"method": "stabilizing"},
        "implementation": {"sample_time": 0.1, "delay": 0.1, "varying_delay": True},
    }
    cert = certify(config_from_dict(table, "varying"))
    out = cert.to_dict()
    assert not out["certified"] and out["parts"]["composed"]["applies"] and not out["parts"]["composed"]["ok"]
    assert out["actuators"]["certified"] is False and "sampled law" in out["actuators"]["reason"]
    (why,) = [r for r in cert.findings if r.part == "composed"]
    assert why.settings
    again = certify(with_settings(cert.config, [(s.table, s.key, s.value) for s in why.settings]))
    assert again.certified, again.reasons
    # without actuators the other route certifies the errors, and the composed part is waived
    free = certify(config_from_dict({k: v for k, v in table.items() if k != "actuators"}, "free")).to_dict()
    assert free["certified"] and not free["parts"]["composed"]["applies"]
