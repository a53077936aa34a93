"""From a configuration to a certified run (:mod:`auv_hinf.certificate.run_plan`).

The report's measured numbers are recomputed from the raw trajectory and the reference,
the measured decay rate from its documented definition, and the gains against the full
certificate.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import design_point, formation_offsets, initial_states
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.run_plan import (
    force_floor,
    guidance_run,
    measured_decay_rate,
    plan_run,
    run_report,
    with_start,
)
from auv_hinf.config.presets import TRIANGLE_SHAPE, preset_config
from auv_hinf.config.settings import FormationConfig, ReferenceConfig, SimulationConfig
from auv_hinf.exceptions import ConfigError, ParameterError
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import remus100
from auv_hinf.numerics.quadratic_forms import start_bounds
from auv_hinf.simulation.engine import simulate
from auv_hinf.simulation.metrics import DECAY_MEASURE_DROP

REPORT_KEYS = {
    "stayed_in_envelope",
    "first_exit_time",
    "start",
    "blend_time",
    "turn_time",
    "certificate_covers_run",
    "coverage_reason",
    "measured_decay_rate",
    "certified_decay_rate",
    "measured_errors",
    "certified_errors",
    "certified_thrust",
    "alpha",
    "k1",
    "k_psi",
    "final_shape_error",
    "max_sway",
    "horizon",
}
ERROR_KEYS = {"position_error", "velocity_error", "heading_error", "yaw_rate_error"}


@pytest.fixture(scope="module")
def triangle():
    cfg = preset_config("paper-triangle")
    return cfg, closed_loop_for(design_point(cfg))


def inside_start(cfg: FormationConfig, cert, rng: np.random.Generator, scale: float = 0.9) -> np.ndarray:
    """A start whose errors against the raw mission are ``scale`` times the region's radii."""
    fleet = design_point(cfg).fleet()
    m = fleet.motion(0.0)
    reg = cert.region.region
    th = rng.uniform(0, 2 * np.pi, (2, cfg.n))
    e = scale * reg.position * np.stack([np.cos(th[0]), np.sin(th[0])], -1)
    de = scale * reg.velocity * np.stack([np.cos(th[1]), np.sin(th[1])], -1)
    psi = m.psi + scale * reg.heading * rng.choice([-1.0, 1.0], cfg.n)
    vel = m.v + de
    c, s = np.cos(psi), np.sin(psi)
    r = m.r + scale * reg.yaw_rate * rng.choice([-1.0, 1.0], cfg.n)
    return np.column_stack([m.p + e, psi, c * vel[:, 0] + s * vel[:, 1], -s * vel[:, 0] + c * vel[:, 1], r])


@pytest.mark.slow
def test_run_report_keys_and_measured_errors(triangle, rng):
    cfg, cert = triangle
    x = inside_start(cfg, cert, rng)
    plan = plan_run(with_start(cfg, x), start="paper", horizon=20.0, samples=401)
    res = simulate(plan.scenario)
    rep = run_report(plan, res)
    assert REPORT_KEYS <= set(rep)
    assert set(rep["measured_errors"]) == ERROR_KEYS == set(rep["certified_errors"])
    assert rep["start"] == "paper" and rep["blend_time"] is None and rep["certificate_covers_run"] is True
    assert rep["stayed_in_envelope"] is True and rep["first_exit_time"] is None
    assert rep["alpha"] == plan.design.require_gains().alpha and rep["k1"] == cfg.k1
    # measured errors recomputed from the states and the raw mission
    motion = design_point(cfg).fleet().motion(res.t)
    st = res.states
    vel = np.stack(
        [
            np.cos(st[..., 2]) * st[..., 3] - np.sin(st[..., 2]) * st[..., 4],
            np.sin(st[..., 2]) * st[..., 3] + np.cos(st[..., 2]) * st[..., 4],
        ],
        -1,
    )
    dpsi = np.angle(np.exp(1j * (st[..., 2] - motion.psi)))
    want = {
        "position_error": np.linalg.norm(st[..., :2] - motion.p, axis=-1).max(),
        "velocity_error": np.linalg.norm(vel - motion.v, axis=-1).max(),
        "heading_error": np.abs(dpsi).max(),
        "yaw_rate_error": np.abs(st[..., 5] - motion.r).max(),
    }
    for k, v in want.items():
        assert rep["measured_errors"][k] == pytest.approx(v, rel=1e-9, abs=1e-12)
    # certified errors: the start's own ellipsoid bounds (largest over the vehicles)
    e0 = x[:, :2] - motion.p[0]
    de0 = vel[0] - motion.v[0]
    bounds = start_bounds(cert.region.p2, cert.region.q, e0, de0, dpsi[0], x[:, 5] - motion.r[0]).max(axis=0)
    for k, b in zip(("position_error", "velocity_error", "heading_error", "yaw_rate_error"), bounds):
        assert rep["certified_errors"][k] == pytest.approx(b, rel=1e-9)
        assert rep["measured_errors"][k] <= rep["certified_errors"][k] + 1e-6
    # the start region's force bound, each channel with the floor of a computed trajectory
    floor = force_floor(cfg.vehicle, plan.design.require_gains(), cfg.envelope)
    assert rep["certified_thrust"] == {k: b + floor[k] for k, b in plan.coverage.thrust.to_dict().items()}
    assert all(rep["commanded_peak"][k] <= rep["certified_thrust"][k] for k in floor)


@pytest.mark.slow
def test_a_run_from_exactly_on_its_slots_commands_no_more_than_its_certified_thrust():
    """A review's BlueROV2 line (the answer's small box), started exactly on its slots in still water: the start
    region is a point, certified the force at the reference alone (no sway force, no moment), and the simulation
    commands round-off above it (3e-5 N of surge, 6e-5 N of sway). The reported bound carries the floor."""
    cfg = preset_config("bluerov2-line")
    plan = plan_run(cfg, horizon=10.0)
    rep = run_report(plan, simulate(plan.scenario))
    assert rep["certificate_covers_run"] and rep["certified_errors_source"] == "closed_loop"
    exact = plan.coverage.thrust.to_dict()
    peak, bound = rep["commanded_peak"], rep["certified_thrust"]
    assert peak["force_y"] > exact["force_y"]  # not vacuous: the round-off is above the exact bound
    assert all(peak[k] <= bound[k] for k in bound), (peak, bound)
    assert all(bound[k] - exact[k] < 1e-3 * max(exact["force_x"], 1.0) for k in bound)  # and the floor is small


@pytest.mark.slow
def test_measured_decay_rate_matches_its_definition(triangle, rng):
    cfg, cert = triangle
    plan = plan_run(with_start(cfg, inside_start(cfg, cert, rng)), start="paper", horizon=40.0, samples=801)
    res = simulate(plan.scenario)
    cert = plan.certificate
    rate = measured_decay_rate(res, cert)
    p, q = cert.position.matrix, cert.heading.matrix
    tr = res.tracking
    rates = []
    for i in range(cfg.n):
        x = np.concatenate([tr.e[:, i], tr.e_dot[:, i]], -1)  # (T, 4) = (e, e')
        big_p = np.kron(p, np.eye(2))
        z = np.stack([tr.e_psi[:, i], tr.e_psi_dot[:, i]], -1)
        v = np.einsum("ti,ij,tj->t", x, big_p, x) + np.einsum("ti,ij,tj->t", z, q, z)
        k = int(np.argmax(v <= DECAY_MEASURE_DROP * v[0]))
        assert k > 0, "the run is too short to see the drop"
        rates.append(0.5 * math.log(v[0] / v[k]) / res.t[k])
    assert rate == pytest.approx(min(rates), rel=1e-9)
    assert rate >= cert.rate
    assert run_report(plan, res)["measured_decay_rate"] == rate


@pytest.mark.slow
def test_measured_decay_is_none_for_the_shaped_start(triangle):
    cfg, cert = triangle
    plan = plan_run(cfg, horizon=30.0, samples=301)
    assert plan.start == "shaped" and plan.coverage is not None and plan.coverage.blend_time is not None
    res = simulate(plan.scenario)
    rep = run_report(plan, res)
    assert measured_decay_rate(res, cert) is None and rep["measured_decay_rate"] is None
    assert rep["certified_decay_rate"] == cert.rate
    assert rep["certificate_covers_run"] is True and rep["stayed_in_envelope"] is True
    assert rep["measured_errors"]["position_error"] < 1e-4


@pytest.mark.slow
@pytest.mark.parametrize(
    "change, note",
    [
        ({"plant": {"d11_lin": 1.2, "m22": 0.9}}, "plant differs"),
        ({"current": (0.05, -0.02)}, "current"),
    ],
)
def test_plant_mismatch_or_current_is_not_covered(triangle, rng, change, note):
    cfg, cert = triangle
    x = inside_start(cfg, cert, rng)
    sim = SimulationConfig(initial=tuple(map(tuple, x.tolist())), start="paper", **change)
    plan = plan_run(replace(cfg, simulation=sim), horizon=10.0, samples=101)
    assert plan.coverage is not None and plan.coverage.covered  # the start alone would be covered
    assert not plan.covered
    assert any(note in n for n in plan.notes)
    rep = run_report(plan, simulate(plan.scenario))
    assert rep["certificate_covers_run"] is False and note in rep["coverage_reason"]


@pytest.mark.slow
@pytest.mark.parametrize("which", ["paper-triangle", "paper-hexagon", "remus-line"])
def test_design_gains_agree_with_certify(which):
    if which == "remus-line":
        cfg = FormationConfig(
            name="remus",
            vehicle=remus100(),
            n=3,
            jacobi="paper",
            shape=TRIANGLE_SHAPE,
            envelope=Envelope(u=(0.5, 2.5), v=(-0.3, 0.3), r=(-0.3, 0.3)),
            reference=ReferenceConfig("line", {"speed": 1.5}),
        )
    else:
        cfg = preset_config(which)
    point = design_point(cfg)
    cert = certify(cfg)
    assert point.gains == cert.gains and point.source == cert.gain_source
    if point.source == "theorem1":
        assert point.require_gains().alpha == pytest.approx(cert.alpha_used, rel=1e-12)
    assert point.lam == pytest.approx(cert.lam, rel=1e-12)
    assert point.sigma.upper == pytest.approx(cert.sigma.upper, rel=1e-12)
    assert point.gamma == pytest.approx(cert.gamma, rel=1e-12)
    assert cert.closed_loop is not None and cert.closed_loop.certificate is not None
    assert cert.closed_loop.certificate.rate == pytest.approx(closed_loop_for(design_point(cfg)).rate, rel=1e-12)


def test_initial_states_and_offsets(triangle):
    cfg, _ = triangle
    np.testing.assert_array_equal(initial_states(design_point(cfg)), np.asarray(cfg.simulation.initial))
    off = formation_offsets(cfg)
    # paper Jacobi convention: rho_j = mean(p_1..p_j) - p_{j+1}, centroid at zero
    np.testing.assert_allclose(off.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(off[0] - off[1], TRIANGLE_SHAPE[0], atol=1e-12)
    np.testing.assert_allclose(0.5 * (off[0] + off[1]) - off[2], TRIANGLE_SHAPE[1], atol=1e-12)


def test_the_api_refuses_what_is_not_a_configuration_or_a_start_with_its_own_errors():
    """A wrong argument to the API is one of the package's errors, with what was expected, not an AttributeError."""
    import auv_hinf
    from auv_hinf.exceptions import ConfigError, ParameterError
    from auv_hinf.simulation.engine import simulate

    for bad in (None, "paper-triangle", 3.0):
        with pytest.raises(ConfigError, match="expected a configuration"):
            auv_hinf.certify(bad)
        with pytest.raises(ConfigError, match="expected a configuration"):
            auv_hinf.plan_run(bad)
    with pytest.raises(ConfigError, match="start must be one of"):
        auv_hinf.plan_run(auv_hinf.preset_config("paper-triangle"), start="bogus")
    with pytest.raises(ParameterError, match="expected a Scenario"):
        simulate(None)


@pytest.mark.slow
def test_plan_run_sends_a_guided_fleet_to_its_cascade_and_checks_its_arguments():
    """A torpedo fleet steered by [guidance] is not planned with the fully actuated law (a review's plan_run +
    simulate ran that law, commanding 67 N of sway the vehicle has not); bad arguments are the package's errors."""
    guided = preset_config("remus-transit-ilos")
    with pytest.raises(ConfigError, match=r"guidance_run\(cfg\)"):
        plan_run(guided)
    tri = preset_config("paper-triangle")
    with pytest.raises(ParameterError, match="horizon"):
        plan_run(tri, horizon="10")
    with pytest.raises(ParameterError, match="horizon"):
        plan_run(tri, horizon=-1.0)
    with pytest.raises(ParameterError, match="samples"):
        plan_run(tri, samples=1)
    with pytest.raises(ConfigError, match="expected a configuration"):
        guidance_run("remus-transit-ilos")
    with pytest.raises(ParameterError, match="horizon"):
        guidance_run(guided, horizon="5")
    run = guidance_run(guided, horizon=2.0)  # the cascade the message names runs the fleet
    assert run.report()["commanded_peak"].keys() == {"force_x", "rudder"}


@pytest.mark.slow
def test_the_public_calls_refuse_bad_arguments_with_the_packages_errors(tmp_path):
    """What a notebook user mistypes is an AuvHinfError naming the argument, never a bare AssertionError,
    ValueError or numpy error from deep inside (a review's list)."""
    from auv_hinf import certify as certify_api
    from auv_hinf import load_config
    from auv_hinf import simulate as simulate_api

    tri = preset_config("paper-triangle")
    for bad in (0, -1, "a", True):
        with pytest.raises(ParameterError, match="jacobi_samples"):
            certify_api(tri, jacobi_samples=bad)
    with pytest.raises(ParameterError, match="refine_jacobi"):
        certify_api(tri, refine_jacobi="yes")
    with pytest.raises(ConfigError, match="path of a TOML"):
        load_config(5)
    plan = plan_run(tri, horizon=1.0, samples=11)
    for kw, word in (
        ({"rtol": "a"}, "rtol"),
        ({"rtol": -1.0}, "rtol"),
        ({"atol": 0.0}, "atol"),
        ({"subdivisions": 0}, "subdivisions"),
    ):
        with pytest.raises(ParameterError, match=word):
            simulate_api(plan.scenario, **kw)
    cert = certify_api(tri)
    for bad in ("x", 3):
        with pytest.raises(ParameterError, match="reference"):
            cert.controller(reference=bad)
    assert cert.controller(reference=plan.scenario.reference).noutputs == 3 * tri.n
    # numbers of numpy's and of Python's alike: integers and reals accepted, truth values, complex and huge refused
    assert certify_api(tri, jacobi_samples=np.int64(10)).certified
    assert plan_run(tri, horizon=np.float64(1.0), samples=np.int64(11)).scenario.horizon == 1.0
    for bad in (np.True_, 5 + 3j, np.complex128(5 + 3j), 10**400, np.array(["1"])):
        with pytest.raises(ParameterError, match="horizon"):
            plan_run(tri, horizon=bad)
    guided = preset_config("remus-transit-ilos")
    for kw in (
        {"current": (0.0, 0.5, 1.0)},
        {"current": "ab"},
        {"plant": "x"},
        {"noise": (-1, "uniform")},
        {"noise": (5,)},
        {"noise": 5},
        {"noise": ("5", "uniform")},
        {"noise": (5.5, "uniform")},
        {"noise": (5, "loud")},
    ):
        with pytest.raises(ParameterError):
            guidance_run(guided, horizon=1.0, **kw)
    with pytest.raises(ConfigError, match="DesignPoint"):
        plan_run(tri, design="x")
