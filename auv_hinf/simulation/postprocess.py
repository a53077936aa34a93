"""Vectorised post-processing of closed-loop runs: O(N) Jacobi maps, errors, envelope margin.

Every function works on whole sample arrays at once (no Python loop over samples or
vehicles). Positions are inertial (m); stacks have shape ``(..., N, 2)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from auv_hinf._typing import FloatArray, JacobiKind
from auv_hinf.mission.fleet import Motion, wrap_angle
from auv_hinf.models.jacobi import jacobi_coordinates


@dataclass(frozen=True)
class TrackingErrors:
    """Per-vehicle tracking errors against the reference the law used.

    Attributes
    ----------
    e, e_dot : ndarray, shape (T, N, 2)
        ``p_i - p_id`` (m) and ``p_i' - p_id'`` (m/s), inertial.
    e_psi, e_psi_dot : ndarray, shape (T, N)
        ``wrap(psi_i - psi_id)`` (rad) and ``r_i - psi_id'`` (rad/s).
    """

    e: FloatArray
    e_dot: FloatArray
    e_psi: FloatArray
    e_psi_dot: FloatArray


def tracking_errors(states: FloatArray, p_dot: FloatArray, motion: Motion) -> TrackingErrors:
    """:class:`TrackingErrors` of states ``(T, N, 6)`` with ground velocities ``(T, N, 2)``.

    Parameters
    ----------
    states : ndarray, shape (T, N, 6)
        ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s); extra leading axes broadcast.
    p_dot : ndarray, shape (T, N, 2)
        Ground velocities (m/s, inertial frame).
    motion : Motion
        The desired motion at the same samples.
    """
    e_psi = wrap_angle(states[..., 2] - motion.psi)
    return TrackingErrors(
        e=states[..., 0:2] - motion.p,
        e_dot=p_dot - motion.v,
        e_psi=e_psi,
        e_psi_dot=states[..., 5] - motion.r,
    )


@dataclass(frozen=True)
class FormationErrors:
    """Formation-level errors against a target motion (the unshaped mission).

    Attributes
    ----------
    jacobi : ndarray, shape (T, N, 2)
        Jacobi coordinates of the positions (m).
    shape_error : ndarray, shape (T,)
        ``||X_shape - X_shape,d||`` (m, Frobenius over the N-1 shape vectors).
    center_error : ndarray, shape (T,)
        ``||q_c - q_cd||`` (m).
    desired_center : ndarray, shape (T, 2)
        ``q_cd``, the mean of the target positions (m).
    position_error : ndarray, shape (T, N)
        ``||p_i - p_id||`` of every vehicle (m).
    shape_diff : ndarray, shape (T, N-1, 2)
        ``X_shape - X_shape,d``: the error of each Jacobi shape vector (m, inertial frame).
    """

    jacobi: FloatArray
    shape_error: FloatArray
    center_error: FloatArray
    desired_center: FloatArray
    position_error: FloatArray
    shape_diff: FloatArray


def in_path_frame(vectors: FloatArray, course: FloatArray | None) -> FloatArray:
    """Inertial vectors ``(T, ..., 2)`` in the frame of the course ``chi (T,)``: ``[along, cross] = R(chi)^T v``.

    Unchanged when ``course`` is None (the inertial frame).

    Parameters
    ----------
    vectors : ndarray, shape (T, ..., 2)
        Inertial vectors (e.g. m).
    course : ndarray, shape (T,), or None
        Course angle ``chi`` of each sample (rad).
    """
    if course is None:
        return vectors
    shape = (-1,) + (1,) * (vectors.ndim - 2)
    c, s = np.cos(course).reshape(shape), np.sin(course).reshape(shape)
    out: FloatArray = np.stack(
        [c * vectors[..., 0] + s * vectors[..., 1], -s * vectors[..., 0] + c * vectors[..., 1]], axis=-1
    )
    return out


def formation_errors(positions: FloatArray, target: FloatArray, kind: JacobiKind = "paper") -> FormationErrors:
    """:class:`FormationErrors` of positions ``(T, N, 2)`` against target positions (m).

    Leading axes broadcast: positions ``(T, S, N, 2)`` of ``S`` scenarios against one target
    ``(T, 1, N, 2)`` transform the target once (``desired_center`` then has the target's shape).

    Parameters
    ----------
    positions : ndarray, shape (T, N, 2)
        Vehicle positions (m, inertial frame).
    target : ndarray, shape (T, N, 2)
        Target positions (m, inertial frame).
    kind : {"paper", "orthonormal"}
        Row scaling of the Jacobi transform.
    """
    jac = jacobi_coordinates(positions, kind)
    jac_d = jacobi_coordinates(target, kind)
    diff = jac - jac_d
    return FormationErrors(
        jacobi=jac,
        shape_error=np.sqrt(np.sum(diff[..., :-1, :] ** 2, axis=(-2, -1))),
        center_error=np.linalg.norm(diff[..., -1, :], axis=-1),
        desired_center=jac_d[..., -1, :],
        position_error=np.linalg.norm(positions - target, axis=-1),
        shape_diff=diff[..., :-1, :],
    )


__all__ = ["FormationErrors", "TrackingErrors", "formation_errors", "in_path_frame", "tracking_errors"]
