"""The sampled-data simulation: the law at the sample instants, held forces, delay, noisy measurements.

The convention is :mod:`auv_hinf.implementation.model`'s. At ``t_k = k h`` the law
(:class:`~auv_hinf.law.formation_law.VehicleLaw`) is evaluated on the state measured at
``s_k = max(t_k - d_k, 0)`` plus the noise of sample ``k`` (:mod:`auv_hinf.implementation.draws`),
against the desired motion at ``s_k``; its forces (saturated, if actuators are declared) are
held on ``[t_k, t_{k+1})``. The measured ground velocity is ``R(psi~) (u~, v~) + current``
from the measured heading and body velocity. :func:`integrate_sampled` runs a batch of runs
(:class:`HeldBatch`: what the loop reads of a :class:`~auv_hinf.simulation.scenario.ScenarioBatch`);
the simulation engine post-processes its solution like a continuous one.

The plant stays continuous: between samples it is the vehicle under constant forces,
integrated by the product's Dormand-Prince 5(4)
(:func:`~auv_hinf.numerics.integrators.dopri5`) at its tolerances
(``rtol = atol = 1e-8``), restarted on every segment, and every segment ends exactly on a
sample instant, a measurement instant or an output time. All runs of a batch advance together
(one call per segment, each run with its own step control, in its own scaled time), so the
cost stays O(N) per step and vectorised over vehicles and runs. Envelope exits are located on
the integrator's interpolant, as in the continuous engine. A run whose speeds or yaw rates
exceed :data:`DIVERGED_RATE` (an unstable implementation) is stopped there and reported as
diverged.

``sample_time = 0`` with a delay or noise runs the law at a fine period
(:func:`control_period`): a tenth of the delay, between :data:`FINEST_PERIOD` (1 ms) and
:data:`FINE_PERIOD` (10 ms), and at least :data:`MIN_SAMPLES` samples per run. The hold adds at
most that period to the delay (10 % of a delay of 10 ms or more).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError
from auv_hinf.implementation.draws import ImplementationDraws
from auv_hinf.implementation.model import MIN_SAMPLE_TIME, Implementation
from auv_hinf.law.formation_law import MotionSource, VehicleLaw, saturate
from auv_hinf.mission.fleet import wrap_angle
from auv_hinf.models.envelope import Envelope, envelope_bound, envelope_event, envelope_margin
from auv_hinf.models.vehicle import PlantBatch, VehicleParams, ground_velocity, plant_derivative
from auv_hinf.numerics.integrators import ATOL, RTOL, BatchSolution, SampleSink, dopri5
from auv_hinf.numerics.progress import PROGRESS_DELAY

#: Speed or yaw rate (m/s, rad/s) past which a run has diverged: no AUV moves at 100 m/s, and
#: beyond it the quadratic damping makes the plant stiff (the run is stopped, not integrated on).
DIVERGED_RATE = 100.0


#: The one output time of every segment: its end, in scaled time.
_END = np.array([1.0])


#: Longest and shortest control period (s) of a continuous law (``sample_time = 0``) that runs
#: with a delay or noise: every segment costs a restart of the integrator and a law evaluation
#: (about 1 ms for a small fleet), so 1 ms over the paper's 300 s would cost minutes.
FINE_PERIOD, FINEST_PERIOD = 1e-2, MIN_SAMPLE_TIME


#: A continuous law's period is at most this fraction of the delay ...
FINE_FRACTION = 0.1


#: ... and gives at least this many samples per run (short runs get a finer period).
MIN_SAMPLES = 1000


#: Instants closer than this (s) are one instant: ``k h``, ``k h - d`` and the output grid
#: (``linspace``) differ by round-off only, and a 1e-17 s step would cost a whole substep.
SNAP = 1e-9


def control_period(implementation: Implementation, horizon: float) -> float:
    """Period (s) at which the law runs: ``sample_time``, or the fine period when it is 0 (module note).

    Parameters
    ----------
    implementation : Implementation
        Sample time and delay of the controller.
    horizon : float
        Length of the run (s); a continuous law gets at least :data:`MIN_SAMPLES` samples over it.
    """
    if implementation.sample_time > 0.0:
        return implementation.sample_time
    wanted = FINE_FRACTION * implementation.delay if implementation.delay > 0.0 else FINE_PERIOD
    return min(max(FINEST_PERIOD, min(FINE_PERIOD, wanted)), horizon / MIN_SAMPLES)


class HeldRun(Protocol):
    """What the sampled loop reads of one run (a :class:`~auv_hinf.simulation.scenario.Scenario`)."""

    @property
    def law(self) -> VehicleLaw:
        """The law and its controller model."""
        ...

    @property
    def envelope(self) -> Envelope | None:
        """Where a run counts as inside (its exits are located)."""
        ...

    @property
    def implementation(self) -> Implementation:
        """Sample time, delay and noise bounds."""
        ...

    @property
    def horizon(self) -> float:
        """End of the run (s)."""
        ...

    @property
    def times(self) -> FloatArray:
        """Output times (s)."""
        ...

    @property
    def seed(self) -> int:
        """Seed of the noise and delay draws."""
        ...

    @property
    def noise_pattern(self) -> str:
        """How the noise is drawn within its bounds (:mod:`auv_hinf.implementation.draws`)."""
        ...


class HeldBatch(Protocol):
    """What the sampled loop reads of a batch of runs (a :class:`~auv_hinf.simulation.scenario.ScenarioBatch`).

    The runs share their law, envelope, implementation, horizon and output times; their plants,
    starts, currents, seeds and noise patterns differ.
    """

    @property
    def scenarios(self) -> Sequence[HeldRun]:
        """The runs."""
        ...

    @property
    def initial(self) -> FloatArray:
        """Initial states, shape ``(S, N, 6)``."""
        ...

    @property
    def current(self) -> FloatArray:
        """Currents, shape ``(S, 2)`` (m/s, inertial)."""
        ...

    @property
    def plant(self) -> PlantBatch:
        """The runs' plants."""
        ...

    @property
    def source(self) -> MotionSource:
        """The desired motion of every run (batched)."""
        ...


@dataclass(frozen=True)
class SampleTrace:
    """What the controller did at every sample (for tests and plots).

    Attributes
    ----------
    times : ndarray, shape (K,)
        Sample instants ``t_k`` (s).
    measured_at : ndarray, shape (S, K)
        Measurement instants ``s_k`` (s).
    noise : ndarray, shape (S, K, N, 6)
        Measurement errors added to ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s).
    commanded, forces : ndarray, shape (S, K, N, 3)
        Law output before and after saturation, held on ``[t_k, t_{k+1})`` (N, N, N m).
    """

    times: FloatArray
    measured_at: FloatArray
    noise: FloatArray
    commanded: FloatArray
    forces: FloatArray


def _none() -> FloatArray:
    return np.zeros(0)


@dataclass(frozen=True)
class SampledSolution(BatchSolution):
    """A :class:`~auv_hinf.numerics.integrators.BatchSolution` of ``S`` runs, and what their controller did.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Output times (s).
    y : ndarray, shape (T, S, 6 N), or None
        States at the output times; None when the samples went to a sink.
    event_time : ndarray, shape (S,)
        Each run's first envelope exit (s, NaN if none) on the integrator's interpolant.
    n_steps : ndarray of int, shape (S,)
        Each run's accepted steps over all segments.
    n_rejected : ndarray of int, shape (S,)
        Zero (not counted).
    next_step : None
        Not used by the sampled loop.
    commanded : ndarray, shape (T, S, N, 3), or None
        The held command (before saturation) at the output times (N, N, N m).
    commanded_peak : ndarray, shape (S, 3)
        Largest ``|tau_x|, |tau_y|, |tau_psi|`` commanded at any sample (N, N, N m).
    saturated_fraction : ndarray, shape (S,)
        Fraction of the samples at which some vehicle's command saturates.
    diverged : ndarray, shape (S,)
        When each run was stopped as diverged (s, :data:`DIVERGED_RATE`); NaN if it was not.
    period : float
        Control period (s).
    trace : SampleTrace or None
    """

    commanded: FloatArray | None = None
    commanded_peak: FloatArray = field(default_factory=_none)
    saturated_fraction: FloatArray = field(default_factory=_none)
    diverged: FloatArray = field(default_factory=_none)
    period: float = 0.0
    trace: SampleTrace | None = None


class SampledLoop:
    """The state of one sampled integration (see :func:`integrate_sampled`)."""

    def __init__(self, batch: HeldBatch, sink: SampleSink | None, trace: bool) -> None:
        first = batch.scenarios[0]
        impl = first.implementation
        self.s, self.n = batch.initial.shape[:2]
        self.law, self.ref, self.env = first.law, batch.source, first.envelope
        self.plants = batch.plant
        self.plant_all = batch.plant.coefficients(1)
        self.rtol, self.atol = RTOL, ATOL
        self.current = batch.current[:, None, :]
        self.h = control_period(impl, first.horizon)
        self.k_count = max(1, math.ceil((first.horizon - SNAP) / self.h))
        self.grid = np.append(np.arange(self.k_count) * self.h, first.horizon)
        self.window = math.floor((impl.delay + SNAP) / self.h) + 1  # pending measurements
        patterns = [s.noise_pattern for s in batch.scenarios]
        self.draws = ImplementationDraws(impl, [s.seed for s in batch.scenarios], self.n, patterns)
        self.against = bool(self.draws.against_rows.any())
        self.y = np.array(batch.initial, dtype=float)
        self.now = np.zeros(self.s)
        self.forces: FloatArray = np.zeros((self.s, self.n, 3))
        self.buf = np.empty((self.window + 1, self.s, self.n, 6))  # measured states by sample index
        self.buf_at = np.zeros((self.window + 1, self.s))  # and their instants
        self.te = first.times
        self.out_interval = np.searchsorted(self.grid, self.te - SNAP, side="left") - 1
        self.out_hold = np.clip(np.searchsorted(self.grid[:-1], self.te + SNAP, side="right") - 1, 0, None)
        self.out = np.empty((self.te.size, self.s, 6 * self.n)) if sink is None else None
        self.cmd_out = np.empty((self.te.size, self.s, self.n, 3)) if sink is None else None
        self.sink = sink
        self.exit = np.full(self.s, np.nan)
        if self.env is not None:
            self.exit[envelope_margin(self.env, self.y).min(axis=-1) < 0] = 0.0
        self.diverged = np.full(self.s, np.nan)
        self.step = np.full(self.s, np.nan)  # each run's next integration step (s)
        self.steps = np.zeros(self.s, dtype=int)
        self.peak = np.zeros((self.s, 3))
        self.saturated = np.zeros(self.s, dtype=int)
        self.trace: list[tuple[FloatArray, ...]] | None = [] if trace else None

    def plant_of(self, rows: slice | NDArray[np.int_]) -> VehicleParams:
        """Plant coefficients of ``rows``, broadcasting against ``(rows, N)``.

        Parameters
        ----------
        rows : slice or ndarray of int
            The runs; a slice stands for all of them.
        """
        return self.plant_all if isinstance(rows, slice) else self.plants.coefficients(1, rows)

    def advance(self, target: FloatArray) -> None:
        """Integrate every live run from its current instant to ``target (S,)`` under the held forces.

        One :func:`~auv_hinf.numerics.integrators.dopri5` call over the runs that move: run
        ``s`` in the scaled time ``theta = (t - now_s) / L_s in [0, 1]``, so runs of different
        lengths share the call. The plant under held forces is autonomous, so ``dy/dtheta =
        L_s f(y)`` and every run keeps its own step control and error norm.

        Parameters
        ----------
        target : ndarray, shape (S,)
            Instant (s) each run is integrated to; runs already there, or diverged, stay.
        """
        length = np.where(np.isnan(self.diverged), target - self.now, 0.0)
        rows = np.flatnonzero(length > SNAP)
        self.now = np.where(np.isnan(self.diverged), np.maximum(self.now, target), self.now)
        if rows.size == 0:
            return
        every = rows.size == self.s
        sel: slice | NDArray[np.int_] = slice(None) if every else rows
        scale, forces, plant = length[sel][:, None, None], self.forces[sel], self.plant_of(sel)
        current = self.current[sel]

        def f(theta: FloatArray, y: FloatArray) -> FloatArray:
            s = y.reshape(-1, self.n, 6)
            d = plant_derivative(plant, current, s, forces, (np.cos(s[..., 2]), np.sin(s[..., 2])))
            return (scale * d).reshape(s.shape[0], -1)

        ev = envelope_event(self.env, self.n) if self.env is not None else None
        live_ev = ev if ev is not None and np.isnan(self.exit[sel]).any() else None
        last = self.step[sel]  # the previous segment's next step (s), in this one's scaled time
        sol = dopri5(
            f,
            (0.0, 1.0),
            self.y[sel].reshape(rows.size, -1),
            _END,
            rtol=self.rtol,
            atol=self.atol,
            event=live_ev,
            event_bound=None if live_ev is None or self.env is None else envelope_bound(self.env, self.n),
            first_step=np.minimum(last / length[sel], 1.0),  # NaN (a first segment): estimated
        )
        assert sol.next_step is not None
        self.step[sel] = sol.next_step * length[sel]
        assert sol.y is not None
        before = self.y[sel]
        self.y[sel] = sol.y[0].reshape(rows.size, self.n, 6)
        self.steps[sel] += sol.n_steps
        start = target[sel] - length[sel]
        hit = np.isnan(self.exit[sel]) & ~np.isnan(sol.event_time)
        exits = self.exit[sel]
        exits[hit] = start[hit] + sol.event_time[hit] * length[sel][hit]
        self.exit[sel] = exits
        moved = self.y[sel]
        wild = ~np.all(np.isfinite(moved), axis=(1, 2)) | (np.abs(moved[..., 3:6]).max(axis=(1, 2)) > DIVERGED_RATE)
        if wild.any():  # keep the last state within bounds, stop the run there
            self.diverged[rows[wild]] = target[rows[wild]]
            self.y[rows[wild]] = before[wild]

    def capture(self, rows: NDArray[np.int_], j: NDArray[np.int_], at: FloatArray) -> None:
        """Store the states of ``rows`` as the measurements of samples ``j`` taken at ``at`` (s).

        Parameters
        ----------
        rows : ndarray of int
            The runs.
        j : ndarray of int
            Sample index of each run's measurement.
        at : ndarray
            Measurement instant ``s_j`` of each (s).
        """
        slot = j % self.buf.shape[0]
        self.buf[slot, rows] = self.y[rows]
        self.buf_at[slot, rows] = at

    def output(self, rows: NDArray[np.int_], idx: NDArray[np.int_]) -> None:
        """Send the states of ``rows`` as output samples ``idx``.

        Parameters
        ----------
        rows : ndarray of int
            The runs.
        idx : ndarray of int
            Output-time index of each run's sample.
        """
        values = self.y[rows].reshape(rows.size, 6 * self.n)
        if self.sink is not None:
            self.sink(idx, rows, values)
        elif self.out is not None:
            self.out[idx, rows] = values

    def measurements(self, lo: int) -> tuple[NDArray[np.int_], FloatArray, NDArray[np.int_]]:
        """Samples ``j`` of the window from ``lo``, their instants ``s_j (S, J)`` and hold intervals.

        The hold interval of an instant is the index ``k`` of ``[t_k, t_{k+1})`` it falls in
        (-1 at ``t = 0``).

        Parameters
        ----------
        lo : int
            First sample of the window (non-decreasing between calls).
        """
        j = np.arange(lo, min(lo + self.window, self.k_count))
        at = np.maximum(self.grid[j] - self.draws.delays(lo, lo + j.size), 0.0)
        return j, at, np.searchsorted(self.grid, at - SNAP, side="left") - 1

    def start(self) -> None:
        """Outputs and measurements at ``t = 0``."""
        rows = np.arange(self.s)
        for o in np.flatnonzero(self.out_interval < 0):
            self.output(rows, np.full(self.s, o))
        j, _, interval = self.measurements(0)
        for c in range(j.size):
            hit = np.flatnonzero(interval[:, c] < 0)
            self.capture(hit, np.full(hit.size, j[c]), np.zeros(hit.size))

    def sample(self, k: int) -> None:
        """Evaluate the law of sample ``k`` and hold its forces.

        Parameters
        ----------
        k : int
            Sample index; its measurement must have been captured.
        """
        slot = k % self.buf.shape[0]
        noise = self.draws.noise(k)
        motion = self.ref.motion(self.buf_at[slot])
        if self.against:  # the errors that oppose what the law is about to measure
            noise = noise + self.draws.against(self.errors(self.buf[slot], motion))
        meas = self.buf[slot] + noise
        cs = (np.cos(meas[..., 2]), np.sin(meas[..., 2]))
        p_dot = ground_velocity(meas, self.current, cs)
        tau = self.law.unsaturated(meas, p_dot, motion, cs)
        self.forces, active = saturate(tau, self.law.actuators, meas[..., 3])
        self.peak = np.maximum(self.peak, np.abs(tau).max(axis=1))
        self.saturated += active.any(axis=1)
        if self.cmd_out is not None:
            self.cmd_out[self.out_hold == k] = tau
        if self.trace is not None:
            self.trace.append((self.buf_at[slot].copy(), noise, tau, self.forces))

    def errors(self, state: FloatArray, motion: Any) -> FloatArray:
        """The true errors ``[ex, ey, epsi, eu, ev, er]`` of ``state`` against ``motion`` (body-frame velocity error).

        Parameters
        ----------
        state : ndarray, shape (S, N, 6)
            The states at the measurement.
        motion : Any
            The desired motion at the measurement (``p``, ``v``, ``psi``, ``r``).
        """
        psi = state[..., 2]
        cs = (np.cos(psi), np.sin(psi))
        de = ground_velocity(state, self.current, cs) - motion.v
        c, s = cs
        return np.stack(
            [
                state[..., 0] - motion.p[..., 0],
                state[..., 1] - motion.p[..., 1],
                wrap_angle(psi - motion.psi),
                c * de[..., 0] + s * de[..., 1],
                -s * de[..., 0] + c * de[..., 1],
                state[..., 5] - motion.r,
            ],
            axis=-1,
        )

    def interval(self, k: int) -> None:
        """Sample ``k``, then integrate to ``t_{k+1}``, stopping on measurements and outputs.

        Parameters
        ----------
        k : int
            Sample index.
        """
        self.sample(k)
        end = self.grid[k + 1]
        j, at, interval = self.measurements(k + 1)
        member = interval == k
        outs = np.flatnonzero(self.out_interval == k)
        if member.any() or outs.size:
            cap_t = np.where(member, np.minimum(at, end), end)
            times = np.concatenate([cap_t, np.broadcast_to(np.minimum(self.te[outs], end), (self.s, outs.size))], 1)
            order = np.argsort(times, axis=1, kind="stable")
            rows = np.arange(self.s)
            for p in range(order.shape[1]):
                col = order[:, p]
                self.advance(times[rows, col])
                is_cap = col < j.size
                if j.size:
                    cap = np.flatnonzero(is_cap & member[rows, np.minimum(col, j.size - 1)])
                    self.capture(cap, j[col[cap]], at[cap, col[cap]])
                out = np.flatnonzero(~is_cap)
                if out.size:
                    self.output(out, outs[col[out] - j.size])
        self.advance(np.full(self.s, end))

    def solution(self) -> SampledSolution:
        """The result of the integration so far (call after the last :meth:`interval`)."""
        trace = None
        if self.trace is not None:
            at, noise, cmd, forces = (np.stack(x, axis=1) for x in zip(*self.trace))
            trace = SampleTrace(self.grid[:-1], at, noise, cmd, forces)
        return SampledSolution(
            t=self.te,
            y=self.out,
            commanded=self.cmd_out,
            event_time=self.exit,
            n_steps=self.steps,
            n_rejected=np.zeros(self.s, dtype=int),
            commanded_peak=self.peak,
            saturated_fraction=self.saturated / self.k_count,
            period=self.h,
            trace=trace,
            diverged=self.diverged,
        )


def integrate_sampled(batch: HeldBatch, *, sink: SampleSink | None = None, trace: bool = False) -> SampledSolution:
    """Integrate the scenarios of ``batch`` under their (shared) sampled implementation.

    Parameters
    ----------
    batch : HeldBatch
        Each scenario's ``seed`` gives its noise and delay draws.
    sink : callable, optional
        Receives the output samples instead of storing them
        (:data:`~auv_hinf.numerics.integrators.SampleSink`).
    trace : bool
        Also return what the controller did at every sample (:class:`SampleTrace`).

    Raises
    ------
    ParameterError
        If the implementation is the continuous, exact law (that runs in
        :mod:`auv_hinf.simulation.engine`).
    """
    impl = batch.scenarios[0].implementation
    if impl.continuous:
        raise ParameterError("the implementation is continuous and exact: simulate it with the continuous engine")
    loop = SampledLoop(batch, sink, trace)
    loop.start()
    # a bar for long runs on a terminal only (delayed; campaign workers and pipes get none)
    with tqdm(
        total=loop.k_count, desc="sampled run", unit="sample", delay=PROGRESS_DELAY, leave=False, disable=None
    ) as bar:
        for k in range(loop.k_count):
            loop.interval(k)
            bar.update(1)
    return loop.solution()


__all__ = [
    "DIVERGED_RATE",
    "FINE_FRACTION",
    "MIN_SAMPLES",
    "SNAP",
    "HeldBatch",
    "HeldRun",
    "SampleTrace",
    "SampledLoop",
    "SampledSolution",
    "control_period",
    "integrate_sampled",
]
