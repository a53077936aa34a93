"""Sample-time and delay limits of an error loop: certified (LMI) and exact (discretisation).

Certified: the largest lag bound ``tau`` for which the Lyapunov-Krasovskii LMI of
:mod:`auv_hinf.implementation.lmi` is strictly feasible at zero decay, by bisection. It covers
every lag in ``[0, tau]``, so a sampled loop with period ``h`` and delay ``d`` is certified
when ``h + d <= tau``: ``max_sample_time = tau - delay`` and ``max_delay = tau - sample_time``.

Exact (the outside reference): the nominal loop ``e'' = a e' + u`` with ``u`` the law on the
state ``d`` seconds old, held over each period ``h``, discretised exactly with python-control
(``sample_system``, zero-order hold) and augmented with the held inputs the delay keeps in
flight; it is stable iff the spectral radius is below 1. The first period at which it is
not (scanning up from a period far below the loop's time constants, then bisecting) is the
exact limit. A certified period can never exceed it: the certificate covers the nominal loop.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import DesignError
from auv_hinf.implementation.lmi import LagLoop, LagResult, lmi_lag
from auv_hinf.numerics.bisection import bisect

#: Relative width at which the bisections on a lag or a period stop.
LIMIT_RTOL = 1e-4
#: Relative width at which the decay-rate bisection stops (the certificates use half the rate,
#: so 1 % of it is plenty; each step is one LMI solve).
DECAY_RTOL = 1e-2
#: Absolute width (1/s) at which it stops too: a rate below it (a time constant beyond 11 days) is
#: reported as 0. Without it a loop certified only at ``beta = 0`` bisects towards 0 until the
#: floats underflow (about 1,000 LMI solves instead of about 25).
DECAY_ATOL = 1e-6
#: Growth factor of the scan for the first unstable period (each step is one exact
#: discretisation; 2 % steps cannot step over an instability window narrower than 2 %).
SCAN_FACTOR = 1.02
#: The scan starts at this fraction of the loop's fastest time constant (s).
SCAN_START = 1e-3
#: Periods beyond this many times the slowest time constant are reported as unlimited.
SCAN_SPAN = 1e4
#: Relative back-off of the certified lag below the bisection's feasible end, so that the LMI
#: holds there with a positive decay rate (at the supremum itself only beta = 0 is certified).
LAG_BACKOFF_RTOL = 1e-3


def lag_floor(loop: LagLoop) -> float:
    """Smallest lag (s) the LMI is solved at: :data:`SCAN_START` of the loop's fastest time constant.

    Certifying a larger lag bound is sound (it covers every smaller lag) and keeps ``1/tau`` in
    the LMI well scaled; below it the solver's accuracy, not the loop, would decide.

    Parameters
    ----------
    loop : LagLoop
        The loop (its first damping vertex and gains set the time constants).
    """
    return SCAN_START * _time_constants(loop.dampings[0], loop.k, loop.b)[0]


def certified_lag(loop: LagLoop) -> float:
    """Largest lag bound ``tau`` (s) with a verified certificate at zero decay (0 if none).

    The LMI is tried on a doubling ladder from :data:`SCAN_START` of the loop's fastest time
    constant (halving below it when that already fails), then refined by bisection to
    :data:`LIMIT_RTOL`.

    Parameters
    ----------
    loop : LagLoop
        The loop to certify.
    """

    def ok(tau: float) -> bool:
        return lmi_lag(loop, tau, 0.0) is not None

    if not ok(0.0):
        return 0.0
    fast, slow = _time_constants(loop.dampings[0], loop.k, loop.b)
    lo = SCAN_START * fast
    while not ok(lo):
        lo *= 0.5
        if lo < 1e-6 * SCAN_START * fast:
            return 0.0
    while ok(2.0 * lo):
        lo *= 2.0
        if lo > SCAN_SPAN * slow:
            return math.inf
    return bisect(ok, lo, 2.0 * lo, rtol=LIMIT_RTOL)[0] * (1.0 - LAG_BACKOFF_RTOL)


def decay_at(loop: LagLoop, tau: float) -> float:
    """Largest decay rate ``beta`` (1/s) certified at lag bound ``max(tau, lag_floor)`` (0 if only ``beta = 0`` is).

    Parameters
    ----------
    loop : LagLoop
        The loop.
    tau : float
        Lag bound (s); 0 (no lag) stays 0.
    """
    tau = _solved_lag(loop, tau)
    eig = max(abs(a) for a in loop.dampings) + abs(loop.b) + math.sqrt(abs(loop.k))
    return bisect(lambda b: lmi_lag(loop, tau, b) is not None, 0.0, eig, rtol=DECAY_RTOL, atol=DECAY_ATOL)[0]


def iss_certificate(loop: LagLoop, tau: float, beta: float, weight: FloatArray) -> LagResult | None:
    """:func:`lmi_lag` with the smallest ISS gain at ``(max(tau, lag_floor), beta)`` and ``P >= weight``.

    Parameters
    ----------
    loop : LagLoop
        The loop.
    tau : float
        Lag bound (s); 0 (no lag) stays 0.
    beta : float
        Decay rate (1/s), >= 0.
    weight : ndarray, shape (2, 2)
        Lower bound of ``P`` (fixes its scale).
    """
    return lmi_lag(loop, _solved_lag(loop, tau), beta, weight=weight)


def _solved_lag(loop: LagLoop, tau: float) -> float:
    """The lag bound the LMI is solved at: ``tau`` raised to :func:`lag_floor` (0 stays 0, no lag)."""
    return max(tau, lag_floor(loop)) if tau > 0 else tau


def _nominal_matrices(a: float) -> tuple[FloatArray, FloatArray]:
    return np.array([[0.0, 1.0], [0.0, a]]), np.array([[0.0], [1.0]])


def _time_constants(a: float, k: float, b: float) -> tuple[float, float]:
    """Fastest and slowest time constants (s) of the continuous nominal loop (``inf`` if unstable)."""
    eigs = np.linalg.eigvals(np.array([[0.0, 1.0], [-k, a - b]]))
    if eigs.real.max() >= 0:
        return 1.0 / float(np.abs(eigs).max()), math.inf
    return 1.0 / float(np.abs(eigs).max()), 1.0 / float(np.abs(eigs.real).min())


def held_plant(a: float, t: float) -> tuple[FloatArray, FloatArray]:
    """Exact zero-order-hold discretisation of ``e'' = a e' + u`` over ``t`` (s), in closed form.

    ``Ad = [[1, phi1], [0, exp(a t)]]``, ``Bd = [[phi2], [phi1]]`` with
    ``phi1 = (exp(a t) - 1)/a`` and ``phi2 = (exp(a t) - 1 - a t)/a^2`` (series near ``a t = 0``);
    equal to python-control's ``sample_system`` (tested), and cheap enough to scan with.

    Parameters
    ----------
    a : float
        Velocity coefficient (1/s).
    t : float
        Hold time (s).
    """
    x = a * t
    if abs(x) < 1e-4:
        phi1 = t * (1.0 + x / 2.0 + x * x / 6.0 + x**3 / 24.0)
        phi2 = t * t * (0.5 + x / 6.0 + x * x / 24.0 + x**3 / 120.0)
    else:
        phi1 = math.expm1(x) / a
        phi2 = (math.expm1(x) - x) / (a * a)
    return np.array([[1.0, phi1], [0.0, math.exp(x)]]), np.array([[phi2], [phi1]])


def _control_plant(a: float, t: float) -> tuple[FloatArray, FloatArray]:
    """python-control's ``sample_system`` of the same plant (the outside reference)."""
    a_c, b_c = _nominal_matrices(a)
    d = ct.sample_system(ct.ss(a_c, b_c, np.eye(2), np.zeros((2, 1))), t, method="zoh")
    return np.asarray(d.A), np.asarray(d.B)


def spectral_radius(a: float, k: float, b: float, period: float, delay: float, *, control: bool = False) -> float:
    """Spectral radius of the nominal loop held over ``period`` (s) with a constant ``delay`` (s).

    A command computed from ``x_i = x(t_i)`` acts from ``t_i + delay``. With ``delay = m h + f``
    (``0 <= f < h``) the input over ``[t_j, t_{j+1})`` is ``u_{j-m-1}`` for the first ``f``
    seconds and ``u_{j-m}`` after, so ``x_{j+1} = Ad x_j + G1 u_{j-m-1} + G0 u_{j-m}``
    with ``G0 = Bd(h - f)``, ``G1 = Ad(h - f) Bd(f)`` from python-control's ``sample_system``.
    The state ``(x_j, u_{j-1}, ..., u_{j-m-1})`` evolves linearly; its spectral radius decides.

    Parameters
    ----------
    a : float
        Velocity coefficient of the plant ``e'' = a e' + u`` (1/s).
    k, b : float
        Gains of the law ``u = -k e - b e'`` (1/s^2, 1/s).
    period : float
        Sample time ``h`` (s), > 0.
    delay : float
        Constant delay (s), >= 0.
    control : bool
        Discretise with python-control's ``sample_system`` instead of :func:`held_plant`.
    """
    if period <= 0:
        raise DesignError(f"period must be > 0 (s), got {period!r}")
    disc = _control_plant if control else held_plant
    # the delay in whole periods; 1e-12 absorbs the round-off of delay/period at exact multiples
    m = math.floor(delay / period + 1e-12)
    f = max(delay - m * period, 0.0)
    ad, bd = disc(a, period)
    if f > 0:
        head_b = disc(a, f)[1]
        tail_a, g0 = disc(a, period - f)
        g1 = tail_a @ head_b
    else:
        g0, g1 = bd, np.zeros_like(bd)
    gain = -np.array([[k, b]])
    size = 2 + m + 1
    z = np.zeros((size, size))
    z[:2, :2] = ad

    def feed(g: FloatArray, age: int) -> None:  # u_{j-age}: age 0 is -K x_j, else a stored input
        if age == 0:
            z[:2, :2] += g @ gain
        else:
            z[:2, 1 + age : 2 + age] += g

    feed(g0, m)
    feed(g1, m + 1)
    z[2:3, :2] = gain
    for j in range(1, m + 1):
        z[2 + j, 1 + j] = 1.0
    return float(np.abs(np.linalg.eigvals(z)).max())


def exact_limit(a: float, k: float, b: float, delay: float) -> float:
    """First period (s) at which the nominal held loop with ``delay`` (s) is unstable.

    Returns 0 when even the shortest scanned period is unstable (the delay alone is too long)
    and ``inf`` when no period up to :data:`SCAN_SPAN` times the slowest time constant is.
    The scan starts at :data:`SCAN_START` of the fastest time constant, or at ``delay/64``
    when that is longer (the state then carries at most 64 held inputs). The bracket found
    with the closed form is re-checked with python-control's discretisation.

    Parameters
    ----------
    a : float
        Velocity coefficient of the plant ``e'' = a e' + u`` (1/s).
    k, b : float
        Gains of the law ``u = -k e - b e'`` (1/s^2, 1/s).
    delay : float
        Constant delay (s), >= 0.
    """
    fast, slow = _time_constants(a, k, b)
    if not math.isfinite(slow):
        return 0.0
    h = max(SCAN_START * fast, delay / 64.0)
    if spectral_radius(a, k, b, h, delay) >= 1.0:
        return 0.0
    while spectral_radius(a, k, b, h * SCAN_FACTOR, delay) < 1.0:
        h *= SCAN_FACTOR
        if h > SCAN_SPAN * slow:
            return math.inf
    limit = bisect(lambda p: spectral_radius(a, k, b, p, delay) < 1.0, h, h * SCAN_FACTOR, rtol=LIMIT_RTOL)[0]
    if not spectral_radius(a, k, b, limit, delay, control=True) < 1.0:
        raise DesignError(f"python-control disagrees with the closed-form discretisation at period {limit!r} s")
    return limit


__all__ = [
    "DECAY_RTOL",
    "LAG_BACKOFF_RTOL",
    "LIMIT_RTOL",
    "SCAN_FACTOR",
    "SCAN_SPAN",
    "SCAN_START",
    "certified_lag",
    "decay_at",
    "exact_limit",
    "held_plant",
    "iss_certificate",
    "lag_floor",
    "spectral_radius",
]
