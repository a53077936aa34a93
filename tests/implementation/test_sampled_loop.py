"""The sampled-data loop: ZOH at the sample instants, delayed and noisy measurements, seeded draws."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from auv_hinf.certificate.run_plan import plan_run
from auv_hinf.config.presets import preset_config
from auv_hinf.implementation.draws import ImplementationDraws, noise_from_uniforms, noise_generator
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.implementation.sampled_loop import SNAP, control_period, integrate_sampled
from auv_hinf.models.vehicle import ground_velocity, rhs
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR
from auv_hinf.simulation import engine
from auv_hinf.simulation.engine import fleet_derivative, simulate, simulate_batch
from auv_hinf.simulation.scenario import ScenarioBatch
from tests.helpers import fully_actuated
from tests.implementation.sampled_reference import reference_loop

NOISE = MeasurementNoise(position=0.05, velocity=0.02, heading=0.01, yaw_rate=0.005)
#: Runs of one batch against the same runs alone: only BLAS round-off in the stage sums differs.
ROUND_OFF = 1e-9
#: Relative agreement of the held forces with the independent loop: its states agree to about
#: 5e-8 (m, m/s), and the law's gains turn that into ~1e-8 relative force differences.
FORCE_AGREEMENT = 1e-6


@pytest.fixture(scope="module")
def triangle():
    """The paper triangle over 20 s, an output every 0.05 s."""
    return plan_run(preset_config("paper-triangle"), horizon=20.0, samples=401).scenario


def _run(scn, impl, **kw):
    return integrate_sampled(ScenarioBatch((replace(scn, implementation=impl),)), **kw)


@pytest.mark.slow
@pytest.mark.parametrize(
    "impl",
    [
        Implementation(0.1, 0.1, noise=NOISE),  # delay a multiple of h
        Implementation(0.1, 0.05, noise=NOISE),  # measurement between the samples
        Implementation(0.1, 0.15, varying_delay=True, noise=NOISE),  # any delay in [0, 0.15]
    ],
    ids=["delay=h", "delay=h/2", "varying"],
)
def test_held_forces_are_the_law_at_the_measurement_and_match_an_independent_loop(triangle, impl):
    scn = replace(triangle, implementation=impl)
    sol = _run(triangle, impl, trace=True)
    tr = sol.trace
    at = tr.measured_at[0]
    if impl.varying_delay:
        assert np.all((at >= np.maximum(tr.times - impl.delay, 0.0)) & (at <= tr.times))
        assert np.ptp(tr.times - at) > 0.5 * impl.delay  # the delays do vary
    else:
        assert_array_equal(at, np.maximum(tr.times - impl.delay, 0.0))
    # scipy DOP853 at 1e-12, the law evaluated independently on its own state at s_k (+ the same noise)
    ref, forces = reference_loop(scn, tr.times, at, tr.noise[0], sol.t)
    assert_allclose(tr.forces[0], forces, rtol=FORCE_AGREEMENT, atol=FORCE_AGREEMENT)
    assert np.abs(sol.y[:, 0].reshape(ref.shape) - ref).max() < NUMERICAL_FLOOR
    # zero-order hold: at every output time the applied force is the one of the last sample
    res = simulate(scn)
    k = np.searchsorted(tr.times, sol.t + SNAP, side="right") - 1
    assert_allclose(res.forces, tr.forces[0][k], rtol=0, atol=0)


@pytest.mark.slow
def test_remus_at_50_hz_matches_the_independent_loop():
    scn = plan_run(fully_actuated("remus-line"), horizon=5.0, samples=51).scenario
    impl = Implementation(0.02, 0.01, varying_delay=True, noise=NOISE)
    sol = _run(scn, impl, trace=True)
    ref, _ = reference_loop(
        replace(scn, implementation=impl), sol.trace.times, sol.trace.measured_at[0], sol.trace.noise[0], sol.t
    )
    assert np.abs(sol.y[:, 0].reshape(ref.shape) - ref).max() < NUMERICAL_FLOOR


@pytest.mark.slow
def test_converges_to_the_continuous_loop_linearly_in_h(triangle):
    short = replace(triangle, horizon=8.0, samples=161)
    exact = simulate(short).states
    errors = []
    for h in (0.04, 0.02, 0.01):
        states = _run(short, Implementation(h)).y[:, 0].reshape(exact.shape)
        errors.append(np.abs(states[..., :2] - exact[..., :2]).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert errors[-1] < 0.05 and np.all((ratios > 1.6) & (ratios < 2.5)), (errors, ratios)


def test_noise_stays_inside_its_bounds_and_fills_them():
    rng = np.random.default_rng(0)
    e = noise_from_uniforms(NOISE, rng.random((20000, 6)))
    for got, bound in (
        (np.hypot(e[:, 0], e[:, 1]), NOISE.position),
        (np.abs(e[:, 2]), NOISE.heading),
        (np.hypot(e[:, 3], e[:, 4]), NOISE.velocity),
        (np.abs(e[:, 5]), NOISE.yaw_rate),
    ):
        assert got.max() <= bound and got.max() > 0.99 * bound
    # uniform in the disc: half of the draws inside radius R / sqrt(2)
    assert abs(np.mean(np.hypot(e[:, 0], e[:, 1]) < NOISE.position / np.sqrt(2)) - 0.5) < 0.02


def test_draws_are_reproducible_and_per_vehicle_streams():
    impl = Implementation(0.1, 0.2, varying_delay=True, noise=NOISE)
    a = ImplementationDraws(impl, [5, 9], 3)
    b = ImplementationDraws(impl, [9], 5)  # another batch and fleet size
    noise_a = np.stack([a.noise(k) for k in range(300)])  # crosses block boundaries
    noise_b = np.stack([b.noise(k) for k in range(300)])
    assert_array_equal(noise_a[:, 1], noise_b[:, 0, :3])
    assert_array_equal(a.delays(0, 300)[1], b.delays(0, 300)[0])
    assert not np.allclose(noise_a[:, 0], noise_a[:, 1])
    direct = noise_from_uniforms(NOISE, noise_generator(9, 2).random((300, 6)))
    assert_array_equal(noise_b[:, 0, 2], direct)
    d = a.delays(0, 300)
    assert d.min() >= 0 and d.max() <= impl.delay
    again = ImplementationDraws(impl, [5, 9], 3)
    assert_array_equal(np.stack([again.noise(k) for k in range(300)]), noise_a)


@pytest.mark.slow
def test_a_run_gives_the_same_numbers_in_any_batch(triangle):
    impl = Implementation(0.1, 0.15, varying_delay=True, noise=NOISE)
    runs = [replace(triangle, implementation=impl, seed=s, horizon=5.0, samples=51) for s in (1, 2)]
    both = simulate_batch(ScenarioBatch(tuple(runs)))
    for scn, res in zip(runs, both):
        assert_allclose(simulate(scn).states, res.states, rtol=ROUND_OFF, atol=ROUND_OFF)
    assert not np.allclose(both[0].states, both[1].states)


@pytest.mark.slow
def test_an_unstable_implementation_is_stopped_and_reported():
    plan = plan_run(fully_actuated("remus-line"), horizon=30.0, samples=301)
    res = simulate(replace(plan.scenario, implementation=Implementation(0.1, 0.1)))
    assert res.diverged_at is not None or res.exit_time is not None
    assert np.all(np.isfinite(res.states))


@pytest.mark.slow
def test_continuous_default_runs_the_continuous_engine(triangle, monkeypatch):
    monkeypatch.setattr(engine, "_sampled_batch", lambda batch: pytest.fail("sampled path taken"))
    res = simulate(triangle)
    assert res.diverged_at is None and triangle.implementation.continuous
    with pytest.raises(ValueError, match="continuous"):
        integrate_sampled(ScenarioBatch((triangle,)))


@pytest.mark.slow
def test_fleet_derivative_is_unchanged_by_the_shared_plant():
    scn = plan_run(preset_config("paper-triangle"), horizon=1.0, samples=2).scenario
    rng = np.random.default_rng(3)
    states = scn.initial + 0.1 * rng.standard_normal(scn.initial.shape)
    current = np.array([0.1, -0.05])
    motion = scn.reference.motion(0.3)
    p_dot = ground_velocity(states, current)
    old = rhs(scn.plant, states, scn.law.forces(states, p_dot, motion))
    old[..., 0:2] = p_dot
    assert_array_equal(fleet_derivative(scn.law, scn.plant, current, states, motion), old)


def test_control_period_of_a_continuous_law_with_delay():
    assert control_period(Implementation(0.05), 300.0) == 0.05
    assert control_period(Implementation(0.0, 0.1), 300.0) == pytest.approx(0.01)
    assert control_period(Implementation(0.0, 0.02), 300.0) == pytest.approx(0.002)
    assert control_period(Implementation(0.0, 0.0, noise=NOISE), 300.0) == pytest.approx(0.01)
    assert control_period(Implementation(0.0, 0.1), 1.0) == pytest.approx(0.001)
