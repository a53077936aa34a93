"""Integrators for batches of independent ODE systems, with dense output and exit events.

A *batch* is ``B`` independent systems of equal dimension ``d``: ``y`` has shape ``(B, d)``
and the right-hand side ``rhs(t, y)`` takes per-system times ``t`` of shape ``(B,)``.

* :func:`dopri5` advances every system with its own time, step size and error control
  (Dormand-Prince 5(4), FSAL, the same tableau, error norm and step control as scipy's
  ``RK45``). Outputs are sampled from the continuous extension, and the first time an
  event function turns negative is located by root finding on that interpolant.
* :func:`rk45_reference` runs scipy's ``solve_ivp`` (RK45) on one system behind the same
  interface; it is the reference :func:`dopri5` is tested against.

Limitation of the event location: the event function is checked on ``subdivisions``
equally spaced points per step; an excursion that enters and leaves between two
consecutive points (shorter than ``h / subdivisions``) is missed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, SolverError

#: Product tolerances: shape errors of 1e-3 m on formations of 10-30 m need a relative
#: accuracy well below 1e-5; 1e-8 / 1e-8 keeps the integration error negligible.
RTOL, ATOL = 1e-8, 1e-8


#: Numerical floor of every certified error compared with a simulated one (m, m/s, rad, rad/s):
#: the certificate bounds the exact solution, the integrator returns it to its global error.
#: At RTOL = ATOL = 1e-8 that error, measured against rtol = atol = 1e-11 references, is
#: ~1e-8 once converged and a few 1e-6 during 30 m transients (tests/simulation/
#: test_simulation.py, INTEGRATOR_AGREEMENT_M); 1e-5 covers it with a margin of a few.
NUMERICAL_FLOOR = 1e-5
#: Numerical floor of every certified force or moment compared with a simulated one (N, N m). A
#: channel the mission never loads (the sway force and the yaw moment of a straight line in still
#: water) is certified at exactly 0 by symmetry, while a simulation commands round-off there (3e-15 N
#: measured beside a 28 N surge force); 1e-6 N is far above that and far below any thruster.
FORCE_FLOOR = 1e-6


#: Batched right-hand side: ``(t (B,), y (B, d)) -> dy/dt (B, d)``.
BatchRhs = Callable[[FloatArray, FloatArray], FloatArray]


#: Event function: ``(t (..., B), y (..., B, d)) -> (..., B)``; each system independent.
EventFn = Callable[[FloatArray, FloatArray], FloatArray]


#: Lower bound of an event function over a box of states: ``(y (b, d), radius (b, d)) -> (b,)``,
#: at most the event's value at every time of the step and every state with
#: ``|y' - y| <= radius`` componentwise. Steps whose bound is positive cannot cross zero and
#: skip the sub-grid check.
EventBound = Callable[[FloatArray, FloatArray], FloatArray]


#: Receiver of output samples: ``(sample indices (m,), systems (m,), states (m, d)) -> None``.
#: One call holds at most one sample per system, and each system's samples arrive in
#: increasing time order.
SampleSink = Callable[[NDArray[np.int_], NDArray[np.int_], FloatArray], None]


# Dormand-Prince 5(4) tableau, error weights and dense-output polynomial (Hairer, Norsett &
# Wanner, Solving ODEs I, Sec. II.5-6; Shampine's continuous extension, as in scipy's RK45).
_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])


_A = [
    np.array([]),
    np.array([1 / 5]),
    np.array([3 / 40, 9 / 40]),
    np.array([44 / 45, -56 / 15, 32 / 9]),
    np.array([19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729]),
    np.array([9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]),
]


_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])


_E = np.array([-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])


_P = np.array(
    [
        [1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
        [0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
        [0.0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
        [0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ]
)


_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0


_ERR_EXP = -1.0 / 5.0  # error estimate of order 4


@dataclass(frozen=True)
class BatchSolution:
    """Samples and events of a batch integration.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Output times (s).
    y : ndarray, shape (T, B, d), or None
        States at the output times; None when they went to a sink.
    event_time : ndarray, shape (B,)
        First time (s) the event function is negative; NaN if never (or no event given).
    n_steps, n_rejected : ndarray of int, shape (B,)
        Accepted and rejected steps per system.
    next_step : ndarray, shape (B,), or None
        The step size each system would take next (s; :func:`dopri5` only), to continue
        without a new starting-step estimate.
    """

    t: FloatArray
    y: FloatArray | None
    event_time: FloatArray
    n_steps: NDArray[np.int_]
    n_rejected: NDArray[np.int_]
    next_step: FloatArray | None = None


def _rms(x: FloatArray) -> FloatArray:
    out: FloatArray = np.linalg.norm(x, axis=-1) / np.sqrt(x.shape[-1])
    return out


def check_span(y0: FloatArray, t_span: tuple[float, float], t_eval: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Check and convert the common inputs of :func:`dopri5` and :func:`rk45_reference`.

    Parameters
    ----------
    y0 : ndarray, shape (B, d)
        Initial states; must be finite.
    t_span : tuple of float
        Start and end time (s); finite, end after start.
    t_eval : ndarray, shape (T,)
        Output times (s); sorted and inside ``t_span``.

    Returns
    -------
    tuple of ndarray
        ``y0`` as a new float array and ``t_eval`` as a float array.

    Raises
    ------
    ParameterError
        If any of the conditions above fails.
    """
    y = np.array(y0, dtype=float)
    te = np.asarray(t_eval, dtype=float)
    t0, t1 = t_span
    if y.ndim != 2 or not np.all(np.isfinite(y)):
        raise ParameterError(f"initial states must be a finite (B, d) array, got shape {y.shape}")
    if not (np.isfinite(t0) and np.isfinite(t1) and t1 > t0):
        raise ParameterError(f"time span must be finite and increasing, got {t_span!r}")
    if te.ndim != 1 or np.any(np.diff(te) < 0) or (te.size and (te[0] < t0 or te[-1] > t1)):
        raise ParameterError("output times must be sorted and inside the time span")
    return y, te


def _combine(k: FloatArray, weights: FloatArray) -> FloatArray:
    """``sum_j weights_j k_j`` over stages ``k (s, B, d)``, one BLAS product as scipy's RK45 does."""
    out: FloatArray = np.dot(k.reshape(k.shape[0], -1).T, weights).reshape(k.shape[1:])
    return out


def _initial_step(
    rhs: BatchRhs, t0: float, t1: float, y0: FloatArray, f0: FloatArray, rtol: float, atol: float
) -> FloatArray:
    """Hairer's starting step (Solving ODEs I, II.4), per system, as in scipy."""
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0 / scale), _rms(f0 / scale)
    h0 = np.where((d0 < 1e-5) | (d1 < 1e-5), 1e-6, 0.01 * d0 / np.maximum(d1, 1e-300))
    h0 = np.minimum(h0, t1 - t0)
    f1 = rhs(t0 + h0, y0 + h0[:, None] * f0)
    d2 = _rms((f1 - f0) / scale) / h0
    big = np.maximum(d1, d2)
    h1 = np.where(big <= 1e-15, np.maximum(1e-6, h0 * 1e-3), (0.01 / np.maximum(big, 1e-300)) ** (-_ERR_EXP))
    out: FloatArray = np.minimum(np.minimum(100 * h0, h1), t1 - t0)
    return out


def _dense(y_old: FloatArray, h: FloatArray, q: FloatArray, theta: FloatArray) -> FloatArray:
    """Continuous extension at fractions ``theta`` (..., b) of the steps; ``q`` is (4, b, d).

    ``y_old + h (theta q_0 + theta^2 q_1 + theta^3 q_2 + theta^4 q_3)``, in Horner form.
    """
    th = theta[..., None]
    acc = q[3] * th + q[2]
    acc = acc * th + q[1]
    acc = acc * th + q[0]
    out: FloatArray = y_old + h[:, None] * (acc * th)
    return out


def _coefficients(k: FloatArray) -> FloatArray:
    """Dense-output coefficients ``q (4, B, d)`` from the stages ``k (7, B, d)``: one BLAS product."""
    out: FloatArray = (_P.T @ k.reshape(k.shape[0], -1)).reshape(4, *k.shape[1:])
    return out


def _locate(event: EventFn, t_old: float, h: float, y_old: FloatArray, q: FloatArray, lo: float, hi: float) -> float:
    """Root of the event on the interpolant of one step, bracketed in ``theta in [lo, hi]``."""

    def g(theta: float) -> float:
        th = np.array([theta])
        return float(event(np.array([t_old + theta * h]), _dense(y_old[None], np.array([h]), q[:, None], th))[0])

    if g(lo) <= 0.0:  # round-off: the bracket's left end is already on or past the boundary
        return float(t_old + lo * h)
    try:
        root = brentq(g, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)
    except (ValueError, RuntimeError) as exc:
        raise SolverError(f"event location failed: {exc}") from exc
    return float(t_old + float(root) * h)


def dopri5(
    rhs: BatchRhs,
    t_span: tuple[float, float],
    y0: FloatArray,
    t_eval: FloatArray,
    *,
    rtol: float = RTOL,
    atol: float = ATOL,
    event: EventFn | None = None,
    subdivisions: int = 8,
    max_steps: int = 1_000_000,
    event_bound: EventBound | None = None,
    sink: SampleSink | None = None,
    first_step: FloatArray | None = None,
) -> BatchSolution:
    """Integrate ``B`` independent systems with per-system Dormand-Prince 5(4) steps.

    Parameters
    ----------
    rhs : callable
        ``rhs(t, y)`` with ``t`` (B,) and ``y`` (B, d); always called on the full batch
        (finished systems get a zero step).
    t_span : tuple of float
        Start and end time (s), common to all systems.
    y0 : ndarray, shape (B, d)
        Initial states.
    t_eval : ndarray, shape (T,)
        Sorted output times (s) inside ``t_span``; sampled from the continuous extension.
    rtol, atol : float
        Per-component tolerances; the error norm is the RMS over the ``d`` components of
        each system, as in scipy.
    event : callable, optional
        ``event(t, y)`` (see :data:`EventFn`); its first negative time per system is located
        by brentq on the interpolant, bracketed by a sign change on ``subdivisions`` points
        of each step (see the module note on the residual limitation).
    subdivisions : int
        Number of equally spaced points per step (``theta = 1/subdivisions, ..., 1``) at which
        ``event`` is checked for a sign change.
    max_steps : int
        Cap on the number of batch iterations.
    event_bound : callable, optional
        A sound lower bound of ``event`` over a box of states (:data:`EventBound`). Over a step
        the interpolant stays within ``h (|q_0| + |q_1| + |q_2| + |q_3|)`` of the step's start
        (``0 <= theta <= 1``), so a step whose bound over that box is positive cannot reach an
        exit and skips the sub-grid check. It changes no result, only the cost.
    sink : callable, optional
        Receives the output samples as they are produced (:data:`SampleSink`) instead of
        storing them: memory stays ``O(B d)`` for any number of samples, and the solution's
        ``y`` is None.
    first_step : ndarray, shape (B,), optional
        Starting step sizes (s, > 0), e.g. a previous call's ``next_step``; default (and where
        NaN): Hairer's estimate.

    Raises
    ------
    SolverError
        On a non-finite derivative that step-size reduction cannot avoid, a step size
        below round-off, or more than ``max_steps`` iterations.
    """
    y, te = check_span(y0, t_span, t_eval)
    t0, t1 = float(t_span[0]), float(t_span[1])
    n_sys, dim = y.shape
    out = np.empty((te.size, n_sys, dim)) if sink is None else None
    write: SampleSink = _store(out) if out is not None else cast(SampleSink, sink)
    at_start = int(np.sum(te <= t0))
    for j in range(at_start):
        write(np.full(n_sys, j), np.arange(n_sys), y)
    next_idx = np.full(n_sys, at_start)
    t = np.full(n_sys, t0)
    f = rhs(t, y)
    if not np.all(np.isfinite(f)):
        raise SolverError("non-finite derivative at the initial state")
    if first_step is None or np.isnan(first_step).any():  # estimated per system: NaN asks for the estimate
        h = _initial_step(rhs, t0, t1, y, f, rtol, atol)
        h = h if first_step is None else np.where(np.isnan(first_step), h, np.minimum(first_step, t1 - t0))
    else:
        h = np.minimum(first_step, t1 - t0)
    if not np.all(np.isfinite(h) & (h > 0)):
        raise SolverError("no finite initial step: the derivative is not finite near the initial state")
    event_time = np.full(n_sys, np.nan)
    if event is not None:
        event_time[event(t, y) < 0] = t0
    n_steps = np.zeros(n_sys, dtype=int)
    n_rej = np.zeros(n_sys, dtype=int)
    was_rejected = np.zeros(n_sys, dtype=bool)
    k = np.empty((7, n_sys, dim))
    for _ in range(max_steps):
        active = t < t1
        if not active.any():
            break
        step = np.where(active, np.minimum(h, t1 - t), 0.0)
        k[0] = f
        for s in range(1, 6):
            k[s] = rhs(t + _C[s] * step, y + _combine(k[:s], _A[s]) * step[:, None])
        y_new = y + step[:, None] * _combine(k[:6], _B)
        t_new = np.where(step == t1 - t, t1, t + step)
        k[6] = rhs(t_new, y_new)
        scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
        err = _rms(_combine(k, _E) * step[:, None] / scale)
        err = np.where(np.isfinite(err) & np.all(np.isfinite(k[6]), axis=1), err, np.inf)
        accept = active & (err < 1.0)
        with np.errstate(divide="ignore"):
            factor = np.clip(_SAFETY * err**_ERR_EXP, _MIN_FACTOR, _MAX_FACTOR)
        factor = np.where(accept & was_rejected, np.minimum(factor, 1.0), factor)
        h = np.where(active, step * factor, h)
        if np.any(active & ~accept & ~(h >= 10 * np.spacing(np.maximum(np.abs(t), 1.0)))):
            raise SolverError(f"step size below round-off near t = {float(t[active].min()):.6g} s")
        n_rej += active & ~accept
        was_rejected = active & ~accept
        if accept.any():
            b = np.flatnonzero(accept)
            # when every system accepts (the common case) a slice selects them without copying the stages
            sel: slice | NDArray[np.int_] = slice(None) if b.size == n_sys else b
            q = _coefficients(k[:, sel])
            _sample(write, te, next_idx, b, t[sel], step[sel], t_new[sel], y[sel], q)
            if event is not None:
                _events(event, event_time, b, t[sel], step[sel], y[sel], q, subdivisions, event_bound)
            t[sel], y[sel], f[sel] = t_new[sel], y_new[sel], k[6, sel]
            n_steps[sel] += 1
    else:
        raise SolverError(f"dopri5 did not reach t = {t1} s within {max_steps} steps")
    return BatchSolution(t=te, y=out, event_time=event_time, n_steps=n_steps, n_rejected=n_rej, next_step=h)


def _store(out: FloatArray) -> SampleSink:
    """The default sink: samples written into ``out (T, B, d)``."""

    def write(idx: NDArray[np.int_], systems: NDArray[np.int_], values: FloatArray) -> None:
        out[idx, systems] = values

    return write


def _sample(
    write: SampleSink,
    te: FloatArray,
    next_idx: NDArray[np.int_],
    b: NDArray[np.int_],
    t_old: FloatArray,
    h: FloatArray,
    t_new: FloatArray,
    y_old: FloatArray,
    q: FloatArray,
) -> None:
    """Send the output samples that fall in each accepted step ``(t_old, t_new]`` to ``write``."""
    n_out = te.size
    while True:
        idx = next_idx[b]
        due = (idx < n_out) & (te[np.minimum(idx, n_out - 1)] <= t_new)
        if not due.any():
            return
        sel = np.flatnonzero(due)
        theta = (te[idx[sel]] - t_old[sel]) / h[sel]
        write(idx[sel], b[sel], _dense(y_old[sel], h[sel], q[:, sel], theta))
        next_idx[b[sel]] += 1


def _events(
    event: EventFn,
    event_time: FloatArray,
    b: NDArray[np.int_],
    t_old: FloatArray,
    h: FloatArray,
    y_old: FloatArray,
    q: FloatArray,
    subdivisions: int,
    bound: EventBound | None = None,
) -> None:
    """Locate first exits inside the accepted steps of systems that have not exited yet."""
    live = np.flatnonzero(np.isnan(event_time[b]))
    if live.size and bound is not None:
        radius = h[live, None] * np.abs(q[:, live]).sum(axis=0)
        live = live[bound(y_old[live], radius) <= 0.0]
    if live.size == 0:
        return
    grid = np.linspace(0.0, 1.0, subdivisions + 1)[1:]
    theta = np.broadcast_to(grid[:, None], (subdivisions, live.size))
    y_sub = _dense(y_old[live], h[live], q[:, live], theta)
    g = event(t_old[live] + theta * h[live], y_sub)  # (subdivisions, live)
    neg = g < 0
    for j in np.flatnonzero(neg.any(axis=0)):
        first = int(np.argmax(neg[:, j]))
        lo = 0.0 if first == 0 else float(grid[first - 1])
        i = live[j]
        event_time[b[i]] = _locate(event, float(t_old[i]), float(h[i]), y_old[i], q[:, i], lo, float(grid[first]))


def rk45_reference(
    rhs: BatchRhs,
    t_span: tuple[float, float],
    y0: FloatArray,
    t_eval: FloatArray,
    *,
    rtol: float = RTOL,
    atol: float = ATOL,
    event: EventFn | None = None,
) -> BatchSolution:
    """Scipy ``solve_ivp`` (RK45) on one system (``B = 1``); same interface as :func:`dopri5`.

    The reference the vectorised integrator is tested against. Events use scipy's own
    location (sign changes between step end points, then a root search on its dense
    output), so an excursion inside one step is missed.

    Parameters
    ----------
    rhs : callable
        ``rhs(t, y)`` with ``t`` (1,) and ``y`` (1, d), as for :func:`dopri5`.
    t_span : tuple of float
        Start and end time (s).
    y0 : ndarray, shape (1, d)
        Initial state.
    t_eval : ndarray, shape (T,)
        Sorted output times (s) inside ``t_span``.
    rtol, atol : float
        Tolerances passed to ``solve_ivp``.
    event : callable, optional
        ``event(t, y)`` (see :data:`EventFn`); its first crossing from positive to negative (or
        a negative value at the start) is returned as ``event_time``.

    Raises
    ------
    ParameterError
        If ``y0`` holds more than one system.
    SolverError
        If ``solve_ivp`` reports a failure.
    """
    y, te = check_span(y0, t_span, t_eval)
    if y.shape[0] != 1:
        raise ParameterError(f"rk45_reference integrates one system, got {y.shape[0]}")

    def fun(t: float, x: FloatArray) -> FloatArray:
        out: FloatArray = rhs(np.array([t]), x[None])[0]
        return out

    event_time = np.full(1, np.nan)
    events = []
    if event is not None:
        ev = event

        def g(t: float, x: FloatArray) -> float:
            return float(ev(np.array([t]), x[None])[0])

        g.direction = -1  # type: ignore[attr-defined]
        events.append(g)
        if g(t_span[0], y[0]) < 0:
            event_time[0] = t_span[0]
    try:
        sol = solve_ivp(fun, t_span, y[0], method="RK45", t_eval=te, rtol=rtol, atol=atol, events=events or None)
    except ValueError as exc:
        raise SolverError(f"solve_ivp failed: {exc}") from exc
    if not sol.success:
        raise SolverError(f"solve_ivp failed: {sol.message}")
    if event is not None and np.isnan(event_time[0]) and sol.t_events[0].size:
        event_time[0] = float(sol.t_events[0][0])
    n_steps = np.array([max(sol.nfev - 2, 0) // 6])  # 6 evaluations per step (FSAL) + 2 for the first step
    return BatchSolution(
        t=te, y=sol.y.T[:, None, :], event_time=event_time, n_steps=n_steps, n_rejected=np.zeros(1, dtype=int)
    )


__all__ = [
    "NUMERICAL_FLOOR",
    "BatchRhs",
    "BatchSolution",
    "EventBound",
    "EventFn",
    "SampleSink",
    "check_span",
    "dopri5",
    "rk45_reference",
]
