"""The line-of-sight cascade: closed-form steady states, limits, the configuration and the CLI."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from auv_hinf.actuation.limits import vehicle_actuators
from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.run_plan import guidance_run
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import ReferenceConfig, SimulationConfig, config_from_dict, with_settings
from auv_hinf.exceptions import ConfigError, ParameterError
from auv_hinf.guidance.law import GuidanceConfig, SlotMotion
from auv_hinf.guidance.simulation import simulate_guidance
from auv_hinf.mission.fleet import FleetReference, reference_from_dict
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import remus100
from tests.helpers import preset_certificate, to_toml

REMUS = remus100()
RUDDER = vehicle_actuators("remus100")
SPEED = 1.5  # m/s, the REMUS cruise speed


def line_fleet(n: int = 1, heading: float = 0.0) -> FleetReference:
    """``n`` slots 20 m apart across a straight line at the cruise speed."""
    offsets = np.column_stack([np.zeros(n), 20.0 * np.arange(n)])
    return FleetReference(reference_from_dict("line", speed=SPEED, heading=heading), offsets, None, "path")


def steady(kind: str, current: tuple[float, float], plant=REMUS, horizon: float = 400.0, lookahead: float = 8.0):
    g = GuidanceConfig(kind=kind, lookahead=lookahead)
    return g, simulate_guidance(g, plant, REMUS, RUDDER, line_fleet(), horizon, current)


@pytest.mark.slow
@pytest.mark.parametrize("c", [0.1, 0.2, -0.15])
def test_los_leaves_the_closed_form_offset_of_a_cross_current(c):
    # At rest in the path frame v = 0 and r = 0, so the ground velocity across the track,
    # u sin(psi - gamma) + c, vanishes while the along-track one, u cos(psi - gamma), is U:
    # tan(atan(y_e / Delta)) = c / U, i.e. y_e = Delta c / U.
    g, run = steady("los", (0.0, c))
    assert run.cross_track[-1, 0] == pytest.approx(g.lookahead * c / SPEED, rel=2e-3)
    assert abs(run.along_track[-1, 0]) < 1e-3
    assert run.report()["saturation_fraction"] == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("c", [(0.0, 0.2), (0.0, -0.2), (0.1, 0.17)])
def test_ilos_removes_the_cross_track_offset_of_a_constant_current(c):
    g, run = steady("ilos", c)
    assert abs(run.cross_track[-1, 0]) < 0.1  # the target
    assert abs(run.cross_track[-1, 0]) < 1e-3  # and in fact it goes to zero
    # the integrator holds the crab angle: the water speed is U - c_along along the track, so
    # sigma y_i = Delta tan(crab) = Delta c_across / (U - c_along)
    crab = c[1] / (SPEED - c[0])
    assert g.integral_gain * run.integral[-1, 0] == pytest.approx(g.lookahead * crab, rel=2e-3)
    assert run.report()["saturation_fraction"] == 0.0


@pytest.mark.slow
@pytest.mark.parametrize(
    "scale",
    [
        {"m11": 1.1, "m22": 0.9, "m33": 1.1, "d22_lin": 0.8, "d33_lin": 1.2},
        {"m11": 0.9, "m22": 1.1, "m33": 0.9, "d11_quad": 1.2, "d22_quad": 0.8, "d33_quad": 0.8},
    ],
)
def test_ilos_holds_a_box_corner_plant_in_a_current(scale):
    plant = replace(REMUS, **{k: getattr(REMUS, k) * m for k, m in scale.items()})
    g, run = steady("ilos", (0.0, 0.2), plant=plant, horizon=500.0)
    rep = run.report()
    assert abs(run.cross_track[-1, 0]) < 1e-3
    # along the track the surge loop is proportional: a drag the model does not know, dD (N) at the
    # water speed u = |(U, 0) - c|, is held by m11 k_u k_x sat(x_e) = -dD, sat(x) = x / sqrt(1 + (x/L)^2)
    u = np.hypot(SPEED, 0.2)
    drag = (plant.damping(u, 0.0, 0.0)[0] - REMUS.damping(u, 0.0, 0.0)[0]) * u
    q = -float(drag) / (REMUS.m11 * g.speed_gain * g.along_track_gain)
    assert run.along_track[-1, 0] == pytest.approx(q / np.sqrt(1.0 - (q / g.along_track_length) ** 2), abs=1e-3)
    assert rep["saturation_fraction"] == 0.0 and rep["commanded_peak"]["rudder"] < RUDDER.rudder_max


@pytest.mark.slow
def test_the_report_says_whether_and_when_the_run_left_the_envelope():
    """A LOS run in a cross current: inside a wide envelope; a surge range below the cruise speed is left at once,
    a yaw-rate range that the turn onto the crab exceeds is left at the first sample above it."""
    _, run = steady("los", (0.0, 0.1), horizon=40.0)
    wide = Envelope(u=(0.0, 2.5), v=(-1.0, 1.0), r=(-1.0, 1.0))
    rep = run.report(envelope=wide)
    assert rep["stayed_in_envelope"] is True and rep["first_exit_time"] is None
    slow = replace(wide, u=(0.0, 1.0))
    assert run.report(envelope=slow)["stayed_in_envelope"] is False and run.envelope_exit(slow) == run.t[0]
    r_peak = float(np.abs(run.states[:, 0, 5]).max())
    assert r_peak > 0.0
    tight = replace(wide, r=(-0.5 * r_peak, 0.5 * r_peak))
    first = int(np.flatnonzero(np.abs(run.states[:, 0, 5]) > 0.5 * r_peak)[0])
    assert run.envelope_exit(tight) == run.t[first] > run.t[0]
    assert run.report()["stayed_in_envelope"] is None  # no envelope given: no verdict


@pytest.mark.slow
def test_the_limits_hold_and_the_command_is_reported_before_them():
    # a start 30 m off the track and 90 degrees off course asks for more than full rudder
    g = GuidanceConfig()
    start = np.array([[0.0, 30.0, np.pi / 2, 1.0, 0.0, 0.0]])
    run = simulate_guidance(g, REMUS, REMUS, RUDDER, line_fleet(), 200.0, (0.0, 0.0), start)
    rep = run.report()
    assert np.all(np.abs(run.rudder) <= RUDDER.rudder_max) and np.all(np.abs(run.thrust) <= RUDDER.tau_x)
    assert rep["commanded_peak"]["rudder"] > RUDDER.rudder_max and 0.0 < rep["saturation_fraction"] < 1.0
    assert rep["delivered_peak"]["rudder"] == pytest.approx(RUDDER.rudder_max)
    assert abs(run.cross_track[-1, 0]) < 0.05  # and it still converges onto the track


@pytest.mark.slow
def test_min_separation_is_the_closest_approach_of_the_pair():
    g = GuidanceConfig()
    run = simulate_guidance(g, REMUS, REMUS, RUDDER, line_fleet(3), 60.0, (0.0, 0.1))
    d, pair = run.min_separation()
    p = run.states[:, :, :2]
    brute = min(np.hypot(*(p[:, i] - p[:, j]).T).min() for i in range(3) for j in range(i + 1, 3))
    assert d == pytest.approx(brute) and pair in ((0, 1), (1, 2))


def test_min_separation_of_a_large_fleet_holds_no_table_of_every_pair():
    import dataclasses
    import tracemalloc

    run = simulate_guidance(GuidanceConfig(), REMUS, REMUS, RUDDER, line_fleet(2), 0.2, (0.0, 0.0))
    rng = np.random.default_rng(3)
    samples, n = 20, 600  # 180,000 pairs a sample: a table of them all is 29 MB per sample array
    big = dataclasses.replace(run, states=rng.uniform(-500.0, 500.0, size=(samples, n, 6)))
    tracemalloc.start()
    d, (i, j) = big.min_separation()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6  # the positions' size times a few, not samples x pairs (a 2000-vehicle run was killed)
    p = big.states[:, :, :2]
    brute = min(
        float(np.hypot(*(p[k, :, None] - p[k, None, :]).T)[np.triu_indices(n, 1)].min()) for k in range(samples)
    )
    assert d == pytest.approx(brute) and d == pytest.approx(float(np.hypot(*(p[:, i] - p[:, j]).T).min()))


def test_bad_gains_are_refused_with_the_key():
    for kw in ({"lookahead": 0.0}, {"integral_gain": -1.0}, {"kind": "pure-pursuit"}, {"along_track_gain": -0.1}):
        with pytest.raises(ParameterError, match="guidance"):
            GuidanceConfig(**kw)


def test_guidance_needs_a_rudder_vehicle_and_round_trips():
    cfg = preset_config("remus-survey-ilos")
    data = cfg.to_toml_dict()
    assert config_from_dict(data, "x").guidance == cfg.guidance
    with pytest.raises(ConfigError, match="underactuated"):
        config_from_dict({**data, "actuators": {"tau_x": 10.0, "tau_y": 10.0, "tau_psi": 1.0}}, "x")
    with pytest.raises(ConfigError, match="lookahead"):
        config_from_dict({**data, "guidance": {"lookahead": -2.0}}, "x")


@pytest.mark.slow
def test_the_survey_v_is_not_certified_and_its_formation_law_is_not_evaluated():
    cfg = preset_config("remus-survey-ilos")
    data = preset_certificate("remus-survey-ilos").to_dict()  # shared with the other tests of the preset
    assert data["certified"] is False
    assert data["guidance"]["certified"] is False and data["guidance"]["error_bounds"] is None
    assert data["actuators"]["certified_peak"] == {"force_x": None, "rudder": None}
    assert data["formation"]["min_separation_certified"] is None
    for name in ("theorem1", "closed_loop", "robust", "implementation"):
        assert data["parts"][name]["applies"] is False
    assert [r["part"] for r in data["parts"]["guidance"]["reasons"]] == ["guidance"]
    # neither a smaller current, a smaller box nor the gains tried certify: the answer says the mission
    # binds, with wider turns and the current and box it certifies with; re-run, they certify
    why = data["parts"]["guidance"]["reasons"][0]
    answer = data["guidance"]["largest_certifiable"]["mission"]
    assert "mission binds" in why["message"] and why["settings"] == answer["settings"]
    written = {(s["table"], s["key"]): s["value"] for s in why["settings"]}
    assert written[("reference", "turn_radius")] > cfg.reference.kwargs()["turn_radius"]
    assert 0.0 < answer["scale"] < 1.0
    assert 0.0 < written[("disturbance", "current_speed")] <= answer["scale"] * cfg.disturbance.current_speed
    # the mission, the world scaled, and the gains of the candidates that certify the largest share of it
    # (and the configured run's current, which the preset runs above the advised bound, brought inside it)
    assert (
        {"reference", "disturbance", "uncertainty"}
        <= {t for t, _ in written}
        <= {
            "reference",
            "disturbance",
            "uncertainty",
            "guidance",
            "simulation",
        }
    )
    run_current = written.get(("simulation", "current"), cfg.simulation.current)
    assert float(np.hypot(*run_current)) <= written[("disturbance", "current_speed")]
    again = certify(with_settings(cfg, [(t, k, v) for (t, k), v in written.items()])).to_dict()
    assert again["guidance"]["certified"] is True
    assert again["guidance"]["error_bounds"]["cross_track"] <= answer["position_bound"]


@pytest.mark.slow
def test_cli_simulate_and_certify_of_a_guidance_file(tmp_path, capsys):
    cfg = preset_config("remus-survey-ilos")
    data = cfg.to_toml_dict()
    data["simulation"] = {"horizon": 40.0, "current": [0.0, 0.2]}
    data["reference"] = {"kind": "line", "speed": SPEED, "heading": 0.3}
    path = tmp_path / "torpedo.toml"
    path.write_text(to_toml(data))
    capsys.readouterr()
    # a cascade its certificate does not hold for is run only when asked, as the formation law's gains
    code = main(["simulate", "--config", str(path), "--json"])
    out, err = capsys.readouterr()
    assert code == 1 and json.loads(out)["ok"] is False and "refusing to simulate" in out and "--uncertified" in out
    code = main(["simulate", "--config", str(path), "--json", "--out", str(tmp_path / "out"), "--uncertified"])
    out, err = capsys.readouterr()
    assert code == 1 and "Traceback" not in err and "not certified" in err
    rep = json.loads(out)
    assert set(rep["commanded_peak"]) == {"force_x", "rudder"}
    assert set(rep["measured_errors"]) == {"along_track", "cross_track", "heading"}
    assert rep["certificate_covers_run"] is False and rep["min_separation"] > 0.0
    assert 0.0 <= rep["saturation_fraction"] <= 1.0
    assert {p.name for p in (tmp_path / "out").iterdir()} >= {"paths.png", "errors.png", "actuators.png"}
    code = main(["certify", "--config", str(path), "--json"])
    out, err = capsys.readouterr()
    assert code == 1 and json.loads(out)["certified"] is False and "Traceback" not in err
    code = main(["simulate", "--config", str(path), "--start", "paper"])
    _, err = capsys.readouterr()
    assert code == 2 and "guidance" in err


@pytest.mark.slow
def test_guidance_run_follows_the_configuration():
    cfg = replace(
        preset_config("remus-survey-ilos"),
        reference=ReferenceConfig("line", (("speed", SPEED), ("heading", 0.0))),
        simulation=SimulationConfig(horizon=300.0, current=(0.0, 0.15), plant=(("m22", 1.1),)),
    )
    run = guidance_run(cfg)
    assert run.t[-1] == pytest.approx(300.0) and run.states.shape[1] == cfg.n
    assert np.max(np.abs(run.cross_track[-1])) < 0.1


@pytest.mark.slow
def test_the_python_control_export_is_the_cascade(rng):
    from auv_hinf.guidance.export import VEHICLE_INPUTS, guidance_controller
    from auv_hinf.guidance.law import SlotMotion, commands

    g, fleet = GuidanceConfig(), line_fleet(3, heading=0.4)
    sys = guidance_controller(g, REMUS, RUDDER, fleet)
    assert (sys.nstates, sys.ninputs, sys.noutputs) == (3, 3 * len(VEHICLE_INPUTS), 6) and sys.dt == 0
    for _ in range(5):
        t = float(rng.uniform(0.0, 100.0))
        (p, v, a, _), _ = fleet.kinematics(np.asarray(t))
        states = np.column_stack([p + rng.normal(0, 3, (3, 2)), rng.normal(0.4, 0.3, 3), rng.uniform(0.5, 2, 3),
                                  rng.normal(0, 0.05, (3, 2))])  # fmt: skip
        ground = rng.normal(0.0, 1.0, (3, 2))
        yi = rng.normal(0.0, 2.0, 3)
        u = np.hstack([states, ground]).ravel()
        cmd = commands(g, REMUS, RUDDER, states, yi, SlotMotion(p, v, a), ground)
        np.testing.assert_allclose(sys.dynamics(t, yi, u), cmd.integral_rate, rtol=1e-12)
        np.testing.assert_allclose(sys.output(t, yi, u), np.column_stack([cmd.thrust, cmd.rudder]).ravel(), rtol=1e-12)
    cert_sys = certify(
        replace(preset_config("remus-survey-ilos"), simulation=SimulationConfig(horizon=30.0))
    ).controller()
    assert cert_sys.noutputs == 2 * 5 and cert_sys.output_labels[:2] == ["thrust[0]", "rudder[0]"]
    assert cert_sys.dt == pytest.approx(0.1)  # the cascade as it runs: the 10 Hz its certificate covers


@pytest.mark.slow
def test_the_discrete_export_reproduces_a_delayed_run_sample_by_sample():
    """Fed the measured states and ground velocities of a run (0.2 s period, 0.4 s delay: two samples in
    flight, 5 m off the slots in a 0.2 m/s cross current), the discrete controller gives the run's thrust,
    rudder and ILOS states at every sample."""
    import control as ct

    from auv_hinf.certificate.design_point import raw_fleet
    from auv_hinf.guidance.export import sampled_guidance_controller
    from auv_hinf.implementation.model import Implementation

    current = (0.0, 0.2)
    cfg = replace(preset_config("remus-survey-ilos"), simulation=SimulationConfig(horizon=30.0, current=current))
    start = guidance_run(replace(cfg, simulation=replace(cfg.simulation, horizon=0.2))).states[0].copy()
    start[:, 1] += 5.0
    cfg = replace(
        cfg,
        simulation=replace(cfg.simulation, initial=tuple(tuple(map(float, row)) for row in start)),
        implementation=Implementation(0.2, 0.4),
    )
    run = guidance_run(cfg)
    n = cfg.n
    sys = sampled_guidance_controller(cfg.guidance, cfg.vehicle, cfg.actuators, raw_fleet(cfg), 0.2, 0.4)
    assert sys.dt == pytest.approx(0.2) and sys.nstates == n + 2 * 8 * n
    psi, u, v = run.states[..., 2], run.states[..., 3], run.states[..., 4]
    ground = np.stack(
        [u * np.cos(psi) - v * np.sin(psi) + current[0], u * np.sin(psi) + v * np.cos(psi) + current[1]], -1
    )
    inputs = np.concatenate([run.states, ground], axis=-1).reshape(len(run.t), -1)
    x0 = np.concatenate([run.integral[0], inputs[0], inputs[0]])  # the start measured until t = d
    resp = ct.input_output_response(sys, run.t, inputs.T, x0)
    outputs = resp.outputs.T.reshape(len(run.t), n, 2)
    np.testing.assert_allclose(outputs[..., 0], run.thrust, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(outputs[..., 1], run.rudder, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(resp.states[:n].T, run.integral, rtol=1e-9, atol=1e-12)
    assert np.ptp(run.rudder) > 0.01 and np.abs(run.integral).max() > 0.0  # a transient, not a trivial run


@pytest.mark.parametrize(
    "command",
    [
        ["fleet-sim", "--listen", "udpin:127.0.0.1:0"],
        ["campaign", "--runs", "2", "--out", "OUT", "--workers", "2"],
        ["campaign", "--runs", "2", "--out", "OUT", "--chunk", "1"],
    ],
)
def test_commands_of_the_formation_law_refuse_a_guidance_fleet(command, tmp_path, capsys):
    capsys.readouterr()
    code = main([str(tmp_path / "out") if c == "OUT" else c for c in command] + ["--preset", "remus-survey-ilos"])
    _, err = capsys.readouterr()
    assert code == 2 and "Traceback" not in err and ("[guidance]" in err or "a [guidance] one" in err)
    assert err.count("\n") == 1


@pytest.mark.slow
def test_the_cascade_runs_at_the_declared_sample_time_delay_and_noise_and_refuses_a_varying_delay():
    from auv_hinf.implementation.model import Implementation, MeasurementNoise

    cfg = replace(preset_config("remus-survey-ilos"), simulation=SimulationConfig(horizon=60.0, current=(0.0, 0.2)))
    start = guidance_run(replace(cfg, simulation=replace(cfg.simulation, horizon=0.1))).states[0].copy()
    start[:, 1] += 5.0  # 5 m off the slots: a transient for the hold to shape
    initial = tuple(tuple(map(float, row)) for row in start)
    cfg = replace(cfg, simulation=replace(cfg.simulation, initial=initial))
    runs = {h: guidance_run(replace(cfg, implementation=Implementation(h))) for h in (0.4, 0.2)}
    base = guidance_run(cfg)  # 10 Hz
    assert np.allclose(np.diff(runs[0.4].t), 0.4) and runs[0.4].report()["sample_time"] == pytest.approx(0.4)
    gap = {h: np.abs(r.cross_track - base.cross_track[:: round(h / 0.1)]).max() for h, r in runs.items()}
    assert 0.0 < gap[0.2] < gap[0.4]  # a slower hold moves the run further from the 10 Hz one
    # a late, noisy navigation is run (tests/guidance/test_navigation.py), a varying delay refused
    late = guidance_run(replace(cfg, implementation=Implementation(0.1, 0.3, False, MeasurementNoise(heading=0.01))))
    assert np.abs(late.cross_track - base.cross_track).max() > 0.0
    with pytest.raises(ConfigError, match="fixed"):
        guidance_run(replace(cfg, implementation=Implementation(0.1, 0.05, True)))


def test_ilos_starts_in_the_crab_of_the_current_and_holds_the_line_from_the_start():
    from auv_hinf.guidance.law import MAX_START_CRAB, SlotMotion, integral_start

    g, run = steady("ilos", (0.0, 0.2), horizon=60.0)
    assert np.abs(run.cross_track).max() < 1e-6 and np.abs(run.heading_error).max() < 1e-6
    crab = np.arctan(0.2 / SPEED)  # the start heads into the current, its ground velocity the slot's
    assert run.integral[0, 0] == pytest.approx(g.lookahead * np.tan(crab) / g.sigma, rel=1e-9)
    slot = SlotMotion(p=np.zeros((3, 2)), v=np.array([[SPEED, 0.0]] * 3), a=np.zeros((3, 2)))
    states = np.zeros((3, 6))
    states[:, 2] = [0.1, MAX_START_CRAB + 0.01, -2.0]
    yi = integral_start(g, states, slot)
    assert yi[0] == pytest.approx(g.lookahead * np.tan(-0.1) / g.sigma) and yi[1] == yi[2] == 0.0
    assert np.all(integral_start(GuidanceConfig(kind="los"), states, slot) == 0.0)


def test_a_slots_track_frame_takes_its_own_velocity_along_and_its_left_normal_across():
    rng = np.random.default_rng(3)
    v = rng.normal(0.0, 1.5, (6, 2))
    slot = SlotMotion(rng.normal(0.0, 10.0, (6, 2)), v, rng.normal(0.0, 0.1, (6, 2)))
    along, across = slot.along_across(v[:, 0], v[:, 1])
    np.testing.assert_allclose(along, np.hypot(v[:, 0], v[:, 1]), rtol=1e-12)
    np.testing.assert_allclose(across, 0.0, atol=1e-12)
    along, across = slot.along_across(-v[:, 1], v[:, 0])  # the velocity turned 90 degrees left
    np.testing.assert_allclose((along, across), (0.0 * along, np.hypot(v[:, 0], v[:, 1])), atol=1e-12)
    x, y = rng.normal(size=6), rng.normal(size=6)
    a, c = slot.along_across(x, y)
    np.testing.assert_allclose(a * a + c * c, x * x + y * y, rtol=1e-12)  # a rotation: lengths kept


@pytest.mark.slow
def test_simulate_out_draws_the_certified_bounds_of_a_covered_run(tmp_path, capsys, monkeypatch):
    import auv_hinf.figures.guidance as figures

    drawn = []
    original = figures.guidance_errors

    def spy(run, bounds=None):
        drawn.append(bounds)
        return original(run, bounds)

    monkeypatch.setattr(figures, "guidance_errors", spy)
    code = main(["simulate", "--preset", "remus-transit-ilos", "--horizon", "20", "--json", "--out", str(tmp_path)])
    rep = json.loads(capsys.readouterr().out)
    assert code == 0 and rep["certificate_covers_run"] is True
    assert drawn == [rep["certified_errors"]] and (tmp_path / "errors.png").is_file()


@pytest.mark.slow
def test_certify_out_of_a_guidance_fleet_draws_its_certificate_and_names_the_current_it_holds_in(tmp_path, capsys):
    cfg = preset_config("remus-transit-ilos")
    capsys.readouterr()
    assert main(["certify", "--preset", "remus-transit-ilos", "--json", "--out", str(tmp_path)]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["guidance"]["current_speed"] == pytest.approx(cfg.disturbance.current_speed)
    assert {p.name for p in tmp_path.iterdir()} == {"certificate.json", "guidance_certificate.png"}
