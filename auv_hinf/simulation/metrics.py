"""Per-run error metrics of a batch, accumulated sample by sample while it is integrated.

A campaign needs, per run and vehicle, only the sup of the four tracking errors, the sup of
the position error over the second half of the run, the final position error, the
measured decay rate of the certified Lyapunov norm and, given the law, the peak commanded
force per channel and the fraction of samples at which it saturates. :class:`ErrorSink` receives the
integrator's output samples (:data:`~auv_hinf.numerics.integrators.SampleSink`) and keeps these
running values, so a batch needs ``O(S N)`` memory instead of ``O(T S N)`` for stored
samples, and the post-processing is done while the samples are hot in the cache.

:func:`lyapunov_values` and :func:`decay_rates` are shared with
:func:`~auv_hinf.certificate.run_plan.measured_decay_rate`, which computes the same rate from stored samples.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import SolverError
from auv_hinf.law.formation_law import MotionSource, VehicleLaw, saturate
from auv_hinf.models.vehicle import ground_velocity
from auv_hinf.numerics.arrays import stack_last
from auv_hinf.numerics.quadratic_forms import pair_level
from auv_hinf.simulation.postprocess import TrackingErrors, tracking_errors

#: The measured decay rate is the average rate of the per-vehicle Lyapunov norm from
#: ``t = 0`` until it has fallen by this factor (six decades of error), far above the
#: integrator's noise (rtol 1e-8 of errors of order 1) and far enough to average out transients.
DECAY_MEASURE_DROP = 1e-6
#: Vehicles whose initial Lyapunov norm is below this (about 1e-6 m or m/s of error) have
#: nothing measurable to decay: their errors start at the integrator's noise level.
DECAY_MEASURE_FLOOR = 1e-6


def lyapunov_values(tr: TrackingErrors, p2: FloatArray, q: FloatArray) -> FloatArray:
    """``V = x^T (P2 kron I2) x + z^T Q z`` of every error sample, shape of ``tr.e_psi``.

    ``x = (e, e')`` (m, m/s) and ``z = (e_psi, e_psi')`` (rad, rad/s).

    Parameters
    ----------
    tr : TrackingErrors
        The error samples.
    p2 : ndarray, shape (2, 2)
        Decay matrix of the position loop (acting as ``P2 kron I2``).
    q : ndarray, shape (2, 2)
        Decay matrix of the heading loop.
    """
    v: FloatArray = pair_level(p2, tr.e, tr.e_dot, planar=True) + pair_level(q, tr.e_psi, tr.e_psi_dot)
    return v


def decay_rates(v0: FloatArray, vk: FloatArray, tk: FloatArray) -> FloatArray:
    """Slowest vehicle's rate ``ln(sqrt(V(0) / V(t_k))) / t_k`` (1/s) over the last axis.

    Vehicles with ``sqrt(V(0)) <=`` :data:`DECAY_MEASURE_FLOOR` or ``t_k <= 0`` are skipped;
    NaN where no vehicle is left.

    Parameters
    ----------
    v0 : ndarray, shape (..., N)
        Lyapunov value ``V(0)`` of each vehicle.
    vk : ndarray, shape (..., N)
        Its value at the measuring sample.
    tk : ndarray, shape (..., N)
        Time of the measuring sample (s).
    """
    ok = (np.sqrt(np.maximum(v0, 0.0)) > DECAY_MEASURE_FLOOR) & (tk > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = 0.5 * np.log(v0 / np.maximum(vk, 1e-300)) / tk
    low = np.where(ok, rate, np.inf).min(axis=-1)
    out: FloatArray = np.where(np.isinf(low), np.nan, low)
    return out


@dataclass(frozen=True)
class RunMetrics:
    """Metrics of ``S`` runs of ``N`` vehicles over their output samples.

    Attributes
    ----------
    max_errors : ndarray, shape (S, N, 4)
        Sup over the samples of ``||e||`` (m), ``||e'||`` (m/s), ``|e_psi|`` (rad) and
        ``|e_psi'|`` (rad/s) against the reference the law tracked (ground velocities).
    tail_position : ndarray, shape (S, N)
        Sup of ``||e||`` (m) over the samples from index ``T // 2`` on (the second half).
    final_position : ndarray, shape (S, N)
        ``||e||`` at the last sample (m).
    decay_rate : ndarray, shape (S,)
        Measured decay rate of the slowest vehicle (1/s, see
        :func:`~auv_hinf.certificate.run_plan.measured_decay_rate`); NaN where no vehicle starts off the reference.
    commanded_peak : ndarray, shape (S, 3)
        Sup over the samples and vehicles of the commanded ``|tau_x|`` (N), ``|tau_y|`` (N) and
        ``|tau_psi|`` (N m) before saturation (:meth:`~auv_hinf.law.formation_law.VehicleLaw.unsaturated`);
        NaN when the sink was given no law.
    saturated_fraction : ndarray, shape (S,)
        Fraction of the samples at which some vehicle's command saturates (0 without actuator
        limits; NaN when the sink was given no law).
    """

    max_errors: FloatArray
    tail_position: FloatArray
    final_position: FloatArray
    decay_rate: FloatArray
    commanded_peak: FloatArray
    saturated_fraction: FloatArray


class ErrorSink:
    """A :data:`~auv_hinf.numerics.integrators.SampleSink` that keeps :class:`RunMetrics` of a batch.

    Parameters
    ----------
    reference : MotionSource
        The reference every run tracks (shared by the batch).
    t_eval : ndarray, shape (T,)
        The integrator's output times (s).
    current : ndarray, shape (S, 2)
        Each run's water current (m/s, inertial).
    n : int
        Vehicles per run (the flat state of a run is ``6 n`` long).
    p2, q : ndarray, shape (2, 2)
        Decay matrices of the certified Lyapunov function.
    progress : callable, optional
        Called with the fraction of all samples received (0 to 1) each time it has grown by
        a percent or more (for a progress bar).
    law : VehicleLaw, optional
        The law every run uses: then the sink also keeps the peak commanded force of each run,
        evaluated at the sample states against ``reference`` (``O(S)`` more memory).
    """

    def __init__(
        self,
        reference: MotionSource,
        t_eval: FloatArray,
        current: FloatArray,
        n: int,
        p2: FloatArray,
        q: FloatArray,
        progress: Callable[[float], None] | None = None,
        law: VehicleLaw | None = None,
    ) -> None:
        s = current.shape[0]
        self._ref, self._t, self._current, self._n = reference, np.asarray(t_eval, dtype=float), current, n
        self._p2, self._q = p2, q
        self._max = np.zeros((s, n, 4))
        self._tail = np.zeros((s, n))
        self._final = np.full((s, n), np.nan)
        self._v0 = np.full((s, n), np.nan)
        self._vk = np.full((s, n), np.nan)  # V at the measuring sample, once found
        self._tk = np.full((s, n), np.nan)
        self._seen = np.zeros(s, dtype=int)
        self._law = law
        self._force = np.zeros((s, 3))
        self._saturated = np.zeros(s, dtype=int)
        self._progress, self._reported = progress, 0.0

    def __call__(self, idx: NDArray[np.int_], systems: NDArray[np.int_], values: FloatArray) -> None:
        """Fold samples ``idx`` of runs ``systems`` (flat states ``values (m, w N)``, ``w`` 6 or 8) in."""
        states = np.asfortranarray(values.reshape(-1, self._n, values.shape[-1] // self._n))  # run axis fastest
        motion = self._ref.motion(self._t[idx])
        cs = (np.cos(states[..., 2]), np.sin(states[..., 2]))
        p_dot = ground_velocity(states, self._current[systems, None, :], cs)
        tr = tracking_errors(states, p_dot, motion)
        if self._law is not None:
            tau = self._law.unsaturated(states, p_dot, motion, cs)  # (m, N, 3)
            self._force[systems] = np.maximum(self._force[systems], np.abs(tau).max(axis=1))
            self._saturated[systems] += saturate(tau, self._law.actuators, states[..., 3])[1].any(axis=1)
        pos = np.hypot(tr.e[..., 0], tr.e[..., 1])
        now = stack_last([pos, np.hypot(tr.e_dot[..., 0], tr.e_dot[..., 1]), np.abs(tr.e_psi), np.abs(tr.e_psi_dot)])
        self._max[systems] = np.maximum(self._max[systems], now)
        tail = idx >= self._t.size // 2
        self._tail[systems[tail]] = np.maximum(self._tail[systems[tail]], pos[tail])
        last = idx == self._t.size - 1
        self._final[systems[last]] = pos[last]
        v = lyapunov_values(tr, self._p2, self._q)
        start = idx == 0
        self._v0[systems[start]] = v[start]
        # first sample at which V has dropped enough (or the last one): where the rate is measured
        open_ = np.isnan(self._tk[systems])
        hit = open_ & ((v <= DECAY_MEASURE_DROP * self._v0[systems]) | last[:, None])
        rows, veh = np.nonzero(hit)
        self._vk[systems[rows], veh] = v[rows, veh]
        self._tk[systems[rows], veh] = np.where(idx[rows] == 0, 0.0, self._t[idx[rows]])
        self._seen[systems] += 1
        if self._progress is not None:
            done = float(self._seen.sum()) / self._seen.size / self._t.size
            if done >= self._reported + 0.01:
                self._reported = done
                self._progress(done)

    def result(self) -> RunMetrics:
        """The metrics; every run must have received all ``T`` samples."""
        if np.any(self._seen != self._t.size):
            raise SolverError("the integrator did not deliver every output sample of every run")
        peak, saturated = self._force.copy(), self._saturated / self._t.size
        if self._law is None:  # no law, no forces
            peak, saturated = np.full_like(peak, np.nan), np.full_like(saturated, np.nan)
        return RunMetrics(
            max_errors=self._max.copy(),
            tail_position=self._tail.copy(),
            final_position=self._final.copy(),
            decay_rate=decay_rates(self._v0, self._vk, self._tk),
            commanded_peak=peak,
            saturated_fraction=saturated,
        )


__all__ = ["DECAY_MEASURE_DROP", "DECAY_MEASURE_FLOOR", "ErrorSink", "RunMetrics", "decay_rates", "lyapunov_values"]
