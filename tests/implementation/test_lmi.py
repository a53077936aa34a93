"""The Lyapunov-Krasovskii LMI of a lagged loop: closed forms, python-control, brute-force sampling."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from auv_hinf.closed_loop.nominal import position_decay_rate
from auv_hinf.exceptions import DesignError
from auv_hinf.implementation import limits
from auv_hinf.implementation.limits import certified_lag, decay_at, exact_limit, held_plant, spectral_radius
from auv_hinf.implementation.lmi import LagLoop, lmi_lag

#: The paper triangle's position loop (lambda, alpha, k1, sigma) and heading loop (c range, k_psi).
PAPER_POSITION = LagLoop((-2.1,), 0.5, 0.2605, 1.8403)
PAPER_HEADING = LagLoop((-(2.5 - 1.875), -(3.125 - 1.875)), 1.5, 1.875)
#: Relative agreement of the closed-form and python-control discretisations (both exact; round-off).
DISC_RTOL = 1e-10
#: The LKF decay bisection stops at 1e-2 relative (sampling.DECAY_RTOL); the closed form is exact.
DECAY_RTOL = 2e-2


@pytest.mark.parametrize("a", [-7.8, -2.1, -0.3, 0.0, 1e-6])
@pytest.mark.parametrize("t", [1e-3, 0.05, 0.7, 3.0])
def test_held_plant_equals_python_control(a, t):
    ad, bd = held_plant(a, t)
    d = ct.sample_system(ct.ss([[0, 1], [0, a]], [[0], [1]], np.eye(2), np.zeros((2, 1))), t, method="zoh")
    np.testing.assert_allclose(ad, d.A, rtol=DISC_RTOL, atol=1e-14)
    np.testing.assert_allclose(bd, d.B, rtol=DISC_RTOL, atol=1e-14)


def _simulate_held(a, k, b, h, delay, horizon, sigma=0.0, lags=None, drive=None, seed=0):
    """Independent simulation of e'' = a e' + q + u, u held: law on x(s_k), s_k = max(t_k - d_k, 0).

    ``lags``: per-sample delay draws (default: constant ``delay``); ``drive``: a function of time
    and state giving the uncertainty q (default 0). Returns times and states (2 axes).
    """
    rng = np.random.default_rng(seed)
    n = round(horizon / h)
    dk = np.full(n, delay) if lags is None else lags(rng, n)
    t_grid = np.arange(n + 1) * h
    # solve on a fine grid, storing dense output to read x(s_k)
    x = np.array([1.0, 0.0, 0.3, -0.2])  # (e_x, e'_x, e_y, e'_y)
    sols, u = [], np.zeros(2)
    times, states = [0.0], [x.copy()]
    for kk in range(n):
        s_k = max(t_grid[kk] - dk[kk], 0.0)
        xs = _state_at(sols, s_k, x, t_grid[kk])
        u = -(k * xs[[0, 2]] + b * xs[[1, 3]])

        def f(t, y, u=u):
            e = y.reshape(2, 2)
            q = np.zeros(2) if drive is None else drive(t, y)
            return np.column_stack([e[:, 1], a * e[:, 1] + q + u]).ravel()

        sol = solve_ivp(f, (t_grid[kk], t_grid[kk + 1]), x, rtol=1e-10, atol=1e-12, dense_output=True)
        sols.append(sol)
        x = sol.y[:, -1]
        times.append(t_grid[kk + 1])
        states.append(x.copy())
    return np.array(times), np.array(states)


def _state_at(sols, s, x_now, t_now):
    if s >= t_now or not sols:
        return x_now if not sols else sols[-1].sol(min(s, sols[-1].t[-1]))
    for sol in sols:
        if sol.t[0] <= s <= sol.t[-1]:
            return sol.sol(s)
    return sols[0].sol(sols[0].t[0])


@pytest.mark.slow
def test_exact_limit_is_where_the_held_loop_starts_to_grow():
    a, k, b = -2.1, 0.5, 0.2605
    for delay in (0.0, 0.3):
        limit = exact_limit(a, k, b, delay)
        assert spectral_radius(a, k, b, 0.97 * limit, delay) < 1.0 <= spectral_radius(a, k, b, 1.03 * limit, delay)
        # an independent simulation of the held loop agrees: decays below the limit, grows above
        for factor, grows in ((0.9, False), (1.1, True)):
            h = factor * limit
            _, xs = _simulate_held(a, k, b, h, delay, horizon=60 * h)
            ratio = np.linalg.norm(xs[-1]) / np.linalg.norm(xs[0])
            assert (ratio > 1.0) == grows, (delay, factor, ratio)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_certified_lag_never_exceeds_the_exact_limit(seed):
    rng = np.random.default_rng(seed)
    a, k, b = -rng.uniform(0.1, 8.0), rng.uniform(0.1, 20.0), rng.uniform(0.2, 10.0)
    loop = LagLoop((a,), k, b)
    lag = certified_lag(loop)
    assert 0.0 < lag <= exact_limit(a, k, b, 0.0)
    assert lmi_lag(loop, lag, 0.0) is not None


def test_lkf_at_zero_lag_is_the_continuous_certificate():
    # with no lag the functional is x^T P x and the LMI is the shifted bounded-real lemma
    beta = decay_at(PAPER_POSITION, 0.0)
    exact = position_decay_rate(-2.1, 0.2605, 0.5, 1.8403)
    assert beta == pytest.approx(exact, rel=DECAY_RTOL) and beta <= exact


def test_a_loop_certified_only_without_decay_answers_zero_after_a_bounded_search(monkeypatch):
    """A rate bisection from 0 stops at its absolute width: about 25 LMI solves, not ~1,000 to underflow."""
    # the deployed BlueROV2 surge loop with a box and a current at 0.2 s of lag: no positive rate is certified
    loop = LagLoop((-7.789526686807653,), 1.5625, 2.5, 7.790037658234344, 5.077878373107323)
    solves = []

    def counted(*args, **kwargs):
        solves.append(args[2])
        return lmi_lag(*args, **kwargs)

    monkeypatch.setattr(limits, "lmi_lag", counted)
    assert decay_at(loop, 0.2) == 0.0
    assert len(solves) <= 40
    assert 0.0 < min(solves) <= limits.DECAY_ATOL  # it searched down to the absolute floor, and no further


def test_paper_triangle_limits_and_tightness():
    """The issue's floor: the certified sample time is at least 0.3 of the exact nominal limit."""
    lag = min(certified_lag(PAPER_POSITION), certified_lag(PAPER_HEADING))
    exact = min(exact_limit(-2.1, 0.5, 0.2605, 0.0), exact_limit(-(2.5 - 1.875), 1.5, 1.875, 0.0))
    assert 0.3 * exact <= lag <= exact


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_certificate_holds_for_sampled_lags_and_uncertainty(seed):
    """Brute force: random varying delays up to the certified lag and a random time-varying D."""
    loop = PAPER_POSITION
    tau = 0.9 * certified_lag(loop)
    beta = 0.5 * decay_at(loop, tau)
    cert = lmi_lag(loop, tau, beta)
    assert cert is not None
    rng = np.random.default_rng(100 + seed)
    h = rng.uniform(0.2, 1.0) * tau
    angles = rng.uniform(0, 2 * np.pi, 50)

    def drive(t, y):  # D(t) e' with ||D|| = sigma, rotating with time
        th = angles[int(t) % 50]
        rot = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        return loop.sigma * rot @ y.reshape(2, 2)[:, 1]

    times, xs = _simulate_held(
        loop.dampings[0],
        loop.k,
        loop.b,
        h,
        0.0,
        horizon=40.0,
        drive=drive,
        lags=lambda r, n: r.uniform(0.0, tau - h, n),
        seed=seed,
    )
    p = cert.p
    pairs = xs.reshape(-1, 2)  # rows (e, e') of the x axis, then of the y axis, per time
    level = np.einsum("ti,ij,tj->t", pairs, p, pairs).reshape(-1, 2).sum(axis=1)
    bound = level[0] * np.exp(-2 * beta * times)
    assert np.all(level <= bound * (1 + 1e-6) + 1e-12)


def test_bad_loops_are_refused():
    with pytest.raises(DesignError, match="dampings"):
        LagLoop((), 1.0, 1.0)
    with pytest.raises(DesignError, match=">= 0"):
        LagLoop((-1.0,), 1.0, 1.0, sigma=-1.0)
    with pytest.raises(DesignError, match="tau"):
        lmi_lag(PAPER_HEADING, -1.0, 0.0)
    assert math.isfinite(certified_lag(PAPER_HEADING))
