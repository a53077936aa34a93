"""Simulation results: trajectories plus vectorised metrics (forces, errors, envelope exit)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import CHANNELS
from auv_hinf.files import written
from auv_hinf.law.formation_law import saturate
from auv_hinf.mission.fleet import Motion
from auv_hinf.mission.separation import closest_approach
from auv_hinf.models.vehicle import ground_velocity
from auv_hinf.simulation.postprocess import TrackingErrors, formation_errors, in_path_frame, tracking_errors

if TYPE_CHECKING:
    from auv_hinf.simulation.scenario import Scenario


@dataclass(frozen=True)
class SimulationResult:
    """Trajectories and metrics of one scenario.

    Attributes
    ----------
    t : ndarray (T,)
        Time, s.
    states : ndarray (T, N, 6)
    forces : ndarray (T, N, 3)
        Applied thrust (after saturation), N and N m, body frame.
    jacobi : ndarray (T, N, 2)
        Jacobi coordinates of the positions (m).
    shape_error, center_error : ndarray (T,)
        Jacobi shape error (m, Frobenius over the N-1 vectors) and centre error (m), both
        against the unshaped mission (``scenario.mission``, default the reference used).
    desired_center : ndarray (T, 2)
        Mission formation centre (m).
    saturated : ndarray (T,) of bool
        Whether any vehicle's thrust was clipped.
    position_error : ndarray (T, N)
        ``||p_i - p_id||`` against the reference the law tracked (m).
    mission_error : ndarray (T, N)
        ``||p_i - off_i - q_d||`` against the unshaped mission (m).
    tracking : TrackingErrors
        Per-vehicle ``e, e', e_psi, e_psi'`` against the reference the law tracked.
    exit_time : float or None
        First time (s) any vehicle's ``(u, v, r)`` left the envelope, located on the
        integrator's interpolant; None if it stayed in (or there is no envelope).
    n_steps : int
        Accepted integration steps (the largest over the scenario's systems).
    scenario : Scenario
    commanded_peak : tuple of float
        Largest ``|tau_x|, |tau_y|, |tau_psi|`` the law commanded at the output samples (at
        every control sample for a sampled implementation), before saturation (N, N, N m),
        over all vehicles.
    diverged_at : float or None
        When a sampled run was stopped as diverged (s; see
        :data:`~auv_hinf.implementation.sampled_loop.DIVERGED_RATE`); None if it was not.
    shape_components : ndarray (T, N-1, 2) or None
        Error of each Jacobi shape vector against the unshaped mission in the scenario's
        ``frame`` (m): ``[along, cross]`` track in the path frame (rotated by the path's course),
        ``[x, y]`` in the inertial frame.
    """

    t: FloatArray
    states: FloatArray
    forces: FloatArray
    jacobi: FloatArray
    shape_error: FloatArray
    center_error: FloatArray
    desired_center: FloatArray
    saturated: NDArray[np.bool_]
    position_error: FloatArray
    mission_error: FloatArray
    tracking: TrackingErrors = field(repr=False)
    exit_time: float | None
    n_steps: int
    scenario: Scenario = field(repr=False)
    commanded_peak: tuple[float, float, float] = (0.0, 0.0, 0.0)
    shape_components: FloatArray | None = field(default=None, repr=False)
    diverged_at: float | None = None

    def error_at(self, time: float) -> tuple[float, float]:
        """Shape and centre error (m) at the sample nearest to ``time`` (s).

        Parameters
        ----------
        time : float
            Time (s).
        """
        k = int(np.argmin(np.abs(self.t - time)))
        return float(self.shape_error[k]), float(self.center_error[k])

    def envelope_check(self) -> tuple[bool | None, float | None]:
        """Whether ``(u, v, r)`` stayed in the scenario's envelope, and the first exit time (s)."""
        if self.scenario.envelope is None:
            return None, None
        return self.exit_time is None, self.exit_time

    def summary(self) -> dict[str, Any]:
        """Metrics as a JSON-safe dictionary (m, N, N m, m/s, rad/s, s)."""
        stayed, exit_time = self.envelope_check()
        return {
            "scenario": self.scenario.name,
            "n": int(self.states.shape[1]),
            "horizon": float(self.t[-1]),
            "final_shape_error": float(self.shape_error[-1]),
            "final_center_error": float(self.center_error[-1]),
            "final_position_error": float(self.mission_error[-1].max()),
            "rms_shape_error": float(np.sqrt(np.mean(self.shape_error**2))),
            "max_force": float(np.abs(self.forces[..., :2]).max()),
            "max_moment": float(np.abs(self.forces[..., 2]).max()),
            "max_speed": float(np.abs(self.states[..., 3]).max()),
            "max_sway": float(np.abs(self.states[..., 4]).max()),
            "max_yaw_rate": float(np.abs(self.states[..., 5]).max()),
            "final_sway": float(np.abs(self.states[-1, :, 4]).max()),
            "saturation_fraction": float(self.saturated.mean()),
            "commanded_peak": dict(zip(CHANNELS, self.commanded_peak)),
            "actuator_limits": None if self.scenario.law.actuators is None else self.scenario.law.actuators.to_dict(),
            "stayed_in_envelope": stayed,
            "first_exit_time": exit_time,
            "shape_errors": self.shape_errors(),
            "diverged_at": self.diverged_at,
            **self.separation(),
        }

    def separation(self) -> dict[str, Any]:
        """``min_separation``: the smallest distance between any two vehicles over the samples (m), and its pair.

        ``min_separation_pair`` is ``[i, j]`` (0-based) and ``min_separation_time`` the sample's time (s);
        see :func:`~auv_hinf.mission.separation.closest_approach` (k-d trees for large fleets).
        """
        if self.states.shape[1] < 2:
            return {"min_separation": None, "min_separation_pair": None, "min_separation_time": None}
        c = closest_approach(self.states[..., :2])
        return {
            "min_separation": c.distance,
            "min_separation_pair": list(c.pair),
            "min_separation_time": float(self.t[c.sample]),
        }

    def shape_errors(self) -> dict[str, Any]:
        """Jacobi shape errors in the formation's frame: largest ``|component|`` at the end and over the run (m)."""
        frame = self.scenario.frame or "inertial"
        axes = ["along", "cross"] if frame == "path" else ["x", "y"]
        comp = self.shape_components
        if comp is None or comp.shape[1] == 0:
            return {"frame": frame, "axes": axes, "final": None, "max": None}
        final = np.abs(comp[-1]).max(axis=0)
        peak = np.abs(comp).max(axis=(0, 1))
        return {"frame": frame, "axes": axes, "final": [float(x) for x in final], "max": [float(x) for x in peak]}

    def save_npz(self, path: str | Path) -> None:
        """Write time, states, forces and Jacobi coordinates to a ``.npz`` file.

        Parameters
        ----------
        path : str or Path
            The file (``np.savez_compressed`` appends ``.npz`` when missing).
        """
        target = Path(path) if str(path).endswith(".npz") else Path(f"{path}.npz")
        with written(target) as tmp:  # an interrupted write leaves no truncated file
            np.savez_compressed(tmp, t=self.t, states=self.states, forces=self.forces, jacobi=self.jacobi)


def build_result(
    scn: Scenario, t: FloatArray, states: FloatArray, exit_time: float | None, n_steps: int
) -> SimulationResult:
    """Post-process the samples ``states (T, N, 6)`` at times ``t (T,)`` in whole-array calls.

    Parameters
    ----------
    scn : Scenario
        The scenario the samples belong to.
    t : ndarray, shape (T,)
        Sample times (s).
    states : ndarray, shape (T, N, 6)
        ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s), or ``(T, N, 8)`` with the integrator.
    exit_time : float or None
        First envelope exit (s), None if the run stayed in.
    n_steps : int
        Accepted integration steps.
    """
    return build_results((scn,), t, states[:, None], [exit_time], [n_steps])[0]


def _expand(m: Motion) -> Motion:
    """``m`` with a scenario axis inserted after the time axis: ``(T, N, .)`` -> ``(T, 1, N, .)``."""
    return Motion(*(x[:, None] for x in (m.p, m.v, m.a, m.psi, m.r, m.r_dot)))


def build_results(
    scns: Sequence[Scenario],
    t: FloatArray,
    states: FloatArray,
    exit_times: Sequence[float | None],
    n_steps: Sequence[int],
    *,
    commanded: FloatArray | None = None,
    peaks: FloatArray | None = None,
) -> list[SimulationResult]:
    """Post-process ``S`` scenarios sampled as ``states (T, S, N, w)`` at times ``t (T,)``.

    ``w`` is 6, or 8 with the integrator of integral action (the law reads it; the results keep
    the plant's 6 columns).

    Scenarios that share their reference, mission, law and Jacobi convention (a campaign's
    chunk) are processed together in whole-array calls, with the desired motion evaluated
    once; the others one at a time. Each result holds views of the batched arrays.

    Parameters
    ----------
    scns : sequence of Scenario
        The ``S`` scenarios.
    t : ndarray, shape (T,)
        Sample times (s).
    states : ndarray, shape (T, S, N, w)
        ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s), then the integrator ``z`` (m s).
    exit_times : sequence of float or None
        Each scenario's first envelope exit (s), None if it stayed in.
    n_steps : sequence of int
        Each scenario's accepted integration steps.
    commanded : ndarray, shape (T, S, N, 3), optional
        The law's output before saturation at the samples (N, N, N m, body frame), when it is not
        the law at the sampled state (a sampled implementation holds it).
    peaks : ndarray, shape (S, 3), optional
        Its peak per channel (N, N, N m) when that was taken over more instants than ``t``.
    """
    first = scns[0]
    shared = all(
        x.reference is first.reference and x.mission is first.mission and x.jacobi == first.jacobi for x in scns
    )
    shared = shared and all(x.law == first.law for x in scns)
    if not shared and len(scns) > 1:
        return [
            build_results(
                (x,),
                t,
                states[:, k : k + 1],
                [exit_times[k]],
                [n_steps[k]],
                commanded=None if commanded is None else commanded[:, k : k + 1],
                peaks=None if peaks is None else peaks[k : k + 1],
            )[0]
            for k, x in enumerate(scns)
        ]
    current = np.array([x.current for x in scns], dtype=float)[None, :, None, :]  # (1, S, 1, 2)
    p_dot = ground_velocity(states, current)
    motion = _expand(first.reference.motion(t))
    if commanded is None:
        commanded = first.law.unsaturated(states, p_dot, motion)  # with the integrator columns, if any
    states = states[..., :6]
    forces, active = saturate(commanded, first.law.actuators, states[..., 3])
    if peaks is None:
        peaks = np.abs(commanded).max(axis=(0, 2))  # (S, 3): over samples and vehicles
    desired = None if first.mission is None else first.mission.motion(t)
    target = motion.p if desired is None else desired.p[:, None]
    form = formation_errors(states[..., 0:2], target, first.jacobi)
    course = (motion.psi[:, 0, 0] if desired is None else desired.psi[:, 0]) if first.frame == "path" else None
    components = in_path_frame(form.shape_diff, course)
    track = tracking_errors(states, p_dot, motion)
    saturated = np.asarray(active.any(axis=-1), dtype=bool)
    position_error = np.linalg.norm(track.e, axis=-1)
    out = []
    for k, scn in enumerate(scns):
        out.append(
            SimulationResult(
                t=t,
                states=states[:, k],
                forces=forces[:, k],
                jacobi=form.jacobi[:, k],
                shape_error=form.shape_error[:, k],
                center_error=form.center_error[:, k],
                desired_center=np.broadcast_to(form.desired_center, (*form.jacobi.shape[:2], 2))[:, k],
                saturated=saturated[:, k],
                position_error=position_error[:, k],
                mission_error=form.position_error[:, k],
                tracking=TrackingErrors(
                    e=track.e[:, k],
                    e_dot=track.e_dot[:, k],
                    e_psi=track.e_psi[:, k],
                    e_psi_dot=track.e_psi_dot[:, k],
                ),
                exit_time=exit_times[k],
                n_steps=int(n_steps[k]),
                scenario=scn,
                commanded_peak=(float(peaks[k, 0]), float(peaks[k, 1]), float(peaks[k, 2])),
                shape_components=np.broadcast_to(components, form.jacobi.shape[:2] + components.shape[-2:])[:, k],
            )
        )
    return out


__all__ = ["SimulationResult", "build_result", "build_results"]
