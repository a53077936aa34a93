"""Simulation results: trajectories plus vectorised metrics (forces, errors, envelope exit)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ._typing import FloatArray
from .control_law import saturate
from .postprocess import TrackingErrors, formation_errors, ground_velocity, tracking_errors

if TYPE_CHECKING:
    from .simulation import Scenario


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

    def error_at(self, time: float) -> tuple[float, float]:
        """Shape and centre error (m) at the sample nearest to ``time`` (s)."""
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
            "stayed_in_envelope": stayed,
            "first_exit_time": exit_time,
        }

    def save_npz(self, path: str | Path) -> None:
        """Write time, states, forces and Jacobi coordinates to a ``.npz`` file."""
        np.savez_compressed(path, t=self.t, states=self.states, forces=self.forces, jacobi=self.jacobi)


def build_result(
    scn: Scenario, t: FloatArray, states: FloatArray, exit_time: float | None, n_steps: int
) -> SimulationResult:
    """Post-process the samples ``states (T, N, 6)`` at times ``t (T,)`` in whole-array calls."""
    p_dot = ground_velocity(states, scn.current)
    motion = scn.reference.motion(t)
    forces, active = saturate(scn.law.unsaturated(states, p_dot, motion), scn.law.thrust_limit)
    target = motion.p if scn.mission is None else scn.mission.motion(t).p
    form = formation_errors(states[..., 0:2], target, scn.jacobi)
    track = tracking_errors(states, p_dot, motion)
    return SimulationResult(
        t=t,
        states=states,
        forces=forces,
        jacobi=form.jacobi,
        shape_error=form.shape_error,
        center_error=form.center_error,
        desired_center=form.desired_center,
        saturated=np.asarray(active.any(axis=-1), dtype=bool),
        position_error=np.linalg.norm(track.e, axis=-1),
        mission_error=form.position_error,
        tracking=track,
        exit_time=exit_time,
        n_steps=n_steps,
        scenario=scn,
    )


__all__ = ["SimulationResult", "build_result"]
