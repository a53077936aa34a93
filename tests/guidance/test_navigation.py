"""The guidance cascade on late and noisy navigation: the simulator, the certificate, the answers.

Properties asserted:

* the simulator's late measurement is the state that long before: with a delay of whole samples
  every command is the law on the state (and the slot) those samples earlier; with a delay of part
  of a sample, it matches an independent run integrated on the half-sample grid;
* a fleet certified with a delay and measurement noise stays inside every certified state bound
  and command bound, on runs with the noise at its bound in every pattern (bang-bang, constant,
  slow square wave, against the error) and drawn uniformly;
* a fleet refused for its navigation is answered with a delay and noise that certify on re-run;
* ``simulate --json`` runs such a fleet and judges the run by its certificate.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from auv_hinf._typing import NOISE_PATTERNS
from auv_hinf.cascade.certificate import STATES, certify_cascade
from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import design_point, raw_fleet
from auv_hinf.certificate.parts.guidance import _navigation_settings, cascade_problem, guidance_summary
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import with_settings
from auv_hinf.guidance.law import SlotMotion, commands, integral_start
from auv_hinf.guidance.simulation import Navigation, ThreeDofPlant, run_cascade, slot_motion, slot_start
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from tests.guidance.test_certificate import TRANSIT, _states_along, transit
from tests.helpers import to_toml

#: The transit fleet on its nominal plant in still water, at 20 Hz on measurements 0.05 s old with
#: small errors: a navigation its certificate covers (a declared box or current on top is refused).
NAVIGATION = {
    "uncertainty": {},
    "disturbance": {},
    "simulation": {"horizon": 60.0},
    "implementation": {
        "sample_time": 0.05,
        "delay": 0.05,
        "noise": {"position": 0.02, "velocity": 0.0005, "heading": 0.002, "yaw_rate": 0.001},
    },
}


def _at(slots: SlotMotion, k: int) -> SlotMotion:
    return SlotMotion(p=slots.p[k], v=slots.v[k], a=slots.a[k])


def _line_run(delay: float, step: float = 0.1, horizon: float = 20.0):
    """A transit run from a start off the slots, in a cross current, with exact navigation ``delay`` s late."""
    cfg = transit()
    fleet = raw_fleet(cfg)
    plant = ThreeDofPlant(cfg.vehicle, cfg.actuators, np.array([0.0, 0.1]))
    start = slot_start(_at(slot_motion(fleet, np.array([0.0])), 0), plant.current)
    start[:, 1] += np.array([2.0, -1.0, 0.5])  # metres off the track
    start[:, 2] += 0.1
    run = run_cascade(cfg.guidance, cfg.vehicle, cfg.actuators, fleet, horizon, plant, start, step, Navigation(delay))
    return cfg, fleet, plant, start, run


def test_a_delay_of_whole_samples_acts_on_the_state_those_samples_before():
    cfg, fleet, plant, _, run = _line_run(0.2)
    lag = 2
    slots = slot_motion(fleet, run.t)
    for k in range(lag, run.t.size, 17):
        view = run.states[k - lag]
        slot = _at(slots, k - lag)
        cmd = commands(cfg.guidance, cfg.vehicle, cfg.actuators, view, run.integral[k], slot, plant.ground(view))
        np.testing.assert_allclose(run.thrust_cmd[k], cmd.thrust_cmd, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(run.rudder_cmd[k], cmd.rudder_cmd, rtol=1e-12, atol=1e-12)
    # before the first late measurement the law acts on the start
    x0 = run.states[0]
    first = commands(cfg.guidance, cfg.vehicle, cfg.actuators, x0, run.integral[1], _at(slots, 0), plant.ground(x0))
    np.testing.assert_allclose(run.thrust_cmd[1], first.thrust_cmd, rtol=1e-12, atol=1e-12)


def test_a_delay_of_half_a_sample_matches_a_run_on_the_half_sample_grid():
    cfg, fleet, plant, start, run = _line_run(0.05)
    step, half = 0.1, 0.05
    fine_t = np.arange(2 * (run.t.size - 1) + 1) * half
    slots = slot_motion(fleet, fine_t)
    x = np.array(start)
    yi = integral_start(cfg.guidance, x, _at(slots, 0))
    history = [x]  # the state on the half-sample grid
    for k in range(run.t.size - 1):
        seen = history[max(2 * k - 1, 0)]  # measured at t_k - 0.05 (the start before t = 0)
        cmd = commands(
            cfg.guidance, cfg.vehicle, cfg.actuators, seen, yi, _at(slots, max(2 * k - 1, 0)), plant.ground(seen)
        )
        np.testing.assert_allclose(run.thrust_cmd[k], cmd.thrust_cmd, rtol=1e-10, atol=1e-10)
        for _ in range(2):  # RK4 on the half-sample grid, the command held
            k1 = plant.derivative(x, cmd)
            k2 = plant.derivative(x + 0.5 * half * k1, cmd)
            k3 = plant.derivative(x + 0.5 * half * k2, cmd)
            k4 = plant.derivative(x + half * k3, cmd)
            x = x + half / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            history.append(x)
        yi = yi + step * cmd.integral_rate
    np.testing.assert_allclose(run.states[-1], x, rtol=1e-10, atol=1e-10)


def _navigation_fleet(**tables: dict):
    return transit(**{**NAVIGATION, **tables})


@pytest.mark.slow
def test_a_fleet_certified_with_delay_and_noise_stays_inside_on_every_noise_pattern():
    cfg = _navigation_fleet()
    summary = guidance_summary(cfg)
    assert summary.holds, summary.reason
    cert = summary.certificate
    box = cert.errors[:7]
    worst, peaks, heading = np.zeros(7), np.zeros(2), 0.0
    impl = cfg.implementation
    for i, pattern in enumerate(NOISE_PATTERNS):
        nav = Navigation(impl.delay, impl, seed=i, pattern=pattern)
        plant = ThreeDofPlant(cfg.vehicle, cfg.actuators, np.zeros(2))
        run = run_cascade(
            cfg.guidance, cfg.vehicle, cfg.actuators, raw_fleet(cfg), 60.0, plant, None, impl.sample_time, nav
        )
        worst = np.maximum(worst, np.abs(_states_along(cfg, run, np.zeros(2))).max(axis=(0, 1)))
        peaks = np.maximum(peaks, [np.abs(run.thrust_cmd).max(), np.abs(run.rudder_cmd).max()])
        heading = max(heading, float(np.abs(run.heading_error).max()))
    for name, w, b in zip(STATES, worst, box, strict=True):
        assert w <= b, f"{name}: simulated {w:.4g} above the certified {b:.4g}"
    assert peaks[0] <= cert.actuation.thrust and peaks[1] <= cert.actuation.rudder
    # the noise acted: on the nominal plant in still water, from the slots, only it moves the heading
    assert heading > 0.1 * impl.noise.heading


@pytest.mark.slow
def test_a_fleet_refused_for_its_navigation_is_answered_with_one_that_certifies_on_re_run():
    noisy = {
        **NAVIGATION["implementation"],
        "noise": {"position": 0.2, "velocity": 0.005, "heading": 0.02, "yaw_rate": 0.01},
    }
    cfg = _navigation_fleet(implementation=noisy)
    data = certify(cfg).to_dict()
    assert data["certified"] is False
    why = data["parts"]["guidance"]["reasons"][0]
    assert "navigation" in why["message"]
    settings = [(s["table"], s["key"], s["value"]) for s in why["settings"]]
    assert {t for t, _, _ in settings} <= {"implementation", "implementation.noise"}
    scale = data["guidance"]["largest_certifiable"]["navigation_scale"]
    assert 0.0 < scale < 1.0
    # every advised bound is a navigation some vehicle can have (none at zero), written as a short decimal
    assert all(0.0 < v == float(f"{v:.3g}") for t, _, v in settings if t == "implementation.noise")
    # also at a scale where four decimals wrote the heading and yaw-rate noise as 0 (a review's fleet)
    problem = cascade_problem(cfg, design_point(cfg))
    declared = {"delay": problem.delay, **problem.noise.to_dict()}
    for x in _navigation_settings(problem, 0.00879):
        want = declared[x.key] * 0.00879
        assert 0.99 * want <= x.value <= want and x.value == float(f"{x.value:.3g}"), (x.key, x.value, want)
    again = certify(with_settings(cfg, settings)).to_dict()
    assert again["certified"] is True and again["guidance"]["certified"] is True


@pytest.mark.slow
def test_cli_simulate_runs_the_late_noisy_cascade_and_judges_it_by_its_certificate(tmp_path, capsys):
    path = tmp_path / "navigation.toml"
    path.write_text(to_toml({**_navigation_table(), "simulation": {"horizon": 30.0, "noise_pattern": "bang-bang"}}))
    capsys.readouterr()
    assert main(["simulate", "--config", str(path), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["certificate_covers_run"] is True and rep["within_certified_bounds"] is True
    assert rep["sample_time"] == pytest.approx(0.05) and rep["delay"] == pytest.approx(0.05)
    assert rep["noise"]["heading"] == pytest.approx(0.002) and rep["noise_pattern"] == "bang-bang"


def _navigation_table() -> dict:
    return {**TRANSIT, **NAVIGATION}


def test_a_navigation_needs_a_finite_non_negative_delay():
    with pytest.raises(Exception, match="delay"):
        Navigation(-0.1)
    assert not Navigation(0.1).noisy
    assert Navigation(0.0, Implementation(0.1, noise=MeasurementNoise(heading=0.01))).noisy


@pytest.mark.slow
def test_a_navigation_that_refuses_the_nominal_plant_in_still_water_tries_no_cells():
    noisy = [("implementation", "delay", 0.1), ("implementation.noise", "heading", 0.01)]
    cfg = with_settings(preset_config("remus-transit-ilos"), [("implementation", "sample_time", 0.1), *noisy])
    problem = cascade_problem(cfg, design_point(cfg))
    cert = certify_cascade(problem)
    assert not cert.holds and "no cells tried" in cert.reason and cert.cells == 1


def test_the_cascade_runs_at_the_declared_sample_time_or_at_10_hz():
    from auv_hinf.guidance.simulation import STEP, cascade_period

    assert cascade_period(Implementation(0.05)) == 0.05 and cascade_period(Implementation()) == STEP == 0.1


def test_a_sample_time_too_long_for_the_cascade_is_answered_with_a_shorter_one_that_certifies_on_re_run():
    """At 2 s the nominal sampled cascade is unstable; the answer is the longest sample time between the
    default 0.1 s and the declared one that certifies (nothing else is declared to shrink), and it does."""
    cfg = transit(uncertainty={}, disturbance={}, simulation={"horizon": 60.0}, implementation={"sample_time": 2.0})
    data = certify(cfg).to_dict()
    assert data["certified"] is False
    why = data["parts"]["guidance"]["reasons"][0]
    assert [(s["table"], s["key"]) for s in why["settings"]] == [("implementation", "sample_time")]
    h = why["settings"][0]["value"]
    assert 0.1 <= h < 2.0 and h == data["guidance"]["largest_certifiable"]["sample_time"]
    assert "delay and noise" not in why["message"]  # neither is declared
    again = certify(with_settings(cfg, [("implementation", "sample_time", h)])).to_dict()
    assert again["certified"] is True
    longer = certify(with_settings(cfg, [("implementation", "sample_time", 1.1 * 1.07 * h)])).to_dict()
    assert longer["certified"] is False  # within the bisection's resolution (6 %) of the longest


@pytest.mark.slow
def test_a_late_sampled_fleet_in_still_water_is_answered_not_crashed_and_the_answer_certifies():
    """The transit's gains in still water, no box, 5 Hz on measurements 0.2 s old: the fixed points of
    the two treatments of the turn close, but their intersection is no operating region of the
    cascade (a bound that is not monotone in the box); the certificate then keeps a box that is one,
    and the refusal's navigation answer certifies when written back."""
    from dataclasses import replace

    from auv_hinf.config.settings import DisturbanceConfig, UncertaintyConfig

    base = preset_config("remus-transit-ilos")
    cfg = replace(
        base,
        uncertainty=UncertaintyConfig(()),
        disturbance=DisturbanceConfig(),
        simulation=replace(base.simulation, current=(0.0, 0.0)),
        implementation=Implementation(0.2, 0.2),
    )
    data = certify(cfg).to_dict()
    assert data["certified"] is False
    why = data["parts"]["guidance"]["reasons"][0]
    settings = [(s["table"], s["key"], s["value"]) for s in why["settings"]]
    assert settings and {t for t, _, _ in settings} <= {"implementation", "implementation.noise"}
    again = certify(with_settings(cfg, settings)).to_dict()
    assert again["certified"] is True and again["guidance"]["certified"] is True


@pytest.mark.slow
def test_a_navigation_and_a_sample_time_that_certify_only_together_are_answered_together():
    """The transit's box and current at 5 Hz on measurements 0.2 s old: no delay certifies at 5 Hz and the
    declared delay does not at 10 Hz; the answer gives both, and it certifies when written back."""
    cfg = with_settings(
        preset_config("remus-transit-ilos"), [("implementation", "sample_time", 0.2), ("implementation", "delay", 0.2)]
    )
    data = certify(cfg).to_dict()
    assert data["certified"] is False
    why = data["parts"]["guidance"]["reasons"][0]
    settings = [(s["table"], s["key"], s["value"]) for s in why["settings"]]
    assert ("implementation", "sample_time", 0.1) in settings and any(k == "delay" for _, k, _ in settings)
    best = data["guidance"]["largest_certifiable"]
    assert best["sample_time"] == 0.1 and 0.0 < best["navigation_scale"] < 1.0
    again = certify(with_settings(cfg, settings)).to_dict()
    assert again["certified"] is True and again["guidance"]["certified"] is True
