"""Peak-to-peak gains of a sampled-data loop against an independent simulation and closed forms.

The loop is one axis of the error dynamics, ``e' = v``, ``v' = a0 v + u + w``, under the law
``u_k = -k1 y_e + (c0 - alpha) y_v`` on a measurement taken ``d`` before the sample and held
for ``h``. The reference simulation here is written apart from :mod:`auv_hinf.implementation.peak`:
an exact zero-order-hold step of the plant on a fine grid (``scipy.linalg.expm``) with a history
buffer for the delay. Every input it tries, however chosen, must stay under the bound, and the
input built from the kernel's signs must come close to it (the bound is nearly tight).
"""

from __future__ import annotations

import math
from dataclasses import replace

import control as ct
import numpy as np
import pytest
from scipy.linalg import expm

from auv_hinf.exceptions import DesignError
from auv_hinf.implementation import peak as peak_module
from auv_hinf.implementation.peak import (
    TAIL_RTOL,
    SampledLoop,
    free_peaks,
    peak_gains,
    small_gain,
    step_bounds,
)

#: Fine steps per sample period of the reference simulation (the bound's own grid is coarser).
SUB = 40
#: Relative slack of "stays under the bound": the reference integrates the exact flow on a grid
#: 40 times finer per period than the outputs are checked at, so only round-off separates them.
UNDER = 1e-9


def axis(a0: float, c0: float, k1: float, alpha: float, h: float, d: float) -> SampledLoop:
    """The loop of the module docstring; outputs (e, v, u, y_v)."""
    return SampledLoop(
        a=np.array([[0.0, 1.0], [0.0, a0]]),
        b_u=np.array([[0.0], [1.0]]),
        b_w=np.array([[0.0], [1.0]]),
        c_y=np.eye(2),
        d_n=np.eye(2),
        b_cn=np.zeros((0, 2)),
        a_c=np.zeros((0, 0)),
        b_c=np.zeros((0, 2)),
        c_c=np.zeros((1, 0)),
        d_c=np.array([[-k1, c0 - alpha]]),
        sample_time=h,
        delay=d,
        outputs=np.array([[1.0, 0, 0, 0, 0], [0, 1.0, 0, 0, 0], [0, 0, 1.0, 0, 0], [0, 0, 0, 0, 1.0]]),
        names=("e", "v", "u", "y_v"),
    )


def simulate(params, w, noise, periods: int, x0=(0.0, 0.0)) -> np.ndarray:
    """Outputs ``|e|, |v|, |u|, |y_v|`` at every fine step; ``w`` per fine step, ``noise`` (2,) per sample."""
    a0, c0, k1, alpha, h, d = params
    dt = h / SUB
    a = np.array([[0.0, 1.0], [0.0, a0]])
    m = np.zeros((4, 4))
    m[:2, :2] = a
    m[1, 2] = 1.0  # u
    m[1, 3] = 1.0  # w
    flow = expm(m * dt)
    lag = round(d / dt)
    assert abs(lag * dt - d) < 1e-12, "the reference needs the delay on its grid"
    x = np.array(x0, dtype=float)
    history = [x.copy()] * (lag + 1)
    u, y_v = 0.0, 0.0
    out = []
    for k in range(periods):
        y = history[-1 - lag] + noise[k]
        u = -k1 * y[0] + (c0 - alpha) * y[1]
        y_v = y[1]
        for j in range(SUB):
            z = flow @ np.array([x[0], x[1], u, w[k * SUB + j]])
            x = z[:2]
            history.append(x.copy())
            out.append([abs(x[0]), abs(x[1]), abs(u), abs(y_v)])
        history = history[-(lag + 2) :]
    return np.array(out)


#: (a0, c0, k1, alpha, h, d): a damped surge-like axis, an undamped sway-like axis, a long delay.
CASES = [
    (-6.37, 2.84, 2.0, 2.0, 0.1, 0.1),
    (0.0, 0.0, 1.0, 2.0, 0.1, 0.1),
    (-1.4, 0.0, 2.0, 2.8, 0.1, 0.25),
]


#: A slow loop: gentle gains (poles near -0.07 and -0.23 1/s), its period map contracting by about
#: 0.993 per 0.1 s period, so its gains need thousands of periods of their kernel.
SLOW = (0.0, 0.0, 0.02, 0.3, 0.1, 0.1)


@pytest.mark.slow
@pytest.mark.parametrize("params", CASES)
def test_noise_gains_bound_every_pattern_and_the_worst_one_nearly_reaches_them(params):
    """Bang-bang, random and kernel-sign noise stay under the discrete gains; the kernel's signs reach 0.9 of them."""
    h = params[4]
    gains = peak_gains(axis(*params))
    assert gains is not None
    periods = 300
    zero_w = np.zeros(periods * SUB)
    rng = np.random.default_rng(1)
    for channel in (0, 1):
        bound = gains.discrete[:, channel]
        worst = np.zeros(4)
        patterns = [
            np.array([(-1.0) ** k for k in range(periods)]),
            rng.choice([-1.0, 1.0], periods),
            np.sign(np.sin(np.arange(periods) * h * 2 * math.pi / 3.0)),
        ]
        for pattern in patterns:
            noise = np.zeros((periods, 2))
            noise[:, channel] = pattern
            worst = np.maximum(worst, simulate(params, zero_w, noise, periods).max(axis=0))
        # the kernel's own signs: the response at the end of period K to a unit error at sample j
        impulse = np.zeros((periods, 2))
        impulse[0, channel] = 1.0
        resp = simulate(params, zero_w, impulse, periods)
        for o in range(4):
            step_ends = resp[SUB - 1 :: SUB, o]  # |response| at each period's last fine step
            signed = simulate(params, zero_w, _signed(impulse, channel, periods, o, params), periods)
            worst[o] = max(worst[o], signed[:, o].max())
            assert step_ends.max() <= bound[o] * (1 + UNDER)
        assert np.all(worst <= bound * (1 + UNDER)), (worst, bound)
        assert np.all(worst >= 0.9 * bound), worst / bound


def _signed(impulse, channel, periods, output, params):
    """Noise with the signs of the output's impulse response read backwards: the worst at the last sample."""
    resp = simulate(params, np.zeros(periods * SUB), impulse, periods)
    # the response at fine step q of period K to a unit error at sample j is resp at step (K - j) SUB + q (signed)
    signed_resp = simulate_signed(params, impulse, periods)[:, output]
    q = int(np.argmax(np.abs(signed_resp[: SUB * 40]))) % SUB  # a phase near the worst
    end = (periods - 1) * SUB + q
    noise = np.zeros((periods, 2))
    for j in range(periods):
        idx = end - j * SUB
        if idx >= 0:
            noise[j, channel] = np.sign(signed_resp[idx]) or 1.0
    del resp
    return noise


def simulate_signed(params, noise, periods):
    """As :func:`simulate` but the signed outputs (e, v, u, y_v)."""
    a0, c0, k1, alpha, h, d = params
    dt = h / SUB
    m = np.zeros((4, 4))
    m[:2, :2] = [[0.0, 1.0], [0.0, a0]]
    m[1, 2] = 1.0
    flow = expm(m * dt)
    lag = round(d / dt)
    x = np.zeros(2)
    history = [x.copy()] * (lag + 1)
    out = []
    for k in range(periods):
        y = history[-1 - lag] + noise[k]
        u = -k1 * y[0] + (c0 - alpha) * y[1]
        for _ in range(SUB):
            x = (flow @ np.array([x[0], x[1], u, 0.0]))[:2]
            history.append(x.copy())
            out.append([x[0], x[1], u, y[1]])
        history = history[-(lag + 2) :]
    return np.array(out)


@pytest.mark.slow
@pytest.mark.parametrize(("params", "periods", "hold"), [*((c, 300, 37) for c in CASES), (SLOW, 3000, 3001)])
def test_disturbance_gains_bound_steps_and_switching_inputs(params, periods, hold):
    """A step and randomly switching unit disturbances stay under the continuous gains (the slow loop's
    gains are summed only to its Gramian tail, and its switches are 7.5 s apart)."""
    gains = peak_gains(axis(*params))
    assert gains is not None
    rng = np.random.default_rng(2)
    switches = np.repeat(rng.choice([-1.0, 1.0], periods * SUB // hold + 1), hold)[: periods * SUB]
    for w in (np.ones(periods * SUB), switches):
        peaks = simulate(params, w, np.zeros((periods, 2)), periods).max(axis=0)
        assert np.all(peaks <= gains.continuous[:, 0] * (1 + UNDER)), (peaks, gains.continuous[:, 0])


def test_position_gain_of_a_fast_nonoscillating_loop_is_the_dc_gain():
    """With a short period and no delay, an overdamped loop's impulse response keeps its sign: gain 1/k1."""
    k1 = 1.0
    gains = peak_gains(axis(0.0, 0.0, k1, 3.0, 0.005, 0.0))
    assert gains is not None
    assert 1.0 / k1 <= gains.continuous[0, 0] <= 1.02 / k1


def test_step_bounds_reach_the_equilibrium_and_the_velocity_area_is_the_offset():
    """A unit step settles at e = 1/k1 (its peak at least that) and the velocity's area is that offset."""
    k1 = 2.0
    steps = step_bounds(axis(-1.4, 0.0, k1, 2.8, 0.1, 0.1))
    assert steps is not None
    assert steps.peak[0, 0] >= 1.0 / k1
    assert not math.isfinite(steps.area[0, 0])  # the position does not decay to zero
    assert 1.0 / k1 <= steps.area[1, 0] <= 1.05 / k1  # int |v| >= int v = 1/k1, equal when v keeps its sign


def test_free_response_bounds_a_start_off_the_slot():
    """The free response from e(0) = 1 (the measurement buffer full of it) stays under its bound."""
    params = (-1.4, 0.0, 2.0, 2.8, 0.1, 0.1)
    free = free_peaks(axis(*params))
    assert free is not None
    periods = 200
    peaks = simulate(params, np.zeros(periods * SUB), np.zeros((periods, 2)), periods, x0=(1.0, 0.0)).max(axis=0)
    assert peaks[0] >= 0.999 and np.all(peaks[:2] <= free[:2, 0] * (1 + UNDER))  # the first stored step is after t = 0


def test_an_unstable_loop_has_no_gains():
    """Too much delay for the gains: the period map is unstable, and every routine says so with None."""
    loop = axis(0.0, 0.0, 4.0, 6.0, 0.2, 0.4)
    assert peak_gains(loop) is None and step_bounds(loop) is None and free_peaks(loop) is None


def test_small_gain_solves_the_least_fixed_point_and_refuses_at_radius_one():
    m = np.array([[0.0, 0.5], [0.4, 0.0]])
    c = np.array([1.0, 2.0])
    s = small_gain(c, m)
    assert s is not None and np.allclose(s, np.linalg.solve(np.eye(2) - m, c), rtol=1e-8)
    assert np.all(c + m @ s <= s * (1 + 1e-12))
    assert small_gain(c, np.array([[0.0, 1.0], [1.0, 0.0]])) is None
    with pytest.raises(DesignError):
        small_gain(c, -m)


def _period_rows(loop: SampledLoop) -> tuple[np.ndarray, np.ndarray]:
    """The period map and the outputs at every fine step's end, on the state at the period's start."""
    _, maps, phi, out = peak_module._maps(loop)
    rows, partial = [], np.eye(phi.shape[0])
    for mp in maps:
        partial = mp @ partial
        rows.append(out @ partial)
    return phi, np.vstack(rows)


def test_the_gramian_tail_bounds_the_remaining_sum_and_follows_it_where_the_contraction_does_not():
    """``sqrt(v^T W v / (1 - sigma))`` is above the exactly summed ``sum_k |l Phi^k v|``, and within a few
    times of it, for every output row and start; the contraction's tail is orders of magnitude above."""
    loop = axis(*SLOW)
    phi, rows = _period_rows(loop)
    radius = float(np.abs(np.linalg.eigvals(phi)).max())
    assert 0.99 < radius < 1.0
    gram = peak_module._gramians(rows, phi, radius)
    assert gram.ok.all()
    p, rho = peak_module._contraction(phi)
    starts = np.random.default_rng(5).normal(size=(phi.shape[0], 6))
    exact, x = np.zeros((rows.shape[0], starts.shape[1])), starts.copy()
    for _ in range(40000):  # radius^40000 < 1e-100: the rest is far below round-off
        exact += np.abs(rows @ x)
        x = phi @ x
    bound = peak_module._gramian_tails(gram, starts)
    assert np.all(bound >= exact * (1 - 1e-9))
    reached = exact > 1e-9 * exact.max()
    assert np.median(bound[reached] / exact[reached]) < 3.0
    contraction = peak_module._tails([rows], starts, p, rho)[0]
    assert np.median(contraction[reached] / exact[reached]) > 100.0


@pytest.mark.parametrize("params", [SLOW, CASES[0]])
def test_gains_summed_to_the_gramian_tail_agree_with_the_long_exact_sum(params, monkeypatch):
    """The gains stop at the Gramian tail (or the zero floor) yet stay above, and within TAIL_RTOL of, the
    gains summed exactly over MAX_PERIODS periods (the tail left after them is below 1e-30)."""
    loop = axis(*params)
    fast = peak_gains(loop)
    free = free_peaks(loop)
    monkeypatch.setattr(peak_module, "GRAMIAN_AFTER", math.inf)
    monkeypatch.setattr(peak_module, "TAIL_RTOL", 0.0)
    peak_module._maps.cache_clear()
    long = peak_gains(loop)
    long_free = free_peaks(loop)
    assert fast is not None and long is not None and free is not None and long_free is not None
    for new, old in ((fast.continuous, long.continuous), (fast.discrete, long.discrete), (free, long_free)):
        assert np.all(new >= old * (1 - 1e-9) - 1e-12)
        assert np.all(new <= old * (1 + 2 * TAIL_RTOL) + 1e-9 * old.max())


def test_the_hold_maps_are_python_controls_zero_order_hold_to_the_last_bit():
    """The one-exponential hold maps equal ``control.sample_system(..., "zoh")`` exactly, for random plants."""
    rng = np.random.default_rng(7)
    for _ in range(60):
        n, m = int(rng.integers(1, 8)), int(rng.integers(1, 4))
        a = rng.normal(size=(n, n)) * rng.uniform(0.1, 20.0)
        b = rng.normal(size=(n, m))
        t = float(rng.uniform(1e-4, 0.5))
        ref = ct.sample_system(ct.ss(a, b, np.eye(n), np.zeros((n, m))), t, method="zoh")
        ad, bd = peak_module._zoh(a, b, t)
        assert np.array_equal(ad, ref.A) and np.array_equal(bd, ref.B)
    eye, zero = peak_module._zoh(np.ones((2, 2)), np.ones((2, 1)), 0.0)
    assert np.array_equal(eye, np.eye(2)) and not zero.any()


def test_a_loop_far_too_fast_for_its_fine_step_is_refused_not_an_error():
    """``||A|| h / FINE_STEPS`` far beyond what ``exp`` can hold: every routine answers None (no overflow)."""
    loop = axis(-1e5, 0.0, 1.0, 2.0, 0.1, 0.0)
    assert peak_gains(loop) is None and free_peaks(loop) is None and step_bounds(loop) is None


def test_a_slow_integrator_chain_with_a_repeated_pole_gets_finite_gains_without_warnings():
    """A period map with a Jordan block (three integrators placed at one pole 0.995): ill-conditioned
    Stein equations are verified, not trusted, and the gains bound a step and its sign pattern."""
    n, h, pole = 3, 0.1, 0.995
    a = np.diag(np.ones(n - 1), 1)
    b = np.zeros((n, 1))
    b[-1, 0] = 1.0
    big = np.zeros((n + 1, n + 1))
    big[:n, :n], big[:n, n:] = a, b
    flow = expm(big * h)
    ad, bd = flow[:n, :n], flow[:n, n:]
    ctrb = np.hstack([np.linalg.matrix_power(ad, i) @ bd for i in range(n)])
    k = np.linalg.solve(ctrb, np.eye(n))[-1:] @ np.linalg.matrix_power(ad - pole * np.eye(n), n)  # Ackermann
    loop = SampledLoop(
        a=a,
        b_u=b,
        b_w=b,
        c_y=np.eye(n),
        d_n=np.eye(n)[:, :1],
        b_cn=np.zeros((0, 1)),
        a_c=np.zeros((0, 0)),
        b_c=np.zeros((0, n)),
        c_c=np.zeros((1, 0)),
        d_c=-k,
        sample_time=h,
        delay=0.0,
        outputs=np.eye(2 * n + 1)[:1],
    )
    gains = peak_gains(loop)
    assert gains is not None and np.isfinite(gains.continuous).all()
    # the step response of the position settles at the DC gain 1/k_0 (the first entry of the feedback)
    phi = np.block([[ad - bd @ k]])
    state, peak_seen = np.zeros((n, 1)), 0.0
    for _ in range(20000):
        state = phi @ state + bd
        peak_seen = max(peak_seen, abs(float(state[0, 0])))
    assert peak_seen <= gains.continuous[0, 0] * (1 + 1e-9)


@pytest.mark.parametrize("params", CASES[:2])
def test_one_signed_gains_bound_one_signed_inputs_and_halve_an_output_that_settles(params):
    """Inputs that keep one sign (a step, on-off switching, a random level in [0, 1], and their
    negatives) stay under the one-signed gains, which are at most the gains. The velocity's
    response to a constant input settles to zero (the position loop takes it up), so its kernel's
    positive and negative parts have equal areas and its one-signed gain is half its gain (up to
    the within-step terms); a step reaches most of it (the kernel changes sign about once)."""
    gains = peak_gains(axis(*params))
    assert gains is not None
    assert np.all(gains.one_signed <= gains.continuous)
    half = gains.one_signed[1, 0] / gains.continuous[1, 0]
    assert 0.5 <= half <= 0.56, half
    periods = 300
    rng = np.random.default_rng(5)
    switches = np.repeat(rng.choice([0.0, 1.0], periods * SUB // 37 + 1), 37)[: periods * SUB]
    levels = np.repeat(rng.uniform(0.0, 1.0, periods * SUB // 13 + 1), 13)[: periods * SUB]
    step = np.ones(periods * SUB)
    worst = np.zeros(4)
    for w in (step, switches, levels):
        for sign in (1.0, -1.0):
            peaks = simulate(params, sign * w, np.zeros((periods, 2)), periods).max(axis=0)
            assert np.all(peaks <= gains.one_signed[:, 0] * (1 + UNDER)), (peaks, gains.one_signed[:, 0])
            worst = np.maximum(worst, peaks)
    assert worst[1] >= 0.85 * gains.one_signed[1, 0], (worst[1], gains.one_signed[1, 0])


def test_step_bounds_of_the_first_inputs_are_those_of_all_inputs():
    """The composed certificate sweeps only its slowly varying input: the same numbers, fewer columns."""
    loop = replace(axis(*CASES[0]), b_w=np.array([[0.0, 1.0], [1.0, 0.0]]))  # a second input, into e'
    full, first = step_bounds(loop), step_bounds(loop, inputs=1)
    assert full is not None and first is not None and full.peak.shape == (4, 2) and first.peak.shape == (4, 1)
    assert np.allclose(first.peak, full.peak[:, :1], rtol=1e-9) and np.allclose(first.area, full.area[:, :1], rtol=1e-9)


def _two_axes(first: SampledLoop, second: SampledLoop) -> SampledLoop:
    """Two loops side by side with nothing between them (the same sample time and delay)."""
    from scipy.linalg import block_diag

    def cols(loop: SampledLoop) -> tuple[np.ndarray, ...]:
        n, nu, _, _ = loop.sizes
        o = loop.outputs
        return o[:, :n], o[:, n : n + nu], o[:, n + nu :]

    (x1, u1, y1), (x2, u2, y2) = cols(first), cols(second)
    return SampledLoop(
        a=block_diag(first.a, second.a),
        b_u=block_diag(first.b_u, second.b_u),
        b_w=block_diag(first.b_w, second.b_w),
        c_y=block_diag(first.c_y, second.c_y),
        d_n=block_diag(first.d_n, second.d_n),
        b_cn=np.zeros((0, 4)),
        a_c=np.zeros((0, 0)),
        b_c=np.zeros((0, 4)),
        c_c=np.zeros((2, 0)),
        d_c=block_diag(first.d_c, second.d_c),
        sample_time=first.sample_time,
        delay=first.delay,
        outputs=np.hstack([block_diag(x1, x2), block_diag(u1, u2), block_diag(y1, y2)]),
    )


def test_inputs_the_structure_does_not_connect_have_zero_gains_and_the_rest_are_each_axis_own(monkeypatch):
    """Two axes side by side: the graph of the loop's nonzero entries links each axis's inputs to its own
    outputs only; the gains across are exactly zero (their tail bounds are round-off, not summed); every
    other gain is within TAIL_RTOL of the same loop's gains summed over MAX_PERIODS, and at least the
    axis's own (within 1 %: the within-step remainder takes the whole loop's ``||A||``, so the slow axis
    beside a faster one gets a slightly larger one)."""
    first, second = axis(*CASES[0]), axis(*SLOW)
    both = _two_axes(first, second)
    linked = peak_module._linked(both)
    own = np.kron(np.eye(2, dtype=bool), np.ones((4, 1), dtype=bool))  # (outputs, inputs of one kind)
    assert np.array_equal(linked[:, :2], own) and np.array_equal(linked[:, 2:], np.repeat(own, 2, axis=1))
    g, g1, g2 = peak_gains(both), peak_gains(first), peak_gains(second)
    assert g is not None and g1 is not None and g2 is not None
    assert np.all(g.continuous[:4, 1] == 0.0) and np.all(g.continuous[4:, 0] == 0.0)
    assert np.all(g.discrete[:4, 2:] == 0.0) and np.all(g.discrete[4:, :2] == 0.0)
    for got, alone in (
        (g.continuous[:4, :1], g1.continuous),
        (g.continuous[4:, 1:], g2.continuous),
        (g.discrete[:4, :2], g1.discrete),
        (g.discrete[4:, 2:], g2.discrete),
        (g.one_signed[:4, :1], g1.one_signed),
        (g.one_signed[4:, 1:], g2.one_signed),
    ):
        assert np.all(got >= alone * (1 - 1e-9)) and np.all(got <= alone * 1.01)
    monkeypatch.setattr(peak_module, "GRAMIAN_AFTER", math.inf)
    monkeypatch.setattr(peak_module, "TAIL_RTOL", 0.0)
    peak_module._maps.cache_clear()
    long = peak_gains(both)
    assert long is not None
    for got, exact in ((g.continuous, long.continuous), (g.discrete, long.discrete), (g.one_signed, long.one_signed)):
        assert np.all(got >= exact * (1 - 1e-9)) and np.all(got <= exact * (1 + 2 * TAIL_RTOL))


def test_the_signed_remaining_sum_bounds_the_tail_from_below_and_splits_it_into_its_signs():
    """``|S| - err`` is at most the exact ``sum_k |l Phi^k v|``, and ``(T + S + err)/2`` and ``(T - S + err)/2``
    (``T`` the exact sum) are at least the sums of its positive and negative terms, for every output row
    of the slow loop and random starts; on that loop, dominated by one slow real mode, the lower bound
    is within a few percent of the sum for most pairs."""
    loop = axis(*SLOW)
    phi, rows = _period_rows(loop)
    p, rho = peak_module._contraction(phi)
    starts = np.random.default_rng(11).normal(size=(phi.shape[0], 6))
    starts = np.linalg.matrix_power(phi, 200) @ starts  # two hundred periods on: the slow mode leads
    total, pos, neg, x = (np.zeros((rows.shape[0], starts.shape[1])) for _ in range(4))
    x = starts.copy()
    for _ in range(40000):
        z = rows @ x
        total += np.abs(z)
        pos += np.maximum(z, 0.0)
        neg += np.maximum(-z, 0.0)
        x = phi @ x
    signed, err = peak_module._SignedSums.of(rows, phi, p, rho)(starts)
    scale = total.max()
    assert np.all(np.abs(signed) - err <= total * (1 + 1e-9) + 1e-12 * scale)
    assert np.all(0.5 * (total + signed + err) >= pos * (1 - 1e-9) - 1e-12 * scale)
    assert np.all(0.5 * (total - signed + err) >= neg * (1 - 1e-9) - 1e-12 * scale)
    reached = total > 1e-6 * scale
    assert np.median(((np.abs(signed) - err) / total)[reached]) > 0.95


def test_the_slow_modes_sums_are_the_exact_sums_of_two_geometric_sequences_and_of_their_signs():
    """``sum_k |a lam^k + b mu^k|`` and its positive and negative parts, in closed form, against the terms
    summed one by one: equal signs, opposite signs crossing early, late (thousands of periods) or never."""
    rng = np.random.default_rng(23)
    lam, mu = 0.995, 0.97
    a = rng.normal(size=400) * 10.0 ** rng.uniform(-3, 3, 400)
    b = rng.normal(size=400) * 10.0 ** rng.uniform(-3, 3, 400)
    b[:40] = -a[:40] * (lam / mu) ** rng.uniform(0.0, 3000.0, 40)  # crossings at known indices
    total, pos, neg = peak_module._slow_sums(a, b, lam, mu)
    k = np.arange(20000)  # lam^20000 < 1e-43
    terms = a[:, None] * lam ** k[None, :] + b[:, None] * mu ** k[None, :]
    exact = np.abs(terms).sum(axis=1)
    for got, want in (
        (total, exact),
        (pos, np.maximum(terms, 0.0).sum(axis=1)),
        (neg, np.maximum(-terms, 0.0).sum(axis=1)),
    ):
        assert np.all(got >= want * (1 - 1e-12))  # the brute-force sum's own round-off
        assert np.all(got <= want * (1 + 1e-9) + 1e-9 * exact)
    assert (a * b < 0).sum() > 200  # most pairs cross: the split is what is tested


def _map_with_spectrum(rng: np.random.Generator) -> np.ndarray:
    """A period map with two slow real modes, a complex pair, a fast mode and a nilpotent Jordan block, in a
    random basis (condition about 30)."""
    core = np.zeros((9, 9))
    core[0, 0], core[1, 1] = 0.998, 0.991
    core[2:4, 2:4] = 0.93 * np.array([[math.cos(0.3), -math.sin(0.3)], [math.sin(0.3), math.cos(0.3)]])
    core[4, 4] = -0.6
    core[5, 6] = core[6, 7] = core[7, 8] = 1.0  # a Jordan block at 0
    core[0, 1:] = rng.normal(size=8) * 0.3  # couplings the decoupling has to remove
    core[2, 4:] = rng.normal(size=5) * 0.3
    u, _ = np.linalg.qr(rng.normal(size=(9, 9)))
    basis = u @ np.diag(np.geomspace(1.0, 30.0, 9)) @ np.linalg.qr(rng.normal(size=(9, 9)))[0]
    return basis @ core @ np.linalg.inv(basis)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_deflated_tail_brackets_the_remaining_sum_and_its_signs_and_follows_it(seed):
    """For every row and start of a map with two slow real modes, a complex pair, a negative mode and a
    nilpotent block: lower <= sum_k |l Phi^k v| <= upper, the positive and negative parts bounded, the
    block norms' sums bounded; after 64 periods the upper bound is within 1e-3 of the sum for most
    pairs (where the contraction's and Gramians' tails are not)."""
    rng = np.random.default_rng(seed)
    phi = _map_with_spectrum(rng)
    rows = rng.normal(size=(7, 9))
    defl = peak_module._deflation(rows, phi)
    assert defl is not None and defl.modes.shape == (2,)
    starts = np.linalg.matrix_power(phi, 64) @ rng.normal(size=(9, 12))
    tails = peak_module._deflated_tails(defl, starts)
    total, pos, neg = (np.zeros((7, 12)) for _ in range(3))
    block = np.zeros((7, 3))
    x = starts.copy()
    for _ in range(40000):  # 0.998^40000 < 1e-34
        z = rows @ x
        total += np.abs(z)
        pos += np.maximum(z, 0.0)
        neg += np.maximum(-z, 0.0)
        block += np.sqrt((z.reshape(7, 3, 4) ** 2).sum(axis=-1))
        x = phi @ x
    slack = 1e-12 * total.max()  # the brute-force sum's own round-off
    assert np.all(tails.upper >= total - slack) and np.all(tails.lower <= total + slack)
    assert np.all(tails.positive >= pos - slack) and np.all(tails.negative >= neg - slack)
    assert np.all(peak_module._deflated_norm_tails(defl, starts, 4) >= block - slack)
    assert np.median(tails.upper / total) < 1.001
    p, rho = peak_module._contraction(phi)
    assert np.median(peak_module._tails([rows], starts, p, rho)[0] / total) > 10.0


def test_a_map_whose_slowest_modes_are_not_real_or_not_separated_is_not_deflated():
    """A complex slowest pair, or two slow modes closer than the gap: no deflation (the other tails stay)."""
    rot = 0.995 * np.array([[math.cos(0.01), -math.sin(0.01)], [math.sin(0.01), math.cos(0.01)]])
    phi = np.zeros((4, 4))
    phi[:2, :2], phi[2, 2], phi[3, 3] = rot, 0.5, 0.2
    assert peak_module._deflation(np.eye(4), phi) is None
    close = np.diag([0.995, 0.995 - 0.1 * peak_module.DEFLATION_GAP, 0.5, 0.2])
    deflated = peak_module._deflation(np.eye(4), close)
    assert deflated is None  # neither the first nor the pair is separated from the next


@pytest.mark.slow
def test_a_slow_ilos_loop_is_summed_to_its_deflated_tail_and_agrees_with_the_long_exact_sum(monkeypatch):
    """The ILOS cascade's loop (its slow integrator mode at 0.997 per period): the gains that stop at the
    deflated tail are above, and within TAIL_RTOL of, the gains summed exactly over MAX_PERIODS periods."""
    from auv_hinf.cascade.certificate import cascade_loop
    from auv_hinf.certificate.design_point import design_point
    from auv_hinf.certificate.parts.guidance import cascade_problem
    from auv_hinf.config.presets import preset_config

    cfg = preset_config("remus-transit-ilos")
    problem = cascade_problem(cfg, design_point(cfg))
    assert not isinstance(problem, str)
    loop = cascade_loop(problem)
    phi, rows = _period_rows(loop)
    assert peak_module._deflation(rows, phi) is not None
    fast = peak_gains(loop)
    monkeypatch.setattr(peak_module, "GRAMIAN_AFTER", math.inf)
    monkeypatch.setattr(peak_module, "TAIL_RTOL", 0.0)
    peak_module._maps.cache_clear()
    long = peak_gains(loop)
    assert fast is not None and long is not None
    for new, old in ((fast.continuous, long.continuous), (fast.one_signed, long.one_signed)):
        assert np.all(new >= old * (1 - 1e-9) - 1e-12 * old.max())
        assert np.all(new <= old * (1 + 2 * TAIL_RTOL) + 1e-9 * old.max())


@pytest.mark.parametrize("scale", [1.0, 1e-150, 1e-155])
def test_the_block_norm_tail_holds_for_states_near_the_bottom_of_the_floating_range(scale):
    """Two slow modes whose block vectors are parallel: the block form keeps their cross term at any scale
    of the state (a state of 1e-152 lost it to an absolute threshold and came out 7 % short)."""
    modal = np.array([[1.0, 0.3, 0.2], [0.1, 1.0, -0.4], [0.2, 0.5, 1.0]])
    phi = modal @ np.diag([0.999, 0.99, 0.5]) @ np.linalg.inv(modal)
    row = np.array([[1.0, 1.0, 1.0]]) @ np.linalg.inv(modal)
    defl = peak_module._deflation(row, phi)
    assert defl is not None and defl.modes.shape == (2,)
    x = modal[:, 0] + modal[:, 1]
    exact, y = 0.0, x.copy()
    for _ in range(30000):  # 0.999^30000 < 1e-13
        exact += abs(float(row[0] @ y))
        y = phi @ y
    exact *= math.sqrt(2.0) * scale  # two equal columns; the sum is linear in the state
    got = float(peak_module._deflated_norm_tails(defl, scale * np.stack([x, x], axis=1), 2)[0, 0])
    assert exact * (1 - 1e-9) <= got <= exact * (1 + 1e-6)


def test_the_slow_norm_sum_charges_the_cancellation_of_nearly_equal_modes():
    """``sum_k |a| |lam^k - mu^k|`` for lam within 1e-13 of mu: the terms' rounding is of their size, not of
    their difference; the bound stays above the exact closed form ``a (1/(1 - lam) - 1/(1 - mu))``."""
    a, lam, mu = 6.204706866556482, 0.6951698612675103, 0.6951698612674405
    got = float(peak_module._slow_norm_sum(np.array([a]), np.array([-1.0]), np.array([0.0]), lam, mu)[0])
    # exact: lam^k - mu^k >= 0, and 1/(1 - lam) - 1/(1 - mu) = (lam - mu)/((1 - lam)(1 - mu)) without cancellation
    exact = a * (lam - mu) / ((1.0 - lam) * (1.0 - mu))
    assert got >= exact
