"""The composed certificate: one vehicle's deployed loop, on every plant of the box, in the current.

:func:`certify_deployed` proves, for the law with the given gains run as declared (sampled,
held, delayed, on noisy measurements), on every plant of the ``[uncertainty]`` box, in every
current up to its bound, along the whole mission:

* bounds of the position, velocity, heading and yaw-rate errors from the configured start;
* a bound of the commanded forces (N, N, N m), which the caller holds against the thrusters;
* that the body velocities and yaw rates stay in an operating box, which it reports and holds
  against the declared envelope.

**The argument.** For an assumed operating box every loop (the surge and sway axes and the
heading, :mod:`auv_hinf.composed.loops`) is its nominal sampled-data loop (the middle of the
plant's ranges, with the declared sample time and delay) plus bounded perturbations: the
plant's deviation from the nominal, the other loops' coupling, the disturbances and the
measurement errors. The nominal loops' peak-to-peak gains are computed rigorously
(:func:`~auv_hinf.implementation.peak.peak_gains`); every perturbation is at most a constant
times the peak of an output of some loop, so the vector of peaks satisfies ``s <= c + M s`` with
nonnegative ``c`` and ``M``, and when ``M``'s spectral radius is below 1 the small-gain theorem in
the peak norm gives ``s <= (I - M)^-1 c`` (:func:`~auv_hinf.implementation.peak.small_gain`).

The disturbance bounds and the perturbations' gains depend on the operating box, which
depends on the error bounds: the bounds are accepted when, computed for an operating box, they
lie inside it (widened by :data:`FIXED_POINT_RTOL`, every dependence is monotone). Then no
trajectory can be the first to leave them (the first-exit argument of
``docs/derivations/closed_loop.md``): until it would, every assumption holds, and the bounds it
would have to cross are strictly larger than what the argument proves. If the bounds outgrow the
box, the box is enlarged and the nominal loops recomputed (:data:`ROUNDS` times).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.composed.loops import (
    AXIS_OUTPUTS,
    HEADING_OUTPUTS,
    MAX_SLIP,
    AxisRanges,
    Disturbances,
    Errors,
    MissionBounds,
    OperatingBox,
    Plant,
    disturbances,
    nominal_loops,
    turn_bounds,
)
from auv_hinf.exceptions import DesignError
from auv_hinf.implementation.model import Implementation
from auv_hinf.implementation.peak import (
    PeakGains,
    SampledLoop,
    StepBounds,
    free_peaks,
    in_flight,
    peak_gains,
    small_gain,
    step_bounds,
)
from auv_hinf.law.gains import Gains
from auv_hinf.models.envelope import Envelope
from auv_hinf.numerics.integrators import FORCE_FLOOR

#: Relative widening of the accepted bounds before the final self-consistency step.
FIXED_POINT_RTOL = 1e-6
#: Iterations of the fixed point within one operating box before it is declared divergent.
FIXED_POINT_ITERATIONS = 200
#: Rounds of (operating box -> nominal loops -> fixed point) before giving up: of 270 BlueROV2
#: problems (noise, box and current scales, 18 gains), every one that covered did so within 6
#: rounds, while failing ones ran to the limit.
ROUNDS = 6
#: Relative room the operating box of a round leaves above the bounds it expects.
BOX_ROOM = 0.15
#: Most measurements in flight (``delay / sample_time``) the sampled loops are analysed with. Each
#: is a state of the loops' period map, and the peak gains' cost grows about as the cube of the
#: state count times the periods summed (which grow as ``1 / sample_time``): on the
#: ``bluerov2-deployed`` fleet 11 in flight (100 Hz, 0.1 s) take 12 s and 21 (200 Hz) 80 s on a
#: loaded 2-core machine. Beyond this the certificate is not evaluated, and says so.
MAX_DELAY_SAMPLES = 24


@dataclass(frozen=True)
class DeployedProblem:
    """Everything one vehicle's composed certificate depends on.

    Attributes
    ----------
    plant : Plant
        The controller's model, the box and the current.
    mission : MissionBounds
        Bounds of the desired motion (every vehicle's slot path).
    envelope : Envelope
        The declared envelope the operating box must stay in.
    implementation : Implementation
        Sample time, delay and noise bounds.
    gains : Gains
        The law's gains.
    start : Errors
        Bounds of every vehicle's errors at ``t = 0`` in still water (the deficit component is
        ignored); the current adds up to its bound to the ground-velocity error
        (:attr:`initial`).
    """

    plant: Plant
    mission: MissionBounds
    envelope: Envelope
    implementation: Implementation
    gains: Gains
    start: Errors

    def __post_init__(self) -> None:
        if not self.implementation.sampled:
            raise DesignError(
                "the composed certificate is about a sampled law: declare [implementation] sample_time > 0 "
                "(the continuous law has the closed-loop and robust certificates)"
            )

    @property
    def initial(self) -> Errors:
        """The start's errors in the current: a vehicle's ground velocity is its water-relative one plus the current."""
        s = self.start
        return Errors(s.position, s.velocity + self.plant.current, s.heading, s.yaw_rate)

    @property
    def integral(self) -> bool:
        """The law has integral action."""
        return self.gains.ki > 0.0

    @property
    def timing(self) -> tuple[float, float]:
        """``(h, d)``: the declared sample time and delay (s)."""
        return self.implementation.sample_time, self.implementation.delay


@dataclass(frozen=True)
class ForceBound:
    """Bounds of the commanded forces (N, N, N m).

    Attributes
    ----------
    force_x, force_y, moment : float
        ``|tau_x|, |tau_y|`` (N) and ``|tau_psi|`` (N m).
    feedback : tuple of float
        The law's feedback accelerations ``|F|`` on the surge and sway axes (m/s^2) and on the
        heading (rad/s^2).
    feed_forward : tuple of float
        The model terms of ``force_x, force_y, moment`` (drag, Coriolis, Munk; N, N, N m).
    """

    force_x: float
    force_y: float
    moment: float
    feedback: tuple[float, float, float]
    feed_forward: tuple[float, float, float]

    def as_tuple(self) -> tuple[float, float, float]:
        """``(force_x, force_y, moment)``."""
        return (self.force_x, self.force_y, self.moment)

    def to_dict(self) -> dict[str, float]:
        """``{force_x, force_y, moment}`` (N, N, N m)."""
        return {"force_x": self.force_x, "force_y": self.force_y, "moment": self.moment}


@dataclass(frozen=True)
class Round:
    """The nominal loops of one operating box and their peak gains.

    Attributes
    ----------
    op : OperatingBox
        The operating box the perturbation bounds hold in.
    axes : tuple of AxisRanges
        The surge, sway and heading ranges.
    cells : tuple of tuple of SampledLoop
        Per loop (surge, sway, heading), every cell's nominal loop (:attr:`loops` are the first ones).
    gains : tuple of PeakGains
        Their peak gains, the largest over each loop's cells.
    free : tuple of ndarray or None
        Their outputs' peaks per unit initial plant state (``None`` when the start has no error).
    """

    op: OperatingBox
    axes: tuple[AxisRanges, AxisRanges, AxisRanges]
    cells: tuple[tuple[SampledLoop, ...], tuple[SampledLoop, ...], tuple[SampledLoop, ...]]
    gains: tuple[PeakGains, PeakGains, PeakGains]
    free: tuple[FloatArray, FloatArray, FloatArray] | None
    _steps: dict[int, StepBounds] = field(default_factory=dict, compare=False, repr=False)

    @property
    def loops(self) -> tuple[SampledLoop, SampledLoop, SampledLoop]:
        """The nominal surge, sway and heading loops (each loop's first cell)."""
        return (self.cells[0][0], self.cells[1][0], self.cells[2][0])

    def steps(self, loop: int) -> StepBounds:
        """Loop ``loop``'s step responses' peaks and areas, the largest over its cells.

        The slowly varying deficit's channel, computed when a deficit first asks for it (:func:`_step_bounds`)
        and kept for the fixed point's later iterations.

        Parameters
        ----------
        loop : int
            0 (surge), 1 (sway) or 2 (heading).
        """
        if loop not in self._steps:
            bounds = [_step_bounds(c) for c in self.cells[loop]]
            self._steps[loop] = StepBounds(
                peak=np.max(np.stack([b.peak for b in bounds]), axis=0),
                area=np.max(np.stack([b.area for b in bounds]), axis=0),
            )
        return self._steps[loop]


@dataclass(frozen=True)
class Peaks:
    """The peaks the small-gain argument proves, by loop and output.

    Attributes
    ----------
    axes : ndarray, shape (2, k)
        Per position axis (surge, sway), the peaks of :data:`~auv_hinf.composed.loops.AXIS_OUTPUTS`
        (and ``z`` with integral action).
    heading : ndarray, shape (6,)
        The peaks of :data:`~auv_hinf.composed.loops.HEADING_OUTPUTS`.
    """

    axes: FloatArray
    heading: FloatArray

    def get(self, axis: int, name: str) -> float:
        """The peak of output ``name`` of position axis ``axis``.

        Parameters
        ----------
        axis : int
            0 (surge) or 1 (sway).
        name : str
            One of :data:`~auv_hinf.composed.loops.AXIS_OUTPUTS` (or ``"z"``).
        """
        names = (*AXIS_OUTPUTS, "z")
        return float(self.axes[axis, names.index(name)])

    def head(self, name: str) -> float:
        """The peak of heading output ``name`` (:data:`~auv_hinf.composed.loops.HEADING_OUTPUTS`).

        Parameters
        ----------
        name : str
            The output's name.
        """
        return float(self.heading[HEADING_OUTPUTS.index(name)])

    def errors(self) -> Errors:
        """The error bounds these peaks prove (m, m/s, rad, rad/s)."""
        e = (self.get(0, "e"), self.get(1, "e"))
        v = (self.get(0, "v"), self.get(1, "v"))
        return Errors(
            position=math.hypot(*e),
            velocity=math.hypot(*v),
            heading=self.head("e"),
            yaw_rate=self.head("v"),
            surge=v[0],
            sway=v[1],
        )


@dataclass(frozen=True)
class DeployedCertificate:
    """What :func:`certify_deployed` proves (bounds ``None`` when it does not cover).

    Attributes
    ----------
    covers : bool
        The bounds are a verified fixed point and the operating box is inside the envelope
        (the thrusters are the caller's: :attr:`force`).
    governed_by : str or None
        What decides when it does not cover: ``"stability"`` (a nominal loop is unstable, or the
        small gain fails, at the start's errors), ``"envelope"`` (the bounds outgrow the envelope
        or do not settle) or ``None``.
    reasons : tuple of str
        Why not (empty when it covers).
    errors : Errors or None
        Bounds of the errors over the whole run (m, m/s, rad, rad/s).
    force : ForceBound or None
    op : OperatingBox or None
        The operating box the certificate holds in (the envelope it needs).
    disturbance : Disturbances or None
        The disturbance bounds at the fixed point.
    peaks : Peaks or None
        Every loop output's peak.
    round : Round or None
        The nominal loops of the accepted operating box.
    small_gain : float or None
        Spectral radius of the accepted small-gain matrix (< 1).
    binding : tuple of (str, float)
        When the small gain fails: the couplings that close the loop and their shares of the
        couplings' total (:func:`binding`), largest first; when the bounds grow instead, the
        couplings that carry the small-gain radius at the start's errors; empty when it covers.
    """

    covers: bool
    governed_by: str | None
    reasons: tuple[str, ...]
    errors: Errors | None = None
    force: ForceBound | None = None
    op: OperatingBox | None = None
    disturbance: Disturbances | None = None
    peaks: Peaks | None = None
    round: Round | None = field(default=None, compare=False)
    small_gain: float | None = None
    binding: tuple[tuple[str, float], ...] = ()


# ----------------------------------------------------------------------------------------------
# the nominal loops of an operating box


def make_round(problem: DeployedProblem, op: OperatingBox) -> Round | str:
    """The nominal loops of ``op`` and their peak gains, or the name of the loop that is unstable.

    A loop whose damping has cells (:class:`~auv_hinf.composed.loops.AxisRanges`) gets one nominal
    loop per cell; its gains are the entrywise largest over the cells, which dominate the small-gain
    system of whichever cell the plant is in.

    Parameters
    ----------
    problem : DeployedProblem
        The problem.
    op : OperatingBox
        The operating box.
    """
    h, d = problem.timing
    axes = nominal_loops(problem.plant, op, problem.mission, problem.implementation.noise.heading, problem.gains, h, d)
    gains, free = [], []
    start = problem.initial
    has_start = any(x > 0 for x in (start.position, start.velocity, start.heading, start.yaw_rate))
    for name, _, cell_loops in axes:
        analysed = [_analyse(loop, has_start) for loop in cell_loops]
        if any(a is None for a in analysed):
            return name
        done = [a for a in analysed if a is not None]
        gains.append(_dominant([a[0] for a in done]))
        if has_start:
            if any(a[1] is None for a in done):
                return "start"
            free.append(np.max(np.stack([a[1] for a in done if a[1] is not None]), axis=0))
    return Round(
        op,
        (axes[0][1], axes[1][1], axes[2][1]),
        (tuple(axes[0][2]), tuple(axes[1][2]), tuple(axes[2][2])),
        (gains[0], gains[1], gains[2]),
        (free[0], free[1], free[2]) if has_start else None,
    )


#: Nominal loops analysed so far, by their defining numbers (a fixed point, an advice search and a
#: gain search meet the same loops many times).
_ANALYSED: dict[tuple[Any, ...], tuple[PeakGains, FloatArray | None] | None] = {}
#: Their step bounds, computed only for the loops a deficit drives (a box, a current or a mission
#: whose feed-forward lags: without one the step responses are never read).
_STEPS: dict[tuple[Any, ...], StepBounds] = {}
#: Most analyses kept.
ANALYSIS_CACHE = 4096


def _loop_key(loop: SampledLoop, with_free: bool) -> tuple[Any, ...]:
    arrays = (
        loop.a,
        loop.b_u,
        loop.b_w,
        loop.c_y,
        loop.d_n,
        loop.b_cn,
        loop.a_c,
        loop.b_c,
        loop.c_c,
        loop.d_c,
        loop.outputs,
    )
    return (*(a.tobytes() for a in arrays), *(a.shape for a in arrays), loop.sample_time, loop.delay, with_free)


def _analyse(loop: SampledLoop, with_free: bool) -> tuple[PeakGains, FloatArray | None] | None:
    """The loop's peak gains and (``with_free``) free-response peaks; ``None`` when unstable."""
    key = _loop_key(loop, with_free)
    if key in _ANALYSED:
        return _ANALYSED[key]
    gains = peak_gains(loop)
    result = None if gains is None else (gains, free_peaks(loop) if with_free else None)
    if len(_ANALYSED) >= ANALYSIS_CACHE:
        _ANALYSED.clear()
    _ANALYSED[key] = result
    return result


def _step_bounds(loop: SampledLoop) -> StepBounds:
    """The step bounds of the loop's deficit input (input 0, the only slowly varying one), remembered."""
    key = _loop_key(loop, False)
    if key not in _STEPS:
        steps = step_bounds(loop, inputs=1)
        if steps is None:  # a loop is analysed (peak_gains, the same contraction) before it is asked
            raise DesignError("the step bounds of a stable nominal loop could not be computed")
        if len(_STEPS) >= ANALYSIS_CACHE:
            _STEPS.clear()
        _STEPS[key] = steps
    return _STEPS[key]


def _dominant(gains: list[PeakGains]) -> PeakGains:
    """The entrywise largest of several loops' peak gains (same layout)."""
    return PeakGains(
        continuous=np.max(np.stack([g.continuous for g in gains]), axis=0),
        discrete=np.max(np.stack([g.discrete for g in gains]), axis=0),
        radius=max(g.radius for g in gains),
        step=max(g.step for g in gains),
        derivative=np.max(np.stack([g.derivative for g in gains]), axis=0),
        one_signed=np.max(np.stack([g.one_signed for g in gains]), axis=0),
    )


# ----------------------------------------------------------------------------------------------
# the small-gain system of one operating box


class _Index:
    """Positions of the named peaks in the small-gain vector."""

    def __init__(self, axis_outputs: tuple[str, ...]) -> None:
        self.names: list[str] = []
        for j in range(2):
            self.names += [f"{j}:{o}" for o in axis_outputs]
            self.names += [f"{j}:q", f"{j}:qc", f"{j}:q_e", f"{j}:p_z", f"{j}:n_e", f"{j}:n_v"]
        self.names += [f"h:{o}" for o in HEADING_OUTPUTS] + ["h:q", "h:qc", "h:n_e", "h:n_v"]
        self.at = {n: k for k, n in enumerate(self.names)}

    def __call__(self, name: str) -> int:
        return self.at[name]

    @property
    def size(self) -> int:
        return len(self.names)


def _system(problem: DeployedProblem, rnd: Round, dist: Disturbances) -> tuple[FloatArray, FloatArray, _Index]:
    """``(c, M, index)`` of ``s <= c + M s`` for the round's loops and the disturbances ``dist``."""
    impl, plant, mission = problem.implementation, problem.plant, problem.mission
    n = impl.noise
    h, d = problem.timing
    integral = problem.integral
    outs = (*AXIS_OUTPUTS, "z") if integral else AXIS_OUTPUTS
    ix = _Index(outs)
    c = np.zeros(ix.size)
    m = np.zeros((ix.size, ix.size))
    op = rnd.op
    r = op.r
    coriolis = plant.coriolis() * r
    s_hi = mission.speed[1]
    start = problem.initial
    # --- position axes
    for j in range(2):
        g = rnd.gains[j]
        other = 1 - j
        a0 = max(max(abs(lo), abs(hi)) for lo, hi in rnd.axes[j].parts)
        da, dc, dl = rnd.axes[j].deviations
        w_c = dist.deficit_axes[j]
        w_axis = w_c + dist.residual
        st = rnd.steps(j) if w_c > 0.0 else None  # no deficit: its channel adds nothing
        # outputs: gains from w, q, q_e (continuous) and n_e, n_v, p_z (discrete)
        for k, o in enumerate(outs):
            row = ix(f"{j}:{o}")
            # the deficit is slowly varying: an output that settles sees its step response
            deficit = 0.0 if st is None else min(g.continuous[k, 0] * w_c, st.bound(k, 0, w_c, dist.deficit_rate))
            c[row] += deficit + g.continuous[k, 0] * dist.residual
            m[row, ix(f"{j}:q")] += g.continuous[k, 1]
            m[row, ix(f"{j}:qc")] += g.one_signed[k, 1]  # the drag's curvature keeps one sign
            m[row, ix(f"{j}:q_e")] += g.continuous[k, 2]
            m[row, ix(f"{j}:n_e")] += g.discrete[k, 0]
            m[row, ix(f"{j}:n_v")] += g.discrete[k, 1]
            m[row, ix(f"{j}:p_z")] += g.discrete[k, 2]
            if rnd.free is not None:  # the start's free response (epsilon, eta components <= the norms)
                c[row] += rnd.free[j][k, 0] * start.position + rnd.free[j][k, 1] * start.velocity
            # between the fine steps the plant-state outputs move by at most step * |derivative|
            der = g.derivative[k]  # on (|epsilon|, |eta|, |u|, |w|, |q|, |q_e|)
            if der.any():
                step = g.step
                for src, coef in zip(("e", "v", "u"), der[:3], strict=True):
                    m[row, ix(f"{j}:{src}")] += step * coef
                c[row] += step * der[3] * w_axis
                m[row, ix(f"{j}:q")] += step * der[4]
                m[row, ix(f"{j}:qc")] += step * der[4]
                m[row, ix(f"{j}:q_e")] += step * der[5]
        # perturbations into eta': the plant's deviation, the other axis's turn and Coriolis
        # terms, the heading's change since measured turning the drift compensation
        q = ix(f"{j}:q")
        c[q] += rnd.axes[j].residual or 0.0  # the drag's residual about the nominal slope (da is 0 then)
        m[q, ix(f"{j}:v")] += da
        m[ix(f"{j}:qc"), ix(f"{j}:v")] += rnd.axes[j].curvature
        m[q, ix(f"{j}:v_m")] += dc
        m[q, ix(f"{j}:F")] += dl
        m[q, ix(f"{other}:v")] += r + coriolis
        m[q, ix("h:dpsi")] += dist.misrotation[j]
        # the position error lives in the desired heading's frame: it turns with r_d, and its
        # rate is the body velocity error turned by the heading error (|R(E) - I| per axis)
        own, cross = turn_bounds(op.heading)
        m[ix(f"{j}:q_e"), ix(f"{other}:e")] += mission.yaw_rate
        m[ix(f"{j}:q_e"), ix(f"{j}:v")] += own
        m[ix(f"{j}:q_e"), ix(f"{other}:v")] += cross
        if integral:  # the integrator turns with the body frame: |z_b| changes by r h |z| per sample
            m[ix(f"{j}:p_z"), ix("0:z")] += r * h
            m[ix(f"{j}:p_z"), ix("1:z")] += r * h
        # measurement errors: the noise, and the turn of the measured position error
        ne, nv = ix(f"{j}:n_e"), ix(f"{j}:n_v")
        c[ne] += n.position
        # the law measures the position error in its body frame: the desired frame's turned by the
        # heading error and the heading noise
        own, cross = turn_bounds(op.heading + n.heading)
        m[ne, ix(f"{j}:e")] += own
        m[ne, ix(f"{other}:e")] += cross
        c[nv] += n.velocity + n.heading * (s_hi + plant.current)
        if impl.varying_delay:  # the measurement is up to d fresher than the nominal's
            m[ne, ix(f"{j}:v")] += d
            m[ne, ix(f"{j}:q_e")] += d
            m[nv, ix(f"{j}:v")] += d * abs(a0)
            m[nv, ix(f"{j}:u")] += d
            m[nv, q] += d
            m[nv, ix(f"{j}:qc")] += d
            c[nv] += d * w_axis
    # --- heading
    g = rnd.gains[2]
    a0 = max(max(abs(lo), abs(hi)) for lo, hi in rnd.axes[2].parts)
    da, dc, dl = rnd.axes[2].deviations
    for k, o in enumerate(HEADING_OUTPUTS):
        row = ix(f"h:{o}")
        c[row] += g.continuous[k, 0] * dist.heading
        m[row, ix("h:q")] += g.continuous[k, 1]
        m[row, ix("h:qc")] += g.one_signed[k, 1]
        m[row, ix("h:n_e")] += g.discrete[k, 0]
        m[row, ix("h:n_v")] += g.discrete[k, 1]
        if rnd.free is not None:
            c[row] += rnd.free[2][k, 0] * start.heading + rnd.free[2][k, 1] * start.yaw_rate
        der = g.derivative[k]  # on (|e_psi|, |e_r|, |u|, |w|, |q|)
        if der.any():
            step = g.step
            for src, coef in zip(("e", "v", "u"), der[:3], strict=True):
                m[row, ix(f"h:{src}")] += step * coef
            c[row] += step * der[3] * dist.heading
            m[row, ix("h:q")] += step * der[4]
            m[row, ix("h:qc")] += step * der[4]
    q = ix("h:q")
    c[q] += rnd.axes[2].residual or 0.0
    m[q, ix("h:v")] += da
    m[ix("h:qc"), ix("h:v")] += rnd.axes[2].curvature
    m[q, ix("h:v_m")] += dc
    m[q, ix("h:F")] += dl
    m[q, ix("0:dv")] += dist.munk[0]
    m[q, ix("1:dv")] += dist.munk[1]
    c[ix("h:n_e")] += n.heading
    c[ix("h:n_v")] += n.yaw_rate
    if impl.varying_delay:
        m[ix("h:n_e"), ix("h:v")] += d
        m[ix("h:n_v"), ix("h:v")] += d * abs(a0)
        m[ix("h:n_v"), ix("h:u")] += d
        m[ix("h:n_v"), q] += d
        m[ix("h:n_v"), ix("h:qc")] += d
        c[ix("h:n_v")] += d * dist.heading
    return c, m, ix


def _system_at(
    problem: DeployedProblem, rnd: Round, errors: Errors
) -> tuple[FloatArray, FloatArray, _Index, Disturbances]:
    """``(c, M, index, disturbances)`` of the small-gain system with the disturbances of ``errors``' operating box."""
    plant, mission = problem.plant, problem.mission
    op = OperatingBox.of(mission, plant.current, errors)
    dist = disturbances(plant, op, mission, problem.implementation, problem.gains, errors)
    c, m, ix = _system(problem, rnd, dist)
    return c, m, ix, dist


def _peaks(problem: DeployedProblem, rnd: Round, errors: Errors) -> tuple[Peaks, Disturbances, float] | None:
    """The peaks the small gain proves when the disturbances are those of ``errors``' operating box."""
    c, m, ix, dist = _system_at(problem, rnd, errors)
    sol = small_gain(c, m)
    if sol is None:
        return None
    radius = float(np.abs(np.linalg.eigvals(m)).max())
    outs = (*AXIS_OUTPUTS, "z") if problem.integral else AXIS_OUTPUTS
    axes = np.array([[sol[ix(f"{j}:{o}")] for o in outs] for j in range(2)])
    heading = np.array([sol[ix(f"h:{o}")] for o in HEADING_OUTPUTS])
    return Peaks(axes, heading), dist, radius


#: The couplings of the small-gain system, by the perturbation channel they drive (the row) and
#: the peak that drives it (the column's output), in words; ``{axis}`` and ``{other}`` are filled in.
_COUPLINGS = {
    ("q", "v"): "the {axis} drag's steady slope about the nominal loop's (the box's and the current's, if declared)",
    ("qc", "v"): "the {axis} drag's curvature (its quadratic part in the velocity error)",
    ("q", "v_m"): "the {axis} drag compensation on the measured velocity (its slope's spread)",
    ("q", "F"): "the {axis} mass ratio on the law's feedback (the box's m_hat/m)",
    ("q", "other:v"): "the body frame's turn and the Coriolis terms from the {other} velocity into the {axis} loop",
    ("q", "h:dpsi"): "the {axis} drift compensation turned by the heading's change over the lag",
    ("q_e", "other:e"): "the desired heading's turn of the {other} position error into the {axis} loop",
    ("q_e", "v"): "the heading error's turn of the {axis} velocity error into the {axis} position",
    ("q_e", "other:v"): "the heading error's turn of the {other} velocity error into the {axis} position",
    ("n_e", "e"): "the heading error's and noise's turn of the measured {axis} position error",
    ("p_z", "z"): "the integrator's turn with the body frame ({axis})",
    ("h:q", "h:v"): "the yaw drag's slope about the nominal loop's",
    ("h:qc", "h:v"): "the yaw drag's curvature (its quadratic part in the yaw-rate error)",
    ("h:q", "h:v_m"): "the yaw drag compensation on the measured yaw rate",
    ("h:q", "h:F"): "the yaw inertia ratio on the heading feedback",
    ("h:q", "dv"): "the Munk moment of the {axis} velocity's change over the lag",
}
#: Axis names of the position loops, by index.
_AXES = ("surge", "sway")


def _coupling(row: str, col: str) -> str | None:
    """The words of the coupling from the peak ``col`` into the perturbation channel ``row`` (``None``: a loop gain)."""
    r_axis, r_name = row.split(":")
    c_axis, c_name = col.split(":")
    if r_axis == "h":
        key = (f"h:{r_name}", f"h:{c_name}" if c_axis == "h" else c_name)
        j = None if c_axis == "h" else int(c_axis)
    else:
        j = int(r_axis)
        if c_axis == r_axis or r_name in ("n_e", "p_z"):
            key = (r_name, c_name)
        else:
            key = (r_name, f"h:{c_name}" if c_axis == "h" else f"other:{c_name}")
    text = _COUPLINGS.get(key)
    if text is None:
        return None
    axis = _AXES[j] if j is not None else "yaw"
    other = _AXES[1 - j] if j is not None else ""
    return text.format(axis=axis, other=other)


#: Couplings named in a small-gain refusal.
BINDING_COUPLINGS = 3


def binding(problem: DeployedProblem, rnd: Round, errors: Errors) -> tuple[tuple[str, float], ...]:
    """The couplings that close the small-gain loop at ``errors``, with their shares (fractions), largest first.

    The shares are the Perron sensitivities of the system's spectral radius: entry ``M_ij``'s
    share is ``y_i M_ij x_j / (rho y.x)`` with ``x``, ``y`` the right and left Perron vectors of
    the nonnegative ``M``; the shares of every entry sum to 1. Each perturbation channel's
    entries are named by the physical coupling (:data:`_COUPLINGS`), the loops' own gains not,
    and the named couplings' shares are given as fractions of their sum.

    Parameters
    ----------
    problem : DeployedProblem
        The problem.
    rnd : Round
        The round's loops.
    errors : Errors
        The errors the disturbances are taken at.
    """
    return _shares(problem, rnd, errors)[0]


def _shares(problem: DeployedProblem, rnd: Round, errors: Errors) -> tuple[tuple[tuple[str, float], ...], float]:
    """:func:`binding`'s couplings and the spectral radius they share (dimensionless), from one eigensolve."""
    _, m, ix, _ = _system_at(problem, rnd, errors)
    w, v = np.linalg.eig(m)
    k = int(np.argmax(np.abs(w)))
    rho = float(np.abs(w[k]))
    wl, u = np.linalg.eig(m.T)
    x, y = np.abs(v[:, k].real), np.abs(u[:, int(np.argmax(np.abs(wl)))].real)
    if rho <= 0.0 or float(y @ x) <= 0.0:
        return (), rho
    shares = m * np.outer(y, x) / (rho * float(y @ x))
    named: dict[str, float] = {}
    for i, j in zip(*np.nonzero(shares), strict=True):
        text = _coupling(ix.names[i], ix.names[j])
        if text is not None:
            named[text] = named.get(text, 0.0) + float(shares[i, j])
    total = sum(named.values())
    if total <= 0.0:
        return (), rho
    top = sorted(named.items(), key=lambda kv: -kv[1])[:BINDING_COUPLINGS]
    return tuple((t, f / total) for t, f in top if f >= 0.005 * total), rho


def _binding_words(binds: tuple[tuple[str, float], ...], what: str = "what closes the loop") -> str:
    """``binds`` as a clause of a refusal (empty when there is none), introduced by ``what``."""
    if not binds:
        return ""
    return f"{what}, by share of the couplings: " + "; ".join(f"{t} ({100.0 * f:.0f} %)" for t, f in binds)


def _inside(op: OperatingBox, room: OperatingBox) -> bool:
    """``op`` lies inside ``room`` (the box the loops were built for)."""
    return (
        op.u[0] >= room.u[0]
        and op.u[1] <= room.u[1]
        and op.v <= room.v
        and op.r <= room.r
        and op.slip <= room.slip
        and op.u_d[0] >= room.u_d[0]
        and op.u_d[1] <= room.u_d[1]
        and op.v_d <= room.v_d
    )


def _widen(errors: Errors, factor: float) -> Errors:
    return Errors.from_array(errors.as_array() * factor)


def _fixed_point(problem: DeployedProblem, rnd: Round) -> tuple[tuple[Peaks, Disturbances, float] | None, Errors, str]:
    """The least fixed point with the round's loops, verified inside its operating box."""
    plant, mission = problem.plant, problem.mission
    errors = problem.initial
    for _ in range(FIXED_POINT_ITERATIONS):
        got = _peaks(problem, rnd, errors)
        if got is None:
            return None, errors, "gain"
        new = got[0].errors()
        new = Errors.from_array(np.maximum(new.as_array(), errors.as_array()))
        if OperatingBox.of(mission, plant.current, new).slip >= MAX_SLIP:
            return None, new, "slip"
        if not _inside(OperatingBox.of(mission, plant.current, new), rnd.op):
            return None, new, "room"
        if np.all(new.as_array() <= errors.as_array() * (1.0 + 1e-12) + 1e-300):
            break
        errors = new
    else:
        return None, errors, "diverged"
    wide = _widen(errors, 1.0 + FIXED_POINT_RTOL)
    if not _inside(OperatingBox.of(mission, plant.current, wide), rnd.op):
        return None, wide, "room"
    got = _peaks(problem, rnd, wide)
    if got is None or not np.all(got[0].errors().as_array() <= wide.as_array()):
        return None, wide, "diverged"
    return got, wide, ""


#: Why a composed certificate fails after its first round, by the failure's name.
_GROWTH = {
    "diverged": "the error bounds do not settle: the disturbances grow faster than the loops reject them",
    "room": "the error bounds outgrow every operating box tried",
    "slip": "the angle between the heading and the desired ground velocity (the mission's heading offset plus the "
    "heading error bound) reaches a right angle",
    "gain": "the small-gain condition fails: the plant's spread and the couplings are too large for the gains",
    "surge": "the error bounds grow until the nominal surge loop is unstable",
    "sway": "the error bounds grow until the nominal sway loop is unstable",
    "heading": "the error bounds grow until the nominal heading loop is unstable",
    "start": "the start's free response is unbounded",
    "envelope": "the error bounds grow beyond the declared envelope",
}


def certify_deployed(problem: DeployedProblem) -> DeployedCertificate:
    """The composed certificate of ``problem`` (see the module docstring); remembered per problem.

    A design, its certificate, its advice and every run of a campaign ask for the same problems;
    the last :data:`CERTIFICATE_CACHE` answers are kept (the problem is a frozen value).

    Parameters
    ----------
    problem : DeployedProblem
        Model, box, current, mission, envelope, implementation, gains and start.
    """
    return _certified(problem)


#: Composed certificates remembered by :func:`certify_deployed`.
CERTIFICATE_CACHE = 256


@functools.lru_cache(maxsize=CERTIFICATE_CACHE)
def _certified(problem: DeployedProblem) -> DeployedCertificate:
    plant, mission = problem.plant, problem.mission
    h, d = problem.timing
    if in_flight(h, d) > MAX_DELAY_SAMPLES:
        return DeployedCertificate(
            False,
            "stability",
            (
                f"not evaluated: the delay is {in_flight(h, d)} sample times ({d:.4g} s at {h:.4g} s), and the "
                f"composed certificate analyses at most {MAX_DELAY_SAMPLES} measurements in flight (each is a state "
                f"of the sampled loops; the cost grows about as the cube of their number); declare [implementation] "
                f"sample_time >= {d / MAX_DELAY_SAMPLES:.4g} s or delay <= {MAX_DELAY_SAMPLES * h:.4g} s",
            ),
        )
    errors = problem.initial
    why = ""
    binds: tuple[tuple[str, float], ...] = ()
    first: Round | None = None
    for attempt in range(ROUNDS):
        op = OperatingBox.of(mission, plant.current, _widen(errors, 1.0 + BOX_ROOM))
        if op.slip >= MAX_SLIP:
            why = "slip"
            break
        rnd = make_round(problem, op)
        if isinstance(rnd, str):
            if attempt == 0:
                lag = "continuous law" if not problem.implementation.sampled else f"sample time {h:.4g} s"
                return DeployedCertificate(
                    False,
                    "stability",
                    (f"the nominal {rnd} loop is unstable ({lag}, delay {d:.4g} s)",),
                )
            why = rnd
            break
        first = first or rnd
        got, reached, why = _fixed_point(problem, rnd)
        if got is not None:
            return _accepted(problem, rnd, got, reached)
        if why == "gain":
            binds = binding(problem, rnd, reached)
            if attempt == 0:
                return DeployedCertificate(
                    False,
                    "stability",
                    (
                        "the small-gain condition fails even at the start's errors: the plant's spread around the "
                        "nominal loops and the couplings are too large for these gains"
                        + (f" ({_binding_words(binds)})" if binds else ""),
                    ),
                    binding=binds,
                )
        errors = Errors.from_array(np.maximum(reached.as_array(), errors.as_array()))  # reported as "last"
        if why in ("diverged", "slip", "gain"):
            break
        if not OperatingBox.of(mission, plant.current, errors).within(problem.envelope):
            # every later round starts from these errors and only adds to them (the system is
            # monotone in the operating box), so its bounds would leave the envelope too
            why = "envelope"
            break
    amplified = ""
    if why != "gain" and first is not None:  # the bounds grew: what amplifies them, at the start's errors
        binds, radius = _shares(problem, first, problem.initial)
        if binds:
            amplified = (
                f"; the small-gain radius is {radius:.3g} at the start's errors (1 refuses) and grows with the "
                f"bounds; {_binding_words(binds, 'what carries it')}"
            )
    return DeployedCertificate(
        False,
        "envelope",
        (
            f"{_GROWTH[why]} (last |e| <= {errors.position:.3g} m, |e'| <= {errors.velocity:.3g} m/s, "
            f"|e_psi| <= {errors.heading:.3g} rad"
            + (f"; the mission's heading offset is {mission.offset:.3g} rad)" if why == "slip" else ")")
            + (f"; {_binding_words(binds)}" if why == "gain" and binds else amplified),
        ),
        binding=binds,
    )


def force_bound(problem: DeployedProblem, op: OperatingBox, peaks: Peaks) -> ForceBound:
    """Bound of the commanded forces (N, N, N m) from the loops' feedback peaks and the operating box.

    ``tau_xy = M_hat [R_y^T p_d'' - F - B_hat_y R_y^T p_d']`` and ``tau_psi = m33_hat (r_d' + d33_hat
    r_d / m33_hat - F_psi) + (m22_hat - m11_hat) u_y v_y``: the feedback ``F`` is each loop's
    output, every other term is bounded on the operating box at the measured state. A channel below
    :data:`~auv_hinf.numerics.integrators.FORCE_FLOOR` is reported at it.

    Parameters
    ----------
    problem : DeployedProblem
        The problem.
    op : OperatingBox
        The operating box.
    peaks : Peaks
        The loops' peaks.
    """
    mdl = problem.plant.model
    n = problem.implementation.noise
    mission = problem.mission
    s_hi = mission.speed[1]
    slip_y = min(op.slip + n.heading, MAX_SLIP)
    u_y = max(abs(op.u[0]), abs(op.u[1])) + n.velocity
    v_y = op.v + n.velocity
    r_y = op.r + n.yaw_rate
    dm_hat = abs(mdl.m22 - mdl.m11)
    ff_x = (mdl.d11_lin + mdl.d11_quad * u_y) * s_hi + dm_hat * r_y * s_hi * math.sin(slip_y)
    ff_y = (mdl.d22_lin + mdl.d22_quad * v_y) * s_hi * math.sin(slip_y) + dm_hat * r_y * s_hi
    ff_psi = (mdl.d33_lin + mdl.d33_quad * r_y) * mission.yaw_rate + dm_hat * u_y * v_y
    fb = (peaks.get(0, "F"), peaks.get(1, "F"), peaks.head("F"))
    return ForceBound(
        force_x=max(FORCE_FLOOR, mdl.m11 * (mission.accel + fb[0]) + ff_x),
        force_y=max(FORCE_FLOOR, mdl.m22 * (mission.accel + fb[1]) + ff_y),
        moment=max(FORCE_FLOOR, mdl.m33 * (mission.yaw_accel + fb[2]) + ff_psi),
        feedback=fb,
        feed_forward=(ff_x, ff_y, ff_psi),
    )


def _accepted(
    problem: DeployedProblem, rnd: Round, got: tuple[Peaks, Disturbances, float], errors: Errors
) -> DeployedCertificate:
    peaks, dist, radius = got
    op = OperatingBox.of(problem.mission, problem.plant.current, errors)
    reasons: tuple[str, ...] = ()
    governed_by = None
    if not op.within(problem.envelope):
        worst = min(op.margins(problem.envelope).items(), key=lambda kv: kv[1])
        reasons = (
            f"the operating box leaves the declared envelope ({worst[0]} by {-worst[1]:.3g}): the certificate needs "
            f"u in [{op.u[0]:.3g}, {op.u[1]:.3g}] m/s, |v| <= {op.v:.3g} m/s, |r| <= {op.r:.3g} rad/s",
        )
        governed_by = "envelope"
    return DeployedCertificate(
        covers=not reasons,
        governed_by=governed_by,
        reasons=reasons,
        errors=errors,
        force=force_bound(problem, op, peaks),
        op=op,
        disturbance=dist,
        peaks=peaks,
        round=rnd,
        small_gain=radius,
    )


def summary(cert: DeployedCertificate) -> dict[str, Any]:
    """A JSON-safe digest of ``cert`` (for reports and tests).

    Parameters
    ----------
    cert : DeployedCertificate
        The certificate.
    """
    return {
        "covers": cert.covers,
        "governed_by": cert.governed_by,
        "reasons": list(cert.reasons),
        "error_bounds": None if cert.errors is None else cert.errors.to_dict(),
        "certified_peak": None if cert.force is None else cert.force.to_dict(),
        "operating_box": None if cert.op is None else cert.op.to_dict(),
        "small_gain": cert.small_gain,
        "binding": [{"coupling": t, "share": f} for t, f in cert.binding],
    }


__all__ = [
    "ANALYSIS_CACHE",
    "BOX_ROOM",
    "CERTIFICATE_CACHE",
    "FIXED_POINT_ITERATIONS",
    "FIXED_POINT_RTOL",
    "MAX_DELAY_SAMPLES",
    "ROUNDS",
    "DeployedCertificate",
    "DeployedProblem",
    "ForceBound",
    "Peaks",
    "Round",
    "certify_deployed",
    "force_bound",
    "make_round",
    "summary",
]
