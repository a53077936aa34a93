"""Peak-to-peak gains of a sampled-data loop: a continuous plant under a held, delayed, discrete law.

The loop (one axis of a vehicle's error loop, with its nominal plant):

    x' = A x + B_u u(t) + B_w w(t),                        (continuous plant)
    y_k = C_y x(t_k - d) + D_n n_k,                         (measured d seconds before the sample)
    xi_{k+1} = A_c xi_k + B_c y_k,   u_k = C_c xi_k + D_c y_k,   u(t) = u_k on [t_k, t_k + h),

with ``t_k = k h``, continuous disturbances ``w`` and discrete measurement errors ``n``. The
*peak-to-peak gain* of an output ``z`` (a linear function of the plant state, the held command
and the measurement it was computed from) from an input is ``sup_t int |g(t, s)| ds`` (continuous
input) or ``sup_t sum_k |g(t, k)|`` (discrete input), ``g`` the loop's kernel: the smallest
number ``N`` with ``sup |z| <= N sup |w|`` for *every* bounded input, started from rest
(Dahleh & Diaz-Bobillo, *Control of Uncertain Systems: A Linear Programming Approach*, 1995). For
a loop with several inputs the bound is ``sum_i N_i W_i``; with perturbation channels
``|v_j(t)| <= delta_j |z_j(t)|`` closed around it, the small-gain theorem in the peak norm
(:func:`small_gain`) bounds every output.

:func:`peak_gains` computes upper bounds of these gains, rigorously:

* the period ``[0, h)`` is cut into fine steps at ``h / FINE_STEPS`` and at the measurement's
  phase; each step is the exact zero-order-hold map (the matrix exponential python-control's
  ``sample_system`` computes, :func:`_zoh`);
* a continuous input over a step of length ``delta`` reaches the state as ``int_0^delta
  e^{A s} B_w w(t - s) ds``; its kernel is bounded by its value at the step's end plus the
  variation ``||e^{A s} - I|| <= e^{||A|| s} - 1``, which adds ``|l| ||B_w|| (e^{a delta} - 1 -
  a delta)/a`` per step (:func:`_variation`);
* the sum over the infinite past is exact for ``K`` periods and bounded beyond by the smaller of a
  geometric tail from a verified discrete Lyapunov contraction of the period map
  (:func:`_contraction`) and, for a slow loop, each output's verified weighted Gramian
  (:func:`_gramians`), which charges an output only with the modes it sees. ``K`` is where that
  tail bound exceeds the exact remaining sum by at most ``TAIL_RTOL`` of the gain, which a lower
  bound of the remaining sum shows: the absolute value of its *signed* sum, ``|l (I - Phi)^-1 x|``
  (:class:`_SignedSums`). Once a slow mode of one sign carries what is left, bound and lower bound
  meet, thousands of periods before the tail itself is small (the ILOS cascade at 20 Hz: 2,900
  periods instead of 7,100). The signed sum also splits the tail between the kernel's positive
  and negative parts;
* a slow loop whose one or two slowest modes are real and separated from the rest gets a tighter
  tail still (:func:`_deflation`, :func:`_deflated_tails`): a similarity ``S`` (a Schur form, a
  Sylvester equation and the slow block's eigenvectors) turns the period map into ``N + E``, ``N``
  block-diagonal with the slow modes apart and ``||E||`` bounded by the residual of ``S^-1 Phi S``
  computed in extended precision. The slow modes' sum is then exact (two geometric sequences cross
  zero at most once, :func:`_slow_sums`), the rest's is bounded by its own contraction or Gramians,
  and ``E``'s share by a Neumann series; the slow modes' sum less the rest is a lower bound too.
  Upper and lower bound then meet as fast as the *rest* decays, not the slowest mode: the ILOS
  cascade's loop at 10 Hz (slowest modes 0.9974 and 0.9931 per period, the rest 0.973) stops after
  128 periods instead of about 4,500, with gains within 5e-5 of the long sum;
* an input that no path of nonzero entries of the loop's matrices leads to an output has a zero
  kernel to it (:func:`_linked`): its gain is 0 exactly, where its tail bounds would leave round-off
  (likewise a free response, :func:`free_peaks`); every other gain is inflated by ``SUM_ROUNDOFF``
  for the round-off of its floating-point sum;
* outputs are evaluated at the fine steps' ends; between them an output moves by at most the
  step length times a bound of its derivative, which :func:`small_gain` adds (``intersample``).

An input that keeps one sign, ``0 <= w(t) <= W`` (or ``-W <= w <= 0``), drives an output to
``int g w ds``, between ``-W int g-`` and ``W int g+`` with ``g+``, ``g-`` the kernel's positive and
negative parts: its bound is ``W max(int g+, int g-)`` (``PeakGains.one_signed``). Each fine step's
kernel is its value at the step's end (one sign over the step) plus the first-order and remainder
terms above, which are added to both parts, as is the tail.
"""

from __future__ import annotations

import functools
import itertools
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import LinAlgWarning, expm, lu_factor, lu_solve, schur, solve_discrete_lyapunov, solve_sylvester

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import DesignError
from auv_hinf.numerics.lmi import roundoff_margin

#: Fine steps per sample period: the intersample and within-step terms are O(h / FINE_STEPS).
FINE_STEPS = 8
#: Periods summed exactly before the geometric tail bound takes over (at least).
MIN_PERIODS = 64
#: The exact sum stops once the tail bound it adds exceeds the exact remaining sum by at most this
#: fraction of the gain so far (the excess is bounded through a lower bound of the remaining sum,
#: :class:`_SignedSums`), so every gain is within this fraction of the exact peak-to-peak gain.
TAIL_RTOL = 1e-4
#: A gain below this fraction of its a-priori bound (the contraction's tail from the first period)
#: is summed only to :data:`TAIL_RTOL` of that fraction: a gain that is nearly zero for the loop's
#: numbers (not for its structure: those are exactly zero, :func:`_linked`) ends with a tail that
#: is small against the gains the loop's other pairs have.
ZERO_RTOL = 1e-9
#: Largest number of periods summed exactly (a loop this slow gets a larger tail bound).
MAX_PERIODS = 20000
#: Relative inflation of every summed gain for the round-off of its floating-point sum: a sum of ``m``
#: nonnegative terms is off by at most ``m eps`` of itself, and a gain sums at most
#: ``MAX_PERIODS x (FINE_STEPS + 1)`` period-step terms of the kernel (with the within-step terms and
#: the tail, about 2e5 of them: 4e-11), so 1e-10 covers it (an independent sum of a pure feedthrough
#: gain came out 1e-15 above it without this).
SUM_ROUNDOFF = 1e-10
#: The outputs' Gramian tails (:func:`_gramians`) are computed beside the contraction's when the
#: contraction's would need more than this many further periods to meet :data:`TAIL_RTOL`: the
#: Gramians cost one Stein equation per output row and step, which a fast loop does not repay.
GRAMIAN_AFTER = 4 * MIN_PERIODS
#: Spectral radius of the period map above which the loop counts as unstable.
UNSTABLE_RADIUS = 1.0 - 1e-9


def _frozen(a: FloatArray) -> FloatArray:
    arr = np.array(a, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise DesignError(f"loop matrices must be finite, got {arr!r}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class SampledLoop:
    """A continuous plant under a held, delayed, discrete law (see the module docstring).

    Attributes
    ----------
    a, b_u, b_w : ndarray
        Plant ``(n, n)``, command input ``(n, nu)`` and continuous inputs ``(n, nw)``.
    c_y : ndarray, shape (ny, n)
        What the law measures.
    d_n : ndarray, shape (ny, nn)
        How the discrete inputs enter the measurement (measurement errors).
    b_cn : ndarray, shape (nc, nn)
        How the discrete inputs enter the law's state at its update (zero rows without a state).
    a_c, b_c, c_c, d_c : ndarray
        The discrete law ``(nc, nc)``, ``(nc, ny)``, ``(nu, nc)``, ``(nu, ny)`` (``nc`` may be 0).
    sample_time, delay : float
        ``h > 0`` and ``d >= 0`` (s).
    outputs : ndarray, shape (no, n + nc + nu + ny)
        Each output as a row on ``(x(t), xi(t), u(t), y_used(t))``: the plant state, the law's
        state, the held command and the measurement it was computed from.
    names : tuple of str
        The outputs' names.
    """

    a: FloatArray
    b_u: FloatArray
    b_w: FloatArray
    c_y: FloatArray
    d_n: FloatArray
    b_cn: FloatArray
    a_c: FloatArray
    b_c: FloatArray
    c_c: FloatArray
    d_c: FloatArray
    sample_time: float
    delay: float
    outputs: FloatArray
    names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        for name in ("a", "b_u", "b_w", "c_y", "d_n", "b_cn", "a_c", "b_c", "c_c", "d_c", "outputs"):
            object.__setattr__(self, name, _frozen(np.atleast_2d(getattr(self, name))))
        n, nu, ny, nc = self.sizes
        if self.outputs.shape[1] != n + nc + nu + ny:
            raise DesignError(f"outputs must have {n + nc + nu + ny} columns, got {self.outputs.shape}")
        if not (self.sample_time > 0.0 and math.isfinite(self.sample_time)):
            raise DesignError(f"sample_time must be > 0 (s), got {self.sample_time!r}")
        if not (self.delay >= 0.0 and math.isfinite(self.delay)):
            raise DesignError(f"delay must be >= 0 (s), got {self.delay!r}")

    @property
    def sizes(self) -> tuple[int, int, int, int]:
        """``(n, nu, ny, nc)``."""
        nc = self.a_c.shape[0] if self.a_c.size else 0
        return self.a.shape[0], self.b_u.shape[1], self.c_y.shape[0], nc


@dataclass(frozen=True)
class PeakGains:
    """Upper bounds of a loop's peak-to-peak gains, at the fine steps' ends.

    Attributes
    ----------
    continuous : ndarray, shape (no, nw)
        From each continuous input to each output.
    discrete : ndarray, shape (no, nn)
        From each discrete measurement error to each output.
    radius : float
        Spectral radius of the period map (< 1: the loop is stable).
    step : float
        The longest fine step (s): outputs between step ends move by at most ``step`` times their
        derivative's bound.
    derivative : ndarray, shape (no, n + nu + nw)
        ``|d output/dt| <= derivative @ (|x|_sup, |u|_sup, |w|_sup)``: rows ``|c_x A|, |c_x B_u|,
        |c_x B_w|`` (the held command and the used measurement are constant between samples).
    one_signed : ndarray, shape (no, nw)
        From each continuous input that keeps one sign (either sign, not changing; constants
        included) to each output: ``max(int g+, int g-)`` of the kernel's positive and negative
        parts, at most :attr:`continuous` (their sum). An output whose response to a constant
        input settles to zero (the velocity error under a position loop's force) gets about half.
    """

    continuous: FloatArray
    discrete: FloatArray
    radius: float
    step: float
    derivative: FloatArray
    one_signed: FloatArray


def _zoh(a: FloatArray, b: FloatArray, t: float) -> tuple[FloatArray, FloatArray]:
    """Exact zero-order-hold maps ``(e^{A t}, int_0^t e^{A s} ds B)``: one matrix exponential.

    ``expm(t [[A, B], [0, 0]])`` holds both maps in its top block row (Van Loan, IEEE TAC 1978).
    It is the computation python-control's ``sample_system(..., method="zoh")`` runs (through
    SciPy's ``cont2discrete``), without building two state-space objects per call: the peak gains of
    a refused deployed fleet's advice ask for about 25,000 of these maps, and the objects cost
    12 of their 16 s (a test checks the two agree). A loop far too fast for the step overflows: its
    maps come out non-finite, and the period map's contraction (:func:`_contraction`) then calls the
    loop unstable.
    """
    n, m = a.shape[0], b.shape[1]
    if t <= 0.0:
        return np.eye(n), np.zeros_like(b)
    block = np.zeros((n + m, n + m))
    block[:n, :n] = a
    block[:n, n:] = b
    with np.errstate(over="ignore", invalid="ignore"):
        flow = expm(block * t)
    return np.array(flow[:n, :n]), np.array(flow[:n, n:])


#: Largest exponent of ``e^{||A|| t}`` evaluated; a loop beyond it (far too fast for its fine step)
#: gets infinite within-step terms and is treated as unstable, like one whose maps overflow.
_EXP_LIMIT = 700.0


def _growth(norm_a: float, t: float) -> float:
    """``int_0^t e^{a s} ds = (e^{a t} - 1)/a`` (``t`` at ``a = 0``): Gronwall's factor for a step of length ``t``."""
    x = norm_a * t
    if x > _EXP_LIMIT:
        return math.inf
    return t * (1.0 + 0.5 * x) if x < 1e-8 else math.expm1(x) / norm_a


def _third(norm_a: float, t: float) -> float:
    """``int_0^t s^2 e^{a s} / 2 ds <= e^{a t} t^3 / 6``: the second-order remainder of ``e^{A s} - I - A s``.

    ``||e^{A s} - I - A s|| <= ||A||^2 s^2 e^{||A|| s} / 2``, integrated over a step of length ``t``.
    """
    if norm_a * t > _EXP_LIMIT:
        return math.inf
    return math.exp(norm_a * t) * t**3 / 6.0


@dataclass(frozen=True)
class _Period:
    """The augmented state's maps over one period, step by step."""

    steps: list[tuple[FloatArray, float]]  # (map of the augmented state over the step, step length)
    events: list[FloatArray | None]  # map applied at the step's start (measurement / update), or None
    noise: list[FloatArray | None]  # how the measurement errors enter at that event, or None
    size: int
    plant: slice


@functools.lru_cache(maxsize=32)
def _period(loop: SampledLoop) -> _Period:
    """Break the period at the fine steps and at the measurement's phase; build every map.

    Augmented state ``Z = (x, xi, u, y_used, buffer)``: the buffer holds the measurements taken
    but not used yet, oldest first (``m + 1`` of them, ``d = m h + f``). At the measurement's
    phase the newest is appended; at phase 0 the oldest is used (after a measurement at the same
    instant, when ``f = 0``) and the buffer shifts.
    """
    n, nu, ny, nc = loop.sizes
    h, d = loop.sample_time, loop.delay
    m = in_flight(h, d)
    f = d - m * h
    if f < 1e-12 * h:
        f = 0.0
    phase = (h - f) % h  # the measurement's phase within the period
    slots = m + 1
    size = n + nc + nu + ny + slots * ny
    ix = slice(0, n)
    ixi = slice(n, n + nc)
    iu = slice(n + nc, n + nc + nu)
    iy = slice(n + nc + nu, n + nc + nu + ny)

    def slot(j: int) -> slice:
        start = n + nc + nu + ny + j * ny
        return slice(start, start + ny)

    # the measurement appends: when measured at phase 0 the buffer was just shifted, else it has
    # 'slots - 1' entries after the last use: the newest goes to the last slot in both cases
    nd = loop.d_n.shape[1]

    def measure() -> tuple[FloatArray, FloatArray]:
        mp = np.eye(size)
        mp[slot(slots - 1), :] = 0.0
        mp[slot(slots - 1), ix] = loop.c_y
        nz = np.zeros((size, nd))
        nz[slot(slots - 1), :] = loop.d_n
        return mp, nz

    def state_input() -> FloatArray:
        """The discrete inputs' entry into the law's state at its update."""
        nz = np.zeros((size, nd))
        if nc:
            nz[ixi, :] = loop.b_cn
        return nz

    def update() -> FloatArray:
        up = np.eye(size)
        # use the oldest: xi+ = A_c xi + B_c y, u = C_c xi + D_c y, y_used = y
        y0 = slot(0)
        up[ixi, :] = 0.0
        if nc:
            up[ixi, ixi] = loop.a_c
            up[ixi, y0] = loop.b_c
        up[iu, :] = 0.0
        if nc:
            up[iu, ixi] = loop.c_c
        up[iu, y0] = loop.d_c
        up[iy, :] = 0.0
        up[iy, y0] = np.eye(ny)
        # shift the buffer: slot j <- slot j + 1, the last slot cleared
        sh = np.eye(size)
        for j in range(slots):
            sh[slot(j), :] = 0.0
            if j + 1 < slots:
                sh[slot(j), slot(j + 1)] = np.eye(ny)
        out: FloatArray = sh @ up
        return out

    cuts = sorted({round(k * h / FINE_STEPS, 15) for k in range(FINE_STEPS)} | {phase})
    cuts = [c for c in cuts if c < h - 1e-15 * h]
    bounds = [*cuts, h]
    flows: dict[float, tuple[FloatArray, FloatArray]] = {}  # the fine steps mostly share one length
    steps: list[tuple[FloatArray, float]] = []
    events: list[FloatArray | None] = []
    noise: list[FloatArray | None] = []
    for start, end in itertools.pairwise(bounds):
        ev: FloatArray | None = None
        nz: FloatArray | None = None
        if abs(start - phase) < 1e-12 * h and start == 0.0:  # measure, then use (f = 0)
            mp, nm = measure()
            ev = update() @ mp
            nz = update() @ nm + state_input()
        elif start == 0.0:
            ev = update()
            nz = state_input()
        elif abs(start - phase) < 1e-12 * h:
            ev, nz = measure()
        length = round(end - start, 15)
        if length not in flows:
            flows[length] = _zoh(loop.a, loop.b_u, end - start)
        ad, bd = flows[length]
        st = np.eye(size)
        st[ix, ix] = ad
        st[ix, iu] = bd
        steps.append((st, end - start))
        events.append(ev)
        noise.append(nz)
    return _Period(steps, events, noise, size, ix)


def in_flight(sample_time: float, delay: float) -> int:
    """The measurements in flight of a law sampled every ``sample_time`` s on ``delay`` s old measurements.

    They are the buffer the sampled loop's period map carries as states (``d = m h + f``, ``m`` of them).

    Parameters
    ----------
    sample_time, delay : float
        ``h > 0`` and ``d >= 0`` (s).
    """
    return math.floor(delay / sample_time + 1e-12)


def _contraction(phi: FloatArray, level: float | None = None) -> tuple[FloatArray, float] | None:
    """A verified ``(P, rho)``: ``Phi^T P Phi <= rho^2 P``, ``P > 0``, ``rho < 1`` (``None`` when unstable).

    ``P`` solves the discrete Lyapunov equation of ``Phi / sqrt(r)``, so that ``rho <= sqrt(r)``;
    ``rho`` is then measured by a generalised eigenvalue problem and inflated by a relative 1e-9 for
    round-off. A period map that overflowed (a loop far too fast for its sample time) has no
    contraction either.

    Parameters
    ----------
    phi : ndarray
        The map.
    level : float, optional
        ``r``, between the spectral radius squared and 1 (default ``(1 + radius)/2``): lower gives a
        smaller ``rho`` and a worse conditioned ``P``.
    """
    if not np.all(np.isfinite(phi)):
        return None
    radius = float(np.abs(np.linalg.eigvals(phi)).max())
    if radius >= UNSTABLE_RADIUS:
        return None
    r = 0.5 * (1.0 + radius) if level is None else level
    if not radius * radius < r < 1.0:
        return None
    scaled = phi / math.sqrt(r)
    try:
        # an ill-conditioned solve (SciPy warns of it: a LinAlgWarning, or a RuntimeWarning for
        # eigenvalues near the bilinear map's pole) is verified below like any other
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LinAlgWarning)
            warnings.simplefilter("ignore", RuntimeWarning)
            p = solve_discrete_lyapunov(scaled.T, np.eye(phi.shape[0]))
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not np.all(np.isfinite(p)):
        return None
    p = 0.5 * (p + p.T)
    w, v = np.linalg.eigh(p)
    if w.min() <= 0.0:
        return None
    root = v @ np.diag(np.sqrt(w)) @ v.T
    inv_root = v @ np.diag(1.0 / np.sqrt(w)) @ v.T
    rho = float(np.linalg.norm(root @ phi @ inv_root, 2)) * (1.0 + 1e-9)
    if rho >= 1.0:
        return None
    return p, rho


@functools.lru_cache(maxsize=32)
def _maps(loop: SampledLoop) -> tuple[_Period, list[FloatArray], FloatArray, FloatArray]:
    """The period's step maps (event, then flow), the period map from phase 0 and the outputs' rows."""
    n, nu, ny, nc = loop.sizes
    per = _period(loop)
    maps = [st if ev is None else st @ ev for (st, _), ev in zip(per.steps, per.events, strict=True)]
    phi = np.eye(per.size)
    for mp in maps:
        phi = mp @ phi
    out = loop.outputs @ np.eye(n + nc + nu + ny, per.size)  # (x, xi, u, y_used) lead the augmented state
    return per, maps, phi, out


def period_radius(loop: SampledLoop) -> float:
    """Spectral radius of ``loop``'s period map: below 1 exactly when the sampled loop is stable.

    Parameters
    ----------
    loop : SampledLoop
        The loop.
    """
    phi = _maps(loop)[2]
    if not np.all(np.isfinite(phi)):
        return math.inf  # the period map overflowed: the loop is far too fast for its sample time
    return float(np.abs(np.linalg.eigvals(phi)).max())


def _sumsq(x: FloatArray) -> FloatArray:
    """``sum_i x[..., i]^2`` over the last axis (a few plant states: summed slice by slice, which
    numpy does far faster than a reduction over a short inner axis)."""
    out: FloatArray = np.square(x[..., 0])
    for i in range(1, x.shape[-1]):
        out += np.square(x[..., i])
    return out


def _row_quad(m: FloatArray, w: FloatArray) -> FloatArray:
    """``sqrt(m_i W m_i^T)`` of every row ``m_i`` of ``m`` (``W`` positive semidefinite; round-off clipped at 0)."""
    out: FloatArray = np.sqrt(np.maximum(((m @ w) * m).sum(axis=1), 0.0))
    return out


def _col_quad(m: FloatArray, w: FloatArray) -> FloatArray:
    """``sqrt(m_j^T W m_j)`` of every column ``m_j`` of ``m`` (``W`` positive semidefinite; round-off clipped at 0)."""
    out: FloatArray = np.sqrt(np.maximum(((w @ m) * m).sum(axis=0), 0.0))
    return out


def _row_norms(m: FloatArray) -> FloatArray:
    """The Euclidean norm of every row of ``m`` (``np.linalg.norm(m, axis=1)``, without its overhead)."""
    out: FloatArray = np.sqrt(np.einsum("ij,ij->i", m, m))
    return out


def _reached(loop: SampledLoop, seeds: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Which outputs a signal entering at ``seeds`` can reach at all, ``(no, columns)``.

    A directed graph on the plant states, the law's states, the held commands and the measurements
    (``seeds`` has a row for each, in that order, and a column per signal) has an edge wherever an
    entry of the loop's matrices is not zero (the measurement is ``C_y x`` taken earlier plus its
    error, so the delay and the hold add no edges). An output none of whose nonzero columns is
    reachable from a signal's seeds does not respond to it, for every value of the nonzero entries.
    """
    n, nu, ny, nc = loop.sizes
    size = n + nc + nu + ny
    ix, ixi = slice(0, n), slice(n, n + nc)
    iu, iy = slice(n + nc, n + nc + nu), slice(n + nc + nu, size)
    adj = np.zeros((size, size), dtype=bool)  # adj[to, from]
    adj[ix, ix] = loop.a != 0.0
    adj[ix, iu] = loop.b_u != 0.0
    adj[iy, ix] = loop.c_y != 0.0
    adj[iu, iy] = loop.d_c != 0.0
    if nc:
        adj[ixi, ixi] = loop.a_c != 0.0
        adj[ixi, iy] = loop.b_c != 0.0
        adj[iu, ixi] = loop.c_c != 0.0
    step = adj.astype(np.int64)
    reach = seeds
    while True:
        grown = reach | ((step @ reach.astype(np.int64)) > 0)
        if np.array_equal(grown, reach):
            break
        reach = grown
    out: NDArray[np.bool_] = ((loop.outputs != 0.0).astype(np.int64) @ reach.astype(np.int64)) > 0
    return out


def _linked(loop: SampledLoop) -> NDArray[np.bool_]:
    """Which input can reach which output at all, ``(no, nw + nn)``: False where the kernel is identically zero.

    The continuous inputs enter the plant states through ``B_w``, the measurement errors the
    measurements through ``D_n`` and the law's state through ``B_cn`` (:func:`_reached`). A pair not
    linked has a zero kernel: its gain is 0 exactly, and its tail bounds (which cannot know that)
    are not summed.
    """
    n, nu, ny, nc = loop.sizes
    nw = loop.b_w.shape[1]
    seeds = np.zeros((n + nc + nu + ny, nw + loop.d_n.shape[1]), dtype=bool)
    seeds[:n, :nw] = loop.b_w != 0.0
    seeds[n + nc + nu :, nw:] = loop.d_n != 0.0
    if nc:
        seeds[n : n + nc, nw:] = loop.b_cn != 0.0
    return _reached(loop, seeds)


@dataclass(frozen=True)
class _SignedSums:
    """The signed remaining sums ``S = sum_{k >= 0} l Phi^k v`` of a loop's output rows, and bounds of their error.

    ``S = l (I - Phi)^-1 v`` is solved through one factorisation of ``I - Phi``. With ``z`` the computed
    solution and ``r = (I - Phi) z - v`` its residual (inflated by its own round-off),
    ``l (I - Phi)^-1 v = l z - sum_k l Phi^k r``, and the sum is bounded by the contraction
    ``|Phi x|_P <= rho |x|_P``: ``|l|_{P^-1} |r|_P / (1 - rho)``, plus the round-off of ``l z``.
    ``|S| - err`` is a lower bound of ``sum_k |l Phi^k v|`` (the sum of the terms' absolute values is
    at least the absolute value of their sum), and ``S`` splits the tail between the kernel's
    positive and negative parts. Everything that does not depend on ``v`` is computed once
    (:meth:`of`).
    """

    lu: tuple[FloatArray, NDArray[np.intp]]  # factorisation of I - Phi
    gap: FloatArray  # I - Phi
    gap_norm: float  # ||I - Phi||_2
    stack: FloatArray  # the output rows l
    row_err: FloatArray  # |l|_{P^-1} sqrt(lambda_max(P)) / (1 - rho) per row
    row_norm: FloatArray  # |l|_2 per row

    @classmethod
    def of(cls, stack: FloatArray, phi: FloatArray, p: FloatArray, rho: float) -> _SignedSums:
        """The factorisation and the rows' weights for output rows ``stack`` of the period map ``phi``.

        Parameters
        ----------
        stack : ndarray, shape (rows, size)
            The output rows.
        phi : ndarray, shape (size, size)
            The period map.
        p, rho : ndarray, float
            A verified contraction ``Phi^T P Phi <= rho^2 P``.
        """
        gap = np.eye(phi.shape[0]) - phi
        w, v = np.linalg.eigh(p)
        inv = v @ np.diag(1.0 / w) @ v.T
        weight = math.sqrt(float(w.max())) / (1.0 - rho)
        return cls(
            lu_factor(gap), gap, float(np.linalg.norm(gap, 2)), stack, _row_quad(stack, inv) * weight, _row_norms(stack)
        )

    def __call__(self, state: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(l z, err)`` for every row ``l`` and column ``v`` of ``state``, each ``(rows, columns)``.

        Parameters
        ----------
        state : ndarray, shape (size, columns)
            The states the sums start from.
        """
        eps = float(np.finfo(float).eps)
        size = state.shape[0]
        z = lu_solve(self.lu, state)
        res = self.gap @ z - state
        z_norm = _col_norms(z)
        res_norm = _col_norms(res) + 4.0 * size * eps * (self.gap_norm * z_norm + _col_norms(state))
        err = np.outer(self.row_err, res_norm) + 4.0 * size * eps * np.outer(self.row_norm, z_norm)
        return self.stack @ z, err


def _col_norms(m: FloatArray) -> FloatArray:
    """The Euclidean norm of every column of ``m``."""
    out: FloatArray = np.sqrt(np.einsum("ij,ij->j", m, m))
    return out


def peak_gains(loop: SampledLoop, max_periods: int = MAX_PERIODS) -> PeakGains | None:
    """Upper bounds of the peak-to-peak gains of ``loop`` (see the module docstring), or ``None`` when unstable.

    By periodicity, the gain at an output phase ``q`` sums, over the injection steps ``j`` of one
    period, the responses at phase ``q`` of every later period to an injection at step ``j``. All
    injections are carried to the next period's start and propagated together by the period map.

    Parameters
    ----------
    loop : SampledLoop
        The loop.
    max_periods : int
        Most periods summed exactly before the tail bound is added (fewer: faster, and the
        gains of a slow loop come out larger, never smaller).
    """
    n = loop.sizes[0]
    per, maps, phi, out = _maps(loop)
    size, steps, no = per.size, len(maps), out.shape[0]
    nw, nn = loop.b_w.shape[1], loop.d_n.shape[1]
    contraction = _contraction(phi)
    if contraction is None:
        return None
    p, rho = contraction
    radius = float(np.abs(np.linalg.eigvals(phi)).max())
    linked = _linked(loop)
    # the outputs at the end of every step q, on the state at the period's start
    rows = []
    partial = np.eye(size)
    for mp in maps:
        partial = mp @ partial
        rows.append(out @ partial)
    stack = np.vstack(rows)  # (steps * no, size)
    sums = _SignedSums.of(stack, phi, p, rho)
    # per injection step j: the continuous inputs over the step (their kernel's value at its end,
    # times its length), the discrete inputs at its event, the first-order term of the continuous
    # kernel over the step, and unit plant states (for the second-order remainder)
    k = nw + nn + nw
    cols = k + n
    acc = np.zeros((steps, no, steps, k))  # output step q, output, injection step j, input
    pos = np.zeros((steps, no, steps, nw))  # the continuous kernel's value terms: positive parts
    neg = np.zeros((steps, no, steps, nw))  # ... and negative parts (acc holds their sum)
    rem = np.zeros((steps, no, steps))
    # every injection step's state, carried together through the rest of the period: at the end of
    # step q the injection of step j <= q has gone through the maps of steps j + 1 .. q
    carried = np.zeros((size, steps, cols))
    for q in range(steps):
        if q:
            carried[:, :q, :] = (maps[q] @ carried[:, :q, :].reshape(size, q * cols)).reshape(size, q, cols)
        length = per.steps[q][1]
        inj = carried[:, q, :]
        inj[per.plant, :nw] = loop.b_w * length
        entry = per.noise[q]
        if entry is not None:
            inj[:, nw : nw + nn] = per.steps[q][0] @ entry
        inj[per.plant, nw + nn : k] = loop.a @ loop.b_w * (0.5 * length * length)
        inj[per.plant, k:] = np.eye(n)
        resp = (out @ carried[:, : q + 1, :].reshape(size, (q + 1) * cols)).reshape(no, q + 1, cols)
        acc[q, :, : q + 1] += np.abs(resp[..., :k])
        pos[q, :, : q + 1] += np.maximum(resp[..., :nw], 0.0)
        neg[q, :, : q + 1] += np.maximum(-resp[..., :nw], 0.0)
        rem[q, :, : q + 1] += np.sqrt(_sumsq(resp[..., k:]))
    state = carried.reshape(size, steps * cols)
    # every gain's a-priori bound: the contraction's tail from the first period on
    prior = np.maximum(
        _tails(rows, state, p, rho).reshape(steps, no, steps, cols)[..., : nw + nn].sum(axis=2).max(axis=0), 1e-300
    )
    # the outputs of MIN_PERIODS consecutive periods on the state at the first one's start
    powers = [np.eye(size)]
    for _ in range(MIN_PERIODS):
        powers.append(phi @ powers[-1])
    leap = powers.pop()  # Phi^MIN_PERIODS
    seen = np.stack([stack @ pw for pw in powers], axis=1)  # (steps * no, MIN_PERIODS, size)
    periods = 0
    gram: _Gramians | None = None
    deflation: _Deflation | None = None
    slow = False
    while True:
        block = (seen @ state).reshape(steps, no, MIN_PERIODS, steps, cols)
        state = leap @ state
        acc += np.abs(block[..., :k]).sum(axis=2)
        pos += np.maximum(block[..., :nw], 0.0).sum(axis=2)
        neg += np.maximum(-block[..., :nw], 0.0).sum(axis=2)
        tail_part = block[..., k:]
        rem += np.sqrt(_sumsq(tail_part)).sum(axis=2)
        periods += MIN_PERIODS
        tails = contraction_tails = _tails(rows, state, p, rho).reshape(steps, no, steps, cols)
        own = None
        # a gain is summed to TAIL_RTOL of itself, or of ZERO_RTOL of its a-priori bound when it is
        # that small; a pair the loop's structure does not connect is not summed (its gain is 0)
        so_far = np.maximum(acc[..., : nw + nn].sum(axis=2).max(axis=0), ZERO_RTOL * prior)
        needed = np.where(linked, tails[..., : nw + nn].sum(axis=2).max(axis=0), 0.0)
        if not slow and _periods_left(needed, so_far, rho) > GRAMIAN_AFTER:
            # a slow loop: the tail with its slowest modes deflated, or else the outputs' own Gramians
            slow = True
            deflation = _deflation(stack, phi)
            gram = _gramians(stack, phi, radius) if deflation is None else None
        if gram is not None:
            own = _gramian_tails(gram, state).reshape(steps, no, steps, cols)
            tails = np.minimum(tails, own)
        deflated = None
        if deflation is not None:
            deflated = _deflated_tails(deflation, state)
            own = deflated.upper.reshape(steps, no, steps, cols)
            tails = np.minimum(tails, own)
        # the tail bound exceeds the exact remaining sum by at most itself less a lower bound of
        # that sum, |S| - err (S the signed remaining sum): once a slow mode of one sign carries
        # what is left, the two meet long before the tail itself is small
        signed, err = sums(state)
        signed, err = signed.reshape(steps, no, steps, cols), err.reshape(steps, no, steps, cols)
        lower = np.maximum(np.abs(signed) - err, 0.0)
        if deflated is not None:
            lower = np.maximum(lower, deflated.lower.reshape(steps, no, steps, cols))
        excess = np.maximum(tails - lower, 0.0)[..., : nw + nn].sum(axis=2).max(axis=0)
        if np.all((excess <= TAIL_RTOL * so_far) | ~linked) or periods >= max_periods:
            acc += tails[..., :k]
            # the tail's positive and negative parts P, N: P + N <= T (the tail bound) and P - N = S,
            # so P <= (T + S)/2 and N <= (T - S)/2, each at most T
            t_w, s_w, e_w = tails[..., :nw], signed[..., :nw], err[..., :nw]
            split_pos = np.clip(0.5 * (t_w + s_w + e_w), 0.0, t_w)
            split_neg = np.clip(0.5 * (t_w - s_w + e_w), 0.0, t_w)
            if deflated is not None:  # the slow modes' own positive and negative sums
                split_pos = np.minimum(split_pos, deflated.positive.reshape(steps, no, steps, cols)[..., :nw])
                split_neg = np.minimum(split_neg, deflated.negative.reshape(steps, no, steps, cols)[..., :nw])
            pos += split_pos
            neg += split_neg
            # the remainder's tail is a sum of norms over the unit states, sum_k |l Phi^k X|_2: the
            # contraction's and the Gramians' per-state tails bound it through their 2-norm (each is a
            # norm of the state, so the Frobenius norm of X enters), the deflated tail by its own
            # block form (:func:`_deflated_norm_tails`); then the smaller
            rem_tail = np.sqrt(_sumsq(contraction_tails[..., k:]))
            if gram is not None and own is not None:
                rem_tail = np.minimum(rem_tail, np.sqrt(_sumsq(own[..., k:])))
            if deflation is not None:
                units = state.reshape(size, steps, cols)[..., k:].reshape(size, -1)
                by_block = _deflated_norm_tails(deflation, units, n)
                rem_tail = np.minimum(rem_tail, by_block.reshape(steps, no, steps))
            rem += rem_tail
            break
    # int_0^delta |l e^{A s} B_w| ds <= delta |l B_w| + delta^2/2 |l A B_w| + |l| ||A||^2 ||B_w|| int s^2 e^{a s}/2 ds
    norm_a = float(np.linalg.norm(loop.a, 2))
    norm_bw = np.linalg.norm(loop.b_w, axis=0)
    third = np.array([norm_a * norm_a * _third(norm_a, per.steps[j][1]) for j in range(steps)])
    if not np.all(np.isfinite(third)):
        return None  # a loop far too fast for its fine step (see _EXP_LIMIT)
    variation = acc[..., nw + nn : k] + (rem * third[None, None, :])[..., None] * norm_bw
    cont = acc[..., :nw] + variation
    worst_c = cont.sum(axis=2).max(axis=0)
    one_signed = np.maximum((pos + variation).sum(axis=2), (neg + variation).sum(axis=2)).max(axis=0)
    worst_d = acc[..., nw : nw + nn].sum(axis=2).max(axis=0)
    c_x = loop.outputs[:, :n]
    deriv = np.hstack([np.abs(c_x) @ np.abs(loop.a), np.abs(c_x) @ np.abs(loop.b_u), np.abs(c_x) @ np.abs(loop.b_w)])
    # a pair the loop's structure does not connect has a zero kernel: its bounds are round-off
    worst_c = np.where(linked[:, :nw], worst_c, 0.0) * (1.0 + SUM_ROUNDOFF)
    worst_d = np.where(linked[:, nw:], worst_d, 0.0) * (1.0 + SUM_ROUNDOFF)
    one_signed = one_signed * (1.0 + SUM_ROUNDOFF)
    return PeakGains(
        continuous=worst_c,
        discrete=worst_d,
        radius=radius,
        step=max(s[1] for s in per.steps),
        derivative=deriv,
        one_signed=np.minimum(one_signed, worst_c),
    )


@dataclass(frozen=True)
class StepBounds:
    """Bounds of the loop's responses to constant continuous inputs, by output and input.

    For an input ``w`` with ``|w| <= W`` and ``|w'| <= R`` (a slowly varying input), ``z = w(0)
    S(t) + int_0^t S(t - s) w'(s) ds`` with ``S`` the step response, so an output whose step
    response decays to zero has ``|z| <= peak W + area R``.

    Attributes
    ----------
    peak : ndarray, shape (no, nw)
        ``sup_t |S(t)|``.
    area : ndarray, shape (no, nw)
        ``int_0^inf |S(t)| dt``; ``inf`` where the step response does not decay to zero.
    """

    peak: FloatArray
    area: FloatArray

    def bound(self, output: int, channel: int, size: float, rate: float) -> float:
        """``peak W + area R`` (``inf`` where the output's step response does not decay).

        Parameters
        ----------
        output, channel : int
            The output and the continuous input.
        size, rate : float
            ``W`` and ``R`` of the input.
        """
        area = float(self.area[output, channel])
        if not math.isfinite(area):
            return math.inf
        return float(self.peak[output, channel]) * size + area * rate


def _sweep(
    loop: SampledLoop, start: FloatArray, unit_input: bool, max_periods: int = MAX_PERIODS, rtol: float = TAIL_RTOL
) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """Peak and area of every output along responses of the loop, and which outputs decay.

    Each column of ``start`` (an augmented state) is a response from that state, with the unit
    continuous input of its column held on when ``unit_input`` (``start`` then has one column
    per input, for the first inputs), none otherwise. The response is propagated exactly to the end of every fine step;
    within a step the command and the input are constant, so ``x'' = A x'`` and ``c_x (x(t_q +
    s) - x(t_q)) = s c_x x' + s^2/2 c_x A x' + R`` with ``|R| <= |c_x| ||A||^2 |x'| s^3 e^{a s}/6``
    and ``x'`` known exactly at the step's start. A constant input takes the loop to an
    equilibrium ``(I - Phi)^-1 f`` (the held command is then constant): an output *decays* when it
    is zero there; beyond ``K`` periods a response's deviation from it is bounded through the
    period map's contraction ``|Phi^k d|_P <= rho^k |d|_P``.

    The responses are followed until the tail's envelope is below ``rtol`` of every decaying
    output's peak so far: the area's tail is then within ``rtol`` of it. A caller that needs only
    the peaks passes ``rtol = 1``: a decaying output's peak is ``max(peak, envelope)``, exact once
    the envelope is below it.

    Returns ``(peak, area, decaying)``, each ``(no, columns)`` (``area`` is ``inf`` where the output
    does not decay), or ``None`` when the loop is unstable.
    """
    n, nu, _, nc = loop.sizes
    per, maps, phi, out = _maps(loop)
    size, no, cols = per.size, out.shape[0], start.shape[1]
    contraction = _contraction(phi)
    if contraction is None:
        return None
    p, rho = contraction
    norm_a = float(np.linalg.norm(loop.a, 2))
    c_x = np.abs(loop.outputs[:, :n])
    iu = slice(n + nc, n + nc + nu)
    drive = loop.b_w[:, :cols] if unit_input else np.zeros((n, cols))
    forced = []  # the inputs' effect over each step, in the augmented state
    for _, length in per.steps:
        f = np.zeros((size, cols))
        if unit_input:
            f[per.plant, :] = _zoh(loop.a, drive, length)[1]
        forced.append(f)
    period_input = np.zeros((size, cols))
    for mp, f in zip(maps, forced, strict=True):
        period_input = mp @ period_input + f
    steady = np.linalg.solve(np.eye(size) - phi, period_input)  # the equilibrium at phase 0
    steady_out = np.abs(out @ steady)
    decaying = steady_out <= 1e-12 * np.maximum(np.abs(out).sum(axis=1, keepdims=True), 1e-300)
    # the tail: every output at every step end and the plant state and the command, on a deviation
    # from the equilibrium, in the contraction's norm (|l d| <= |l|_{P^-1} |d|_P)
    w_p, v_p = np.linalg.eigh(p)
    inv = v_p @ np.diag(1.0 / w_p) @ v_p.T
    rows = []
    partial = np.eye(size)
    for mp in maps:
        partial = mp @ partial
        rows.append(out @ partial)
    row_norm = np.max(np.stack([_row_quad(r, inv) for r in rows]), axis=0)
    plant_norm = float(np.sqrt(max(float(np.max(np.linalg.eigvalsh(inv[per.plant, per.plant]))), 0.0)))
    u_norm = float(np.sqrt(max(float(np.max(np.linalg.eigvalsh(inv[iu, iu]))), 0.0))) if nu else 0.0
    # within a step a deviation (homogeneous: the input is balanced at the equilibrium) moves by at
    # most |d'| (e^{a s} - 1)/a with |d'| <= ||A|| |d_x| + ||B_u|| |d_u|
    growth = _growth(norm_a, max(st[1] for st in per.steps))
    if not math.isfinite(growth):
        return None  # a loop far too fast for its fine step (see _EXP_LIMIT)
    move_tail = np.linalg.norm(c_x, axis=1) * (
        (norm_a * plant_norm + float(np.linalg.norm(loop.b_u, 2)) * u_norm) * growth
    )
    # within the period the augmented state is affine in the state at its start: before step q's
    # flow it is E_q S + e_q (E_q the events and flows so far, e_q the inputs' effect so far)
    lead, offset = [], []
    partial, acc = np.eye(size), np.zeros((size, cols))
    for ev, (flow, _), f in zip(per.events, per.steps, forced, strict=True):
        if ev is not None:
            partial, acc = ev @ partial, ev @ acc
        lead.append(partial)
        offset.append(acc)
        partial, acc = flow @ partial, flow @ acc + f
    lead_all = np.stack(lead)  # (steps, size, size)
    offset_all = np.stack(offset)  # (steps, size, cols)
    lengths = np.array([st[1] for st in per.steps])[:, None, None, None]  # (steps, 1, 1, 1)
    c_full = loop.outputs[:, :n]
    cx_norm = np.linalg.norm(c_x, axis=1)
    third = (norm_a**2 * np.exp(norm_a * lengths)) / 6.0
    peak = np.zeros((no, cols))
    area = np.zeros((no, cols))
    state = np.array(start, dtype=float)
    # every output's a-priori bound (the tail's bound from the start): an output far below it is
    # followed only to ZERO_RTOL of it, as in peak_gains
    prior = steady_out + (row_norm + move_tail)[:, None] * _col_quad(state - steady, p)[None, :]
    periods = 0
    while True:
        batch = []
        for _ in range(MIN_PERIODS):
            batch.append(state)
            state = phi @ state + period_input
        starts = np.stack(batch, axis=1)  # (size, K, cols)
        steps, kc = lead_all.shape[0], starts.shape[1] * cols
        begun = (lead_all @ starts.reshape(size, kc)).reshape(steps, size, -1, cols) + offset_all[:, :, None, :]
        flat = begun.reshape(steps, size, kc)  # (steps, size, K * cols)
        xdot = loop.a @ flat[:, per.plant] + np.tile(drive, kc // cols)
        if nu:
            xdot = xdot + loop.b_u @ flat[:, iu]
        z0 = np.abs(out @ flat).reshape(steps, no, -1, cols)
        d1 = np.abs(c_full @ xdot).reshape(steps, no, -1, cols)
        d2 = np.abs((c_full @ loop.a) @ xdot).reshape(steps, no, -1, cols)
        xdot = xdot.reshape(steps, n, -1, cols)
        r3 = cx_norm[None, :, None, None] * np.linalg.norm(xdot, axis=1)[:, None, :, :] * third
        top = z0 + lengths * d1 + 0.5 * lengths**2 * d2 + r3 * lengths**3
        peak = np.maximum(peak, top.max(axis=(0, 2)))
        area += (lengths * z0 + 0.5 * lengths**2 * d1 + lengths**3 / 6.0 * d2 + r3 * lengths**4 / 4.0).sum(axis=(0, 2))
        periods += MIN_PERIODS
        dev = state - steady
        dev_p = _col_quad(dev, p)  # |d|_P per column
        env = (row_norm + move_tail)[:, None] * dev_p[None, :]  # a tail deviation's sup, times rho^k
        small = np.where(decaying, env <= rtol * np.maximum(peak, ZERO_RTOL * prior), True)
        if np.all(small) or periods >= max_periods:
            peak = np.maximum(peak, steady_out + env)
            area = np.where(decaying, area + env * loop.sample_time / (1.0 - rho), np.inf)
            return peak, area, decaying


def step_bounds(loop: SampledLoop, inputs: int | None = None) -> StepBounds | None:
    """Rigorous :class:`StepBounds` of ``loop``'s continuous inputs (``None`` when unstable).

    The response to each unit constant input from rest (:func:`_sweep`).

    Parameters
    ----------
    loop : SampledLoop
        The loop.
    inputs : int, optional
        Only the first ``inputs`` continuous inputs (the columns of the result; default all): a
        caller that treats only some inputs as slowly varying saves the others' sweeps, each as
        costly as the first.
    """
    size = _period(loop).size
    count = loop.b_w.shape[1] if inputs is None else min(inputs, loop.b_w.shape[1])
    swept = _sweep(loop, np.zeros((size, count)), True)
    if swept is None:
        return None
    return StepBounds(peak=swept[0], area=swept[1])


def free_peaks(loop: SampledLoop, max_periods: int = MAX_PERIODS) -> FloatArray | None:
    """Bounds of ``sup_t |z(t)|`` per unit initial plant state, shape ``(no, n)`` (``None`` when unstable).

    The loop starts at rest but for its plant state ``x(0) = e_i``; measurements before ``t = 0``
    are of ``x(0)`` (the convention of :mod:`auv_hinf.implementation.model`), so the buffer starts
    full of ``C_y e_i`` (:func:`_sweep`).

    Parameters
    ----------
    loop : SampledLoop
        The loop.
    max_periods : int
        Most periods followed exactly before the contraction bound takes over (as in
        :func:`peak_gains`).
    """
    n, nu, ny, nc = loop.sizes
    size = _period(loop).size
    state = np.zeros((size, n))
    state[:n, :] = np.eye(n)
    slots = (size - (n + nc + nu + ny)) // ny
    for j in range(slots):
        begin = n + nc + nu + ny + j * ny
        state[begin : begin + ny, :] = loop.c_y
    # only the peaks are used: a free response decays to zero, and its peak is exact as soon as
    # the tail's envelope is below it (rtol 1)
    swept = _sweep(loop, state, False, max_periods, rtol=1.0)
    if swept is None:
        return None
    # a start in plant state i enters at x_i and, through the measurements taken before t = 0, at
    # the measurements of x_i: an output that neither reaches does not move (its bound is round-off)
    seeds = np.zeros((n + nc + nu + ny, n), dtype=bool)
    seeds[:n, :] = np.eye(n, dtype=bool)
    seeds[n + nc + nu :, :] = loop.c_y != 0.0
    out: FloatArray = np.where(_reached(loop, seeds), swept[0], 0.0)
    return out


def _tails(offsets: Sequence[FloatArray], state: FloatArray, p: FloatArray, rho: float) -> FloatArray:
    """Bounds of ``sum_{k >= 0} |O_o Phi^k v|`` for every offset's output map ``O_o`` and column ``v`` of ``state``.

    With ``|Phi^k v|_P <= rho^k |v|_P`` and ``|l v| <= |l|_{P^-1} |v|_P``: ``|l|_{P^-1} |v|_P / (1 - rho)``.
    """
    w, v = np.linalg.eigh(p)
    inv = v @ np.diag(1.0 / w) @ v.T
    cols = _col_quad(state, p)
    out = []
    for o in offsets:
        out.append(np.outer(_row_quad(o, inv), cols) / (1.0 - rho))
    return np.stack(out)


#: The Gramian tail (:func:`_gramians`) weights the k-th period by ``sigma^-k`` with ``sigma`` the
#: period map's spectral radius raised to this power (at most 1, so ``radius^2 < sigma < 1`` and the
#: weighted sum converges): 1 is exact for a loop whose slowest mode is a real pole, whose tail the
#: bound then charges ``1/(1 - radius)`` like the true geometric sum.
GRAMIAN_POWER = 1.0
#: Floor of ``sigma`` (a loop whose period map is nearly nilpotent keeps a finite weight).
GRAMIAN_FLOOR = 0.05
#: Slack added to each output's Gramian, in units of the round-off of its Stein equation
#: (``size eps ||W|| (1 + ||A||^2)``, the residual ``W - A^T W A - l^T l`` being assembled from terms of
#: that size): enough to clear the eigenvalue check's margin (64 times that round-off,
#: :data:`~auv_hinf.numerics.lmi.EIG_ROUNDOFF_FACTOR`) at the first try on the REMUS and BlueROV2
#: loops, little enough not to loosen the tails (measured when the sum stopped at a tail below
#: TAIL_RTOL of the gain: the ILOS loop stopped at 7,104 periods; with 256 at 7,296, with 1e4 at 8,000).
GRAMIAN_SLACK = 128.0
#: Attempts, each with ten times the slack, before an output falls back to the contraction's tail.
GRAMIAN_TRIES = 4
#: Largest state for which every output's Stein equation is solved through one factorisation of the
#: Kronecker operator (size^2 unknowns: 784 at 28, about 20 ms); larger states solve each on its own,
#: which is faster from there on (0.09 s against 0.22 s for 128 rows at 40).
GRAMIAN_KRON = 28


def _periods_left(tails: FloatArray, target: FloatArray, rho: float) -> float:
    """Periods the contraction's tails (decaying as ``rho`` per period) need to fall to ``TAIL_RTOL target``."""
    ratio = float(np.max(tails / np.maximum(TAIL_RTOL * target, 1e-300)))
    if ratio <= 1.0:
        return 0.0
    return math.log(ratio) / -math.log(rho) if rho > 0.0 else 0.0


@dataclass(frozen=True)
class _Gramians:
    """Verified weighted Gramians of output rows (:func:`_gramians`)."""

    w: FloatArray  # (rows, size, size)
    ok: NDArray[np.bool_]  # (rows,): verified
    sigma: float  # the weight's base
    norms: FloatArray  # (rows,) spectral norms of w

    @classmethod
    def none(cls, shape: tuple[int, ...], sigma: float) -> _Gramians:
        """No row verified (every row keeps the contraction's tail); ``shape`` is ``(rows, size, size)``."""
        return cls(np.zeros(shape), np.zeros(shape[0], dtype=bool), sigma, np.zeros(shape[0]))


def _gramians(rows: FloatArray, phi: FloatArray, radius: float) -> _Gramians:
    """Verified weighted observability Gramians of every output row of the period map.

    For an output row ``l`` and ``A = Phi / sqrt(sigma)`` (:data:`GRAMIAN_POWER`), a ``W >= 0`` with
    ``W - A^T W A - l^T l >= 0`` (both checked with ``eigvalsh`` beyond their round-off margins, which
    scale with ``||A||^2 ||W||``) bounds ``sum_k sigma^-k (l Phi^k v)^2 <= v^T W v`` for every ``v``
    (sum the inequality along ``A^k v``: the sum telescopes to ``v^T W v`` less a term ``>= 0``), so
    by Cauchy-Schwarz

        sum_{k >= 0} |l Phi^k v| <= sqrt(v^T W v / (1 - sigma)).

    Unlike the contraction's tail (:func:`_tails`) this respects the outputs a slow mode barely
    reaches: a pair whose response is small has a small Gramian tail. The Stein equations of all
    rows share one factorisation (``(I - A^T kron A^T) vec W = vec(l^T l)``) when the state is
    small enough (:data:`GRAMIAN_KRON`), else each is solved on its own.

    Returns the Gramians, with whether each row's was verified (a row that is not keeps the
    contraction's tail).
    """
    size = phi.shape[0]
    sigma = max(radius**GRAMIAN_POWER, GRAMIAN_FLOOR)
    a = phi / math.sqrt(sigma)
    eps = float(np.finfo(float).eps)
    loads = rows[:, :, None] * rows[:, None, :]  # (rows, size, size)
    # an ill-conditioned Stein equation is not an error here: its answer is verified below, and a
    # row whose Gramian fails the check keeps the contraction's tail
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", LinAlgWarning)
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            if size <= GRAMIAN_KRON:
                op = np.eye(size * size) - np.kron(a.T, a.T)
                lu = lu_factor(op)
                rhs = np.concatenate([loads.reshape(-1, size * size), np.eye(size).reshape(1, -1)]).T  # row-major
                sol = lu_solve(lu, rhs).T.reshape(-1, size, size)
                grams, base = sol[:-1], sol[-1]
            else:
                grams = np.stack([solve_discrete_lyapunov(a.T, load) for load in loads])
                base = solve_discrete_lyapunov(a.T, np.eye(size))
        except (np.linalg.LinAlgError, ValueError):
            return _Gramians.none(loads.shape, sigma)
    if not (np.all(np.isfinite(grams)) and np.all(np.isfinite(base))):
        return _Gramians.none(loads.shape, sigma)
    grams = 0.5 * (grams + np.swapaxes(grams, 1, 2))
    base = 0.5 * (base + base.T)  # the Gramian of the identity: the slack's shape
    norm_a2 = float(np.linalg.norm(a, 2)) ** 2
    norms = np.linalg.norm(grams, ord=2, axis=(1, 2))
    slack = GRAMIAN_SLACK * size * eps * np.maximum(norms, 1e-300) * (1.0 + norm_a2)
    out = np.zeros_like(grams)
    ok = np.zeros(rows.shape[0], dtype=bool)
    for _ in range(GRAMIAN_TRIES):
        cand = grams + slack[:, None, None] * base
        cand = 0.5 * (cand + np.swapaxes(cand, 1, 2))
        resid = cand - a.T @ cand @ a - loads
        resid = 0.5 * (resid + np.swapaxes(resid, 1, 2))
        low = np.linalg.eigvalsh(resid)[:, 0]
        eig_w = np.linalg.eigvalsh(cand)
        # the residual is assembled from terms up to ||A||^2 ||W||: its round-off scales with that
        scale = np.maximum(np.abs(low), np.abs(eig_w).max(axis=1) * (1.0 + norm_a2))
        margin = np.array([roundoff_margin(size, float(x)) for x in scale])
        # W >= 0 and the residual >= 0 bound the weighted sum for any A (telescoping), so the
        # radius that sigma was taken from need not be exact
        good = (low > margin) & (eig_w[:, 0] > -margin) & ~ok
        out[good], ok[good] = cand[good], True
        if ok.all():
            break
        slack = slack * 10.0
    return _Gramians(out, ok, sigma, np.linalg.norm(out, ord=2, axis=(1, 2)))


def _gramian_tails(gram: _Gramians, state: FloatArray) -> FloatArray:
    """``sqrt(v^T W v / (1 - sigma))`` for every verified row's ``W`` and column ``v`` of ``state`` (``inf`` elsewhere).

    The quadratic form is inflated by its round-off, ``4 size eps ||W|| |v|^2``.
    """
    size = state.shape[0]
    quad = ((gram.w @ state) * state[None]).sum(axis=1)
    sq = _sumsq(state.T)
    quad = np.maximum(quad, 0.0) + 4.0 * size * float(np.finfo(float).eps) * gram.norms[:, None] * sq[None, :]
    out: FloatArray = np.where(gram.ok[:, None], np.sqrt(quad / (1.0 - gram.sigma)), np.inf)
    return out


#: The deflated tail (:func:`_deflation`) separates the period map's one or two slowest modes when
#: they are real, positive and each at least this far in modulus from the next: their decoupling is
#: a Sylvester equation whose condition grows as the inverse of that gap.
DEFLATION_GAP = 1e-3
#: Largest condition number of the decoupling similarity ``S`` that is used: every round-off term of
#: the deflated tail carries a factor of it, and beyond this they would stop being negligible.
DEFLATION_COND = 1e8
#: The rest of the period map gets its own contraction at ``r = radius^2 + DEFLATION_LEVEL (1 -
#: radius^2)`` (:func:`_contraction`): ``rho <= sqrt(r)`` is close to its spectral radius, with ``P``
#: conditioned no worse than about ``1 / DEFLATION_LEVEL`` times that of ``(1 + radius)/2``.
DEFLATION_LEVEL = 0.25


@dataclass(frozen=True)
class _Deflation:
    """A decoupling ``Psi = S^-1 Phi S ~ N = blockdiag(diag(lambda), T)`` of the period map (:func:`_deflation`).

    ``lambda`` (``m = 1`` or ``2`` values, decreasing) are the slowest modes; ``T`` the rest. The
    bounds of :func:`_deflated_tails` hold for the exact ``Psi``, whose distance to ``N`` is at most
    :attr:`coupling`.
    """

    lu: tuple[FloatArray, NDArray[np.intp]]  # factorisation of S
    s: FloatArray  # S
    s_norm: float  # ||S||_F
    s_inv: float  # >= ||S^-1||_2
    modes: FloatArray  # lambda, shape (m,)
    rows: FloatArray  # the output rows times S, shape (rows, size)
    row_err: FloatArray  # bound of their round-off, shape (rows,) (2-norm)
    rest_p: FloatArray  # the rest's contraction
    rest_rho: float
    rest_rows: FloatArray  # |l_rest|_{P^-1} / (1 - rho) per row: the rest's contraction tail per unit |w_rest|_P
    rest_gram: _Gramians  # the rest's Gramians of the rows
    unit: FloatArray  # >= sup_{|x|_2 = 1} sum_k |l S N^k x| per row
    unit_any: float  # >= sup_{|y|_2 = |x|_2 = 1} sum_k |y N^k x|
    coupling: float  # >= ||Psi - N||_2
    rest_p_min: float  # the smallest eigenvalue of the rest's P


def _residual_bound(s: FloatArray, psi: FloatArray, phi: FloatArray) -> float:
    """A bound of ``||S Psi - Phi S||_F`` for the floating-point matrices given, computed in extended precision.

    The products are formed in ``numpy.longdouble`` (a 64-bit significand on x86-64), whose
    rounding errors are bounded by ``gamma = n u / (1 - n u)`` times ``|S| |Psi| + |Phi| |S|``
    entrywise (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., 2002, sec. 3.5),
    which is added; where ``longdouble`` is plain double the bound is the same formula in double.
    """
    ld = np.longdouble
    size = s.shape[0]
    unit = float(np.finfo(ld).eps) / 2.0
    gamma = size * unit / (1.0 - size * unit)
    a, b, c = s.astype(ld), psi.astype(ld), phi.astype(ld)
    resid = float(np.sqrt(np.sum(np.square(a @ b - c @ a))))
    scale = float(np.linalg.norm(np.abs(s) @ np.abs(psi) + np.abs(phi) @ np.abs(s)))
    # the Frobenius norm's own rounding (in long double) and its conversion to double, and the scale's
    # rounding in double, each a few units of double's last place at most
    slack = 1.0 + 8.0 * size * float(np.finfo(float).eps)
    return float(resid * slack + 2.0 * gamma * scale * slack)


def _deflation(rows: FloatArray, phi: FloatArray) -> _Deflation | None:
    """Separate the period map's slowest real modes from the rest, with every bound the tail needs.

    A real Schur form ordered with the ``m`` slowest eigenvalues first, ``Phi = Q [[T11, T12], [0,
    T22]] Q^T``, is block-diagonalised by ``[[I, X], [0, I]]`` with ``T11 X - X T22 = -T12`` (Sylvester),
    and ``T11`` (triangular, distinct eigenvalues) by its eigenvectors: ``S`` is the product. Only
    ``S`` matters afterwards, as any invertible matrix: ``Psi = S^-1 Phi S`` is computed, its distance to
    the block-diagonal ``N`` read from it (the off-diagonal blocks, and the solve's residual through
    ``||S^-1||``). ``None`` when the slowest modes are not real and positive, not separated by
    :data:`DEFLATION_GAP`, or ``S`` is too ill-conditioned.
    """
    size = phi.shape[0]
    vals = np.linalg.eigvals(phi)
    order = np.argsort(-np.abs(vals))
    top = vals[order]
    mods = np.abs(top)
    if size < 3 or not (top[0].imag == 0.0 and top[0].real > 0.0 and mods[0] - mods[1] > DEFLATION_GAP):
        return None
    m = 2 if top[1].imag == 0.0 and top[1].real > 0.0 and mods[1] - mods[2] > DEFLATION_GAP else 1
    cut = 0.5 * (mods[m - 1] + mods[m])
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", LinAlgWarning)
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            tri, q, sdim = schur(phi, output="real", sort=lambda re, im: im == 0.0 and re > cut)
            if sdim != m:
                return None
            x = solve_sylvester(tri[:m, :m], -tri[m:, m:], -tri[:m, m:])
        except (np.linalg.LinAlgError, ValueError):
            return None
    upper = np.eye(size)
    upper[:m, m:] = x
    if m == 2:  # the eigenvectors of [[a, b], [0, c]], (1, 0) and (b/(c - a), 1), the slower first
        vecs = np.array([[1.0, tri[0, 1] / (tri[1, 1] - tri[0, 0])], [0.0, 1.0]])
        upper[:2, :2] = vecs if tri[0, 0] > tri[1, 1] else vecs[:, ::-1]
    s = q @ upper
    if not np.all(np.isfinite(s)):
        return None
    sing = np.linalg.svd(s, compute_uv=False)
    eps = float(np.finfo(float).eps)
    gamma = 4.0 * size * eps
    smin = sing[-1] - gamma * sing[0]
    if smin <= 0.0 or sing[0] / smin > DEFLATION_COND:
        return None
    s_inv = 1.0 / smin
    lu = lu_factor(s)
    phis = phi @ s
    psi = lu_solve(lu, phis)
    s_norm = float(np.linalg.norm(s))
    resid = _residual_bound(s, psi, phi)  # >= ||S Psi - Phi S||_F, so ||Psi_exact - psi|| <= s_inv resid
    modes = np.diag(psi)[:m].copy()
    if not (1.0 > modes[0] > 0.0 and (m == 1 or modes[0] > modes[1] > 0.0)):
        return None
    block = np.zeros_like(psi)
    block[:m, :m] = np.diag(modes)
    block[m:, m:] = psi[m:, m:]
    coupling = float(np.linalg.norm(psi - block)) + s_inv * resid
    rest = psi[m:, m:]
    rest_radius = float(np.abs(np.linalg.eigvals(rest)).max())
    got = _contraction(rest, rest_radius**2 + DEFLATION_LEVEL * (1.0 - rest_radius**2))
    if got is None:
        return None
    rest_p, rest_rho = got
    w, v = np.linalg.eigh(rest_p)
    srows = rows @ s
    rest_rows = _row_quad(srows[:, m:], v @ np.diag(1.0 / w) @ v.T) / (1.0 - rest_rho)
    row_err = gamma * _row_norms(rows) * s_norm
    # sup over unit x of sum_k |l S N^k x|: each slow mode's 1/(1 - lambda), and the rest's sum, by the
    # smaller of its contraction's tail and its Gramian's, sqrt(lambda_max(W) / (1 - sigma))
    slow = (np.abs(srows[:, :m]) / (1.0 - modes)).sum(axis=1)
    rest_gram = _gramians(srows[:, m:], rest, rest_radius)
    by_gram = np.where(
        rest_gram.ok, np.sqrt(np.linalg.eigvalsh(rest_gram.w)[:, -1].clip(0.0) / (1.0 - rest_gram.sigma)), np.inf
    )
    by_gram = by_gram * (1.0 + 1e-9) + np.sqrt(rest_gram.norms / (1.0 - rest_gram.sigma)) * 1e-9  # eigvalsh's round-off
    unit = slow + np.minimum(rest_rows * math.sqrt(float(w.max())), by_gram)
    unit_any = float((1.0 / (1.0 - modes)).sum()) + math.sqrt(float(w.max() / w.min())) / (1.0 - rest_rho)
    return _Deflation(
        lu=lu,
        s=s,
        s_norm=s_norm,
        s_inv=s_inv,
        modes=modes,
        rows=srows,
        row_err=row_err,
        rest_p=rest_p,
        rest_rho=rest_rho,
        rest_rows=rest_rows,
        rest_gram=rest_gram,
        unit=unit,
        unit_any=unit_any,
        coupling=coupling,
        rest_p_min=float(w.min()),
    )


@dataclass(frozen=True)
class _Tails:
    """Bounds of the remaining sums ``sum_{k >= 0} |l Phi^k v|`` per row and column (:func:`_deflated_tails`)."""

    upper: FloatArray  # of the sum
    lower: FloatArray  # of the sum, from below
    positive: FloatArray  # of the sum of the terms' positive parts
    negative: FloatArray  # of the sum of their negative parts


def _slow_sums(a: FloatArray, b: FloatArray, lam: float, mu: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``sum_{k >= 0} |f_k|`` and the sums of ``f_k``'s positive and negative parts, ``f_k = a lam^k + b mu^k``.

    Exact (elementwise) for ``1 > lam > mu > 0``. Where ``a`` and ``b`` have one sign the terms do too
    and the sum is ``|a/(1 - lam) + b/(1 - mu)|``. Otherwise ``(a (lam/mu)^k + b)`` is monotone in
    ``k``: the terms have ``b``'s sign before ``k* = ln(-b/a)/ln(lam/mu)`` and ``a``'s after, so the sum
    is the absolute values of the two one-signed geometric pieces, plus the three terms around the
    crossing taken one by one (which leaves room for an error of up to one index in ``k*``). Each
    result is inflated by a relative 1e-12 for its round-off.
    """
    sa, sb = a / (1.0 - lam), b / (1.0 - mu)
    whole = sa + sb
    total, positive, negative = np.abs(whole), np.maximum(whole, 0.0), np.maximum(-whole, 0.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        cross = np.where((a * b < 0.0), np.log(-b / a) / math.log(lam / mu), -1.0)
    split = np.isfinite(cross) & (cross > 0.0)
    if np.any(split):
        a_s, b_s, k = a[split], b[split], np.floor(cross[split])
        k0, k1 = np.maximum(k - 1.0, 0.0), k + 2.0
        head = a_s * (1.0 - lam**k0) / (1.0 - lam) + b_s * (1.0 - mu**k0) / (1.0 - mu)
        tail = a_s * lam**k1 / (1.0 - lam) + b_s * mu**k1 / (1.0 - mu)
        up = np.maximum(head, 0.0) + np.maximum(tail, 0.0)
        down = np.maximum(-head, 0.0) + np.maximum(-tail, 0.0)
        for j in range(3):
            kj = k0 + j
            term = np.where(kj < k1, a_s * lam**kj + b_s * mu**kj, 0.0)
            up, down = up + np.maximum(term, 0.0), down + np.maximum(-term, 0.0)
        total[split], positive[split], negative[split] = up + down, up, down
    slack = 1e-12 * (np.abs(sa) + np.abs(sb))
    return total * (1.0 + 1e-12) + slack, positive * (1.0 + 1e-12) + slack, negative * (1.0 + 1e-12) + slack


def _deflated_tails(defl: _Deflation, state: FloatArray) -> _Tails:
    """Bounds of ``sum_{k >= 0} |l Phi^k v|`` for every output row ``l`` and column ``v`` of ``state``.

    With ``w = S^-1 v`` and ``Psi = S^-1 Phi S = N + E``: ``l Phi^k v = (l S) Psi^k w`` and ``Psi^k = N^k
    + sum_{j < k} N^{k-1-j} E Psi^j``, so the sum is at most ``sum_k |(l S) N^k w|`` plus ``unit(l) ||E||
    sum_j |Psi^j w|_2``, the last by the same expansion (a Neumann series in ``unit_any ||E||``, which
    must be below 1). ``sum_k |(l S) N^k w|`` is the slow modes' sum, exact
    (:func:`_slow_sums`), plus the rest's, bounded by the smaller of its contraction's and its
    Gramians' tails; the round-off of ``w`` (``|e|_2 <= dw``) is charged through ``unit``, and that of
    ``l S`` (``|f|_2 <= row_err``) through :attr:`_Deflation.unit_any`. Every term but the slow modes'
    exact sum decays with the rest's modes, not the slowest one; the slow modes' sum less all of them
    is a lower bound (the triangle inequality the other way), so that upper less lower decays with
    the rest's modes too, even where the remaining response changes sign. The sums of the terms'
    positive and negative parts are bounded the same way, from the slow modes' exact ones.
    """
    w, contraction, gramian, spill = _deflated_terms(defl, state)
    m = defl.modes.shape[0]
    rows = defl.rows
    first = np.outer(rows[:, 0], w[0])
    if m == 2:
        slow, up, down = _slow_sums(first, np.outer(rows[:, 1], w[1]), defl.modes[0], defl.modes[1])
    else:  # one slow mode: the second term is zero
        slow, up, down = _slow_sums(first, np.zeros_like(first), defl.modes[0], 0.5 * defl.modes[0])
    spill = spill + np.minimum(np.outer(contraction[0], contraction[1]), gramian)
    return _Tails(slow + spill, np.maximum(slow / (1.0 + 1e-12) - spill, 0.0), up + spill, down + spill)


def _deflated_norm_tails(defl: _Deflation, state: FloatArray, group: int) -> FloatArray:
    """Bounds of ``sum_{k >= 0} |l Phi^k X|_2`` for every output row ``l`` and block ``X`` of ``group`` columns.

    The row vector's 2-norm over a block (the remainder's unit states): the slow modes contribute
    ``|l S e_i| |w_i|_2 / (1 - lambda_i)`` (``w_i`` the block's slow coordinate ``i``), the rest the
    2-norm over the block of its per-column contraction or Gramian tails (both are norms of the
    state, so they bound the block's Frobenius norm, hence its 2-norm, period by period), and the
    round-off and coupling terms their sum over the block (``|y|_2 <= |y|_1``).
    """
    w, contraction, gramian, spill = _deflated_terms(defl, state)
    m = defl.modes.shape[0]
    blocks = state.shape[1] // group

    def over(x: FloatArray) -> FloatArray:  # (..., columns) -> (..., blocks, group)
        return x.reshape(*x.shape[:-1], blocks, group)

    # the slow modes: l Psi^k X's slow part is a lam^k + b mu^k with block vectors a = (l S)_1 w_1 and
    # b = (l S)_2 w_2; with b's part along a, beta a, and the rest b_perp (orthogonal to a), its norm is
    # sqrt(|a|^2 (lam^k + beta mu^k)^2 + |b_perp|^2 mu^2k) exactly: summed term by term over NORM_TERMS
    # periods, and beyond them by |a| |lam^k + beta mu^k| + |b_perp| mu^k, whose sum is exact
    # the block vectors are scaled by their largest entries first, so that no product underflows
    w1 = over(w[0])  # (blocks, group)
    s1 = np.abs(w1).max(axis=-1)
    u1 = w1 / np.where(s1 > 0.0, s1, 1.0)[:, None]
    u1_sq = _sumsq(u1)
    a_len = np.outer(np.abs(defl.rows[:, 0]), s1 * np.sqrt(u1_sq))  # |a| per row and block
    if m == 2:
        w2 = over(w[1])
        s2 = np.abs(w2).max(axis=-1)
        u2 = w2 / np.where(s2 > 0.0, s2, 1.0)[:, None]
        u2_sq, dot = _sumsq(u2), (u1 * u2).sum(axis=-1)
        b_len = np.outer(np.abs(defl.rows[:, 1]), s2 * np.sqrt(u2_sq))
        # a = 0 exactly (no first slow component, or none of w_1): the triangle inequality, term by term
        flat = (defl.rows[:, 0] == 0.0)[:, None] | (s1 == 0.0)[None, :]
        safe = np.where(s1 > 0.0, s1, 1.0) * np.where(u1_sq > 0.0, u1_sq, 1.0)
        beta = np.outer(defl.rows[:, 1] / np.where(defl.rows[:, 0] == 0.0, 1.0, defl.rows[:, 0]), s2 * dot / safe)
        perp = s2 * np.sqrt(np.maximum(u2_sq - dot**2 / np.where(u1_sq > 0.0, u1_sq, 1.0), 0.0) + 1e-12 * u2_sq)
        b_perp = np.outer(np.abs(defl.rows[:, 1]), perp)
        slow = np.where(
            flat,
            (a_len / (1.0 - defl.modes[0]) + b_len / (1.0 - defl.modes[1])) * (1.0 + 1e-12),
            _slow_norm_sum(a_len, np.where(flat, 0.0, beta), b_perp, defl.modes[0], defl.modes[1]),
        )
    else:
        slow = a_len / (1.0 - defl.modes[0]) * (1.0 + 1e-12)
    rest = np.minimum(np.outer(contraction[0], np.sqrt(_sumsq(over(contraction[1])))), np.sqrt(_sumsq(over(gramian))))
    out: FloatArray = slow + rest + over(spill).sum(axis=-1)
    return out


#: Periods over which :func:`_slow_norm_sum` sums its sequence term by term (beyond them, by a closed form).
NORM_TERMS = 2048


def _slow_norm_sum(a: FloatArray, beta: FloatArray, b: FloatArray, lam: float, mu: float) -> FloatArray:
    """``sum_{k >= 0} sqrt(a^2 (lam^k + beta mu^k)^2 + b^2 mu^2k)`` (elementwise, ``a, b >= 0``, ``1 > lam > mu > 0``).

    The first :data:`NORM_TERMS` terms are summed (each inflated by a relative ``4 eps`` for its
    round-off), the rest bounded by ``a sum |lam^k + beta mu^k| + b sum mu^k`` from ``k = NORM_TERMS``
    on, in closed form (:func:`_slow_sums` of the shifted sequence); the cancellation in ``lam^k + beta
    mu^k`` (``lam`` near ``mu``, ``beta`` near -1) is charged at a few eps of the terms' sizes.
    """
    eps = float(np.finfo(float).eps)
    total = np.zeros_like(a)
    for start in range(0, NORM_TERMS, 256):
        k = np.arange(start, start + 256, dtype=float)
        lk, mk = lam**k, mu**k
        terms = np.sqrt(np.square(a[..., None] * (lk + beta[..., None] * mk)) + np.square(b[..., None] * mk))
        total += terms.sum(axis=-1)
    total *= 1.0 + 4.0 * eps * NORM_TERMS
    shift_l, shift_m = lam**NORM_TERMS, mu**NORM_TERMS
    rest = a * _slow_sums(np.full_like(a, shift_l), beta * shift_m, lam, mu)[0] + b * shift_m / (1.0 - mu)
    # lam^k + beta mu^k cancels where lam is near mu and beta near -1: its rounding is a few eps of the
    # terms' sizes, not of their difference (every k, the closed-form rest included)
    cancel = 8.0 * eps * (a * (1.0 / (1.0 - lam) + np.abs(beta) / (1.0 - mu)) + b / (1.0 - mu))
    out: FloatArray = total + rest * (1.0 + 1e-12) + cancel
    return out


def _deflated_terms(
    defl: _Deflation, state: FloatArray
) -> tuple[FloatArray, tuple[FloatArray, FloatArray], FloatArray, FloatArray]:
    """What :func:`_deflated_tails` and :func:`_deflated_norm_tails` share, per row and column.

    Returns ``w = S^-1 v`` (computed); the rest's contraction tail as its row factor
    ``|l_r|_{P^-1} / (1 - rho)`` and column factor ``|w_r|_P``; its Gramian tails; and the sum of the
    round-off and coupling terms.
    """
    size = state.shape[0]
    m = defl.modes.shape[0]
    eps = float(np.finfo(float).eps)
    w = lu_solve(defl.lu, state)
    res = defl.s @ w - state
    w_norm = _col_norms(w)
    dw = defl.s_inv * (_col_norms(res) + 4.0 * size * eps * (defl.s_norm * w_norm + _col_norms(state)))
    contraction = (defl.rest_rows, _col_quad(w[m:], defl.rest_p))
    gramian = _gramian_tails(defl.rest_gram, w[m:])
    unit = defl.unit + defl.unit_any * defl.row_err  # per row, for the exact l S
    rounding = np.outer(defl.unit, dw) + np.outer(defl.unit_any * defl.row_err, w_norm + dw)
    # sum_j |Psi^j w|_2 <= sum_j |N^j w|_2 + unit_any ||E|| sum_j |Psi^j w|_2 (the expansion above, for
    # every unit row): a Neumann bound, with sum_j |N^j w|_2 from the slow modes and the rest's contraction
    gain = defl.unit_any * defl.coupling
    if gain >= 1.0:
        return w, contraction, gramian, rounding + np.inf
    free = (np.abs(w[:m]) / (1.0 - defl.modes)[:, None]).sum(axis=0) + contraction[1] / (
        math.sqrt(defl.rest_p_min) * (1.0 - defl.rest_rho)
    )
    orbit = (free + defl.unit_any * dw) / (1.0 - gain)
    return w, contraction, gramian, rounding + np.outer(unit * defl.coupling, orbit)


def small_gain(direct: FloatArray, loop_gain: FloatArray) -> FloatArray | None:
    """The least solution of ``z <= direct + loop_gain z`` (componentwise, nonnegative), or ``None``.

    With ``z`` the peaks, ``direct`` what the bounded inputs cause and ``loop_gain`` the
    perturbation channels (``|v_j| <= sum_i D_ji |z_i|``) closed through the loops' gains, the
    peaks satisfy ``z <= (I - loop_gain)^-1 direct`` when the nonnegative ``loop_gain`` has
    spectral radius below 1: the Neumann series converges and every term is nonnegative (the
    small-gain theorem in the peak norm). ``None`` when the radius is not below 1.

    Parameters
    ----------
    direct : ndarray, shape (k,)
        Nonnegative.
    loop_gain : ndarray, shape (k, k)
        Nonnegative.
    """
    k = direct.shape[0]
    if loop_gain.shape != (k, k):
        raise DesignError(f"small_gain: a ({k}, {k}) gain matrix is needed, got {loop_gain.shape}")
    if np.any(loop_gain < 0) or np.any(direct < 0):
        raise DesignError("small_gain: the gains and the direct terms must be nonnegative")
    radius = float(np.abs(np.linalg.eigvals(loop_gain)).max()) if k else 0.0
    if radius >= SMALL_GAIN_LIMIT:
        return None
    system = np.eye(k) - loop_gain
    if np.linalg.cond(system) * np.finfo(float).eps > SOLVE_RTOL:
        return None
    sol = np.linalg.solve(system, direct)
    if not np.all(np.isfinite(sol)):
        return None
    # the exact solution is nonnegative and the computed one is within cond * eps of it (relative):
    # inflating by SOLVE_RTOL covers it; the inequality's right-hand side is checked at the result
    sol = np.maximum(sol, 0.0) * (1.0 + SOLVE_RTOL)
    short = direct + loop_gain @ sol - sol
    if np.any(short > sol * 1e-12):
        # round-off left the solution short somewhere (a tiny component clipped at 0, or terms far apart in
        # size): add a multiple of v = (I - loop_gain)^-1 1 >= 1, whose image under I - loop_gain is 1
        lift = np.linalg.solve(system, np.ones(k))
        if not np.all(np.isfinite(lift)):
            return None
        sol = sol + 2.0 * float(short.max()) * np.maximum(lift, 1.0)
    # any z >= 0 with z >= direct + loop_gain z is above the least solution (iterate the inequality)
    if np.any(direct + loop_gain @ sol > sol * (1.0 + 1e-12)):
        return None
    out: FloatArray = sol
    return out


#: Relative inflation of the small-gain solution for the linear solve's round-off (the system's
#: condition number times machine epsilon must stay below it).
SOLVE_RTOL = 1e-9


#: The small-gain matrix's spectral radius must stay below this (1 less a margin far above round-off).
SMALL_GAIN_LIMIT = 1.0 - 1e-6


__all__ = [
    "FINE_STEPS",
    "MAX_PERIODS",
    "MIN_PERIODS",
    "SMALL_GAIN_LIMIT",
    "SUM_ROUNDOFF",
    "TAIL_RTOL",
    "PeakGains",
    "SampledLoop",
    "StepBounds",
    "free_peaks",
    "in_flight",
    "peak_gains",
    "period_radius",
    "small_gain",
    "step_bounds",
]
