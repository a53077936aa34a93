"""Vectorised Dormand-Prince: accuracy, per-system independence, dense output, event location."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from auv_hinf.exceptions import ParameterError, SolverError
from auv_hinf.numerics.integrators import dopri5, rk45_reference

#: Damped oscillators x'' = -2 zeta w x' - w^2 x with per-system (w, zeta): 1/s and 1.
PARAMS = np.array([[1.0, 0.05], [3.0, 0.2], [0.3, 0.0], [8.0, 0.5]])


def _osc(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    w, z = PARAMS[: len(y), 0], PARAMS[: len(y), 1]
    return np.column_stack([y[:, 1], -2 * z * w * y[:, 1] - w * w * y[:, 0]])


def _exact(t: np.ndarray, w: float, z: float) -> np.ndarray:
    """x(t) for x(0) = 1, x'(0) = 0 (underdamped)."""
    wd = w * np.sqrt(1 - z * z)
    return np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))


Y0 = np.tile([1.0, 0.0], (len(PARAMS), 1))
T_EVAL = np.linspace(0.0, 10.0, 37)  # deliberately not aligned with the steps


def test_dense_output_accuracy_against_exact_solution():
    sol = dopri5(_osc, (0.0, 10.0), Y0, T_EVAL)
    for i, (w, z) in enumerate(PARAMS):
        # global error of a 5th-order method at rtol = atol = 1e-8 over ~10 periods: 1e-6 is generous
        assert_allclose(sol.y[:, i, 0], _exact(T_EVAL, w, z), rtol=0, atol=1e-6)
    assert len(set(sol.n_steps.tolist())) == len(PARAMS)  # each system chose its own steps


@pytest.mark.slow
def test_matches_tight_scipy_reference():
    tight = np.concatenate(
        [
            rk45_reference(
                lambda t, y, i=i: _osc_one(t, y, i), (0.0, 10.0), Y0[i : i + 1], T_EVAL, rtol=1e-12, atol=1e-12
            ).y
            for i in range(len(PARAMS))
        ],
        axis=1,
    )
    for tol in (1e-6, 1e-8, 1e-10):
        sol = dopri5(_osc, (0.0, 10.0), Y0, T_EVAL, rtol=tol, atol=tol)
        err = np.abs(sol.y - tight).max()
        # states are O(1..10): a global error within 10x the tolerance times the scale
        assert err < 100 * tol
        print(f"rtol=atol={tol:g}: max error vs rtol=1e-12 reference {err:.2e}")


def test_batch_equals_single_systems():
    batch = dopri5(_osc, (0.0, 10.0), Y0, T_EVAL)
    for i in range(len(PARAMS)):
        one = dopri5(lambda t, y, i=i: _osc_one(t, y, i), (0.0, 10.0), Y0[i : i + 1], T_EVAL)
        assert_allclose(batch.y[:, i], one.y[:, 0], rtol=0, atol=1e-13)
        assert batch.n_steps[i] == one.n_steps[0]


def _osc_one(t: np.ndarray, y: np.ndarray, i: int) -> np.ndarray:
    w, z = PARAMS[i]
    return np.column_stack([y[:, 1], -2 * z * w * y[:, 1] - w * w * y[:, 0]])


def test_event_located_between_samples():
    """x = cos(w t) leaves x > 0.5 at t = acos(0.5)/w; samples every 2 s cannot resolve that."""
    coarse = np.linspace(0.0, 10.0, 6)
    g = lambda t, y: y[..., 0] - 0.5  # noqa: E731
    sol = dopri5(lambda t, y: _osc_one(t, y, 2), (0.0, 10.0), Y0[2:3], coarse, event=g)  # w = 0.3, zeta = 0
    exact = np.arccos(0.5) / 0.3
    assert abs(sol.event_time[0] - exact) < 1e-7
    sample_estimate = coarse[np.argmax(sol.y[:, 0, 0] < 0.5)]
    assert abs(sample_estimate - exact) > 0.5
    ref = rk45_reference(lambda t, y: _osc_one(t, y, 2), (0.0, 10.0), Y0[2:3], coarse, event=g, rtol=1e-12, atol=1e-12)
    assert abs(ref.event_time[0] - exact) < 1e-9


def test_event_at_start_and_never():
    y0 = np.array([[3.0, 0.0], [1.0, 0.0]])  # |x| <= 3 for all t (damped), so x + 5 > 0 always
    sol = dopri5(_osc, (0.0, 1.0), y0, np.array([0.0, 1.0]), event=lambda t, y: y[..., 0] - 2.0)
    assert sol.event_time[1] == 0.0  # starts at 1 < 2: outside at t = 0
    assert 0.0 < sol.event_time[0] < 1.0  # x = 3 cos(...) falls below 2 within the first second
    never = dopri5(_osc, (0.0, 1.0), y0, np.array([1.0]), event=lambda t, y: y[..., 0] + 5.0)
    assert np.isnan(never.event_time).all()


def test_errors():
    with pytest.raises(ParameterError, match="finite"):
        dopri5(_osc, (0.0, 1.0), np.array([[np.nan, 0.0]]), np.array([0.0]))
    with pytest.raises(ParameterError, match="output times"):
        dopri5(_osc, (0.0, 1.0), Y0[:1], np.array([0.5, 0.2]))
    with pytest.raises(SolverError, match="initial state"):
        dopri5(lambda t, y: np.full_like(y, np.nan), (0.0, 1.0), Y0[:1], np.array([1.0]))
    blow_up = lambda t, y: np.where(t[:, None] < 0.5, y, np.nan)  # noqa: E731
    with pytest.raises(SolverError, match="step size"):
        dopri5(blow_up, (0.0, 1.0), Y0[:1], np.array([1.0]))
    with pytest.raises(ParameterError, match="one system"):
        rk45_reference(_osc, (0.0, 1.0), Y0, np.array([1.0]))
    with pytest.raises(SolverError, match="within 3 steps"):
        dopri5(_osc, (0.0, 100.0), Y0[:1], np.array([1.0]), max_steps=3)


def test_a_sink_receives_exactly_the_stored_samples_in_order():
    stored = dopri5(_osc, (0.0, 10.0), Y0, T_EVAL)
    got = np.full_like(stored.y, np.nan)
    last = np.full(len(PARAMS), -1)

    def sink(idx: np.ndarray, systems: np.ndarray, values: np.ndarray) -> None:
        assert len(set(systems.tolist())) == systems.size  # at most one sample per system per call
        assert np.all(idx > last[systems])  # each system's samples in increasing time order
        last[systems] = idx
        got[idx, systems] = values

    sol = dopri5(_osc, (0.0, 10.0), Y0, T_EVAL, sink=sink)
    assert sol.y is None
    np.testing.assert_array_equal(got, stored.y)  # every sample, bit for bit
    np.testing.assert_array_equal(sol.n_steps, stored.n_steps)
