"""Mission references (centre paths) and the shaped start, with sound bounds.

INTERFACE STUB: the dataclasses below are the contract shared by ``control_law``,
``simulation`` and ``closed_loop``. The implementation of the paths and the shaped start
is filled in around them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray


@dataclass(frozen=True)
class Motion:
    """Desired motion of every vehicle at one or more times.

    Shapes broadcast over leading axes: ``(..., N, 2)`` for vectors, ``(..., N)`` for scalars.

    Attributes
    ----------
    p, v, a : ndarray
        Desired inertial position (m), velocity (m/s) and acceleration (m/s^2) of each vehicle.
    psi, r, r_dot : ndarray
        Desired heading (rad), yaw rate (rad/s) and yaw acceleration (rad/s^2) of each vehicle.
    """

    p: FloatArray
    v: FloatArray
    a: FloatArray
    psi: FloatArray
    r: FloatArray
    r_dot: FloatArray


@dataclass(frozen=True)
class ReferenceTube:
    """Sound bounds of the desired body-frame motion over a set of time cells.

    Every field holds one row per cell (cells of all vehicles may be concatenated). Each
    bound holds for *every* time in its cell, not only at sample points.

    Attributes
    ----------
    speed : ndarray, shape (K, 2)
        ``[lo, hi]`` of the desired ground speed ``|p_d'|`` (m/s); ``lo > 0`` is required
        for the heading reference to be defined.
    offset : ndarray, shape (K, 2)
        ``[lo, hi]`` of the heading offset ``delta = psi_d - atan2(p_d')`` (rad); zero on an
        unshaped mission reference.
    yaw_rate : ndarray, shape (K, 2)
        ``[lo, hi]`` of the desired yaw rate ``psi_d'`` (rad/s).
    accel : ndarray, shape (K,)
        Upper bound of ``|p_d''|`` (m/s^2).
    yaw_accel : ndarray, shape (K,)
        Upper bound of ``|psi_d''|`` (rad/s^2).
    """

    speed: FloatArray
    offset: FloatArray
    yaw_rate: FloatArray
    accel: FloatArray
    yaw_accel: FloatArray

    def __post_init__(self) -> None:
        for name in ("speed", "offset", "yaw_rate"):
            arr = np.atleast_2d(np.asarray(getattr(self, name), dtype=float))
            object.__setattr__(self, name, arr)
        for name in ("accel", "yaw_accel"):
            object.__setattr__(self, name, np.atleast_1d(np.asarray(getattr(self, name), dtype=float)))

    @staticmethod
    def concatenate(tubes: "list[ReferenceTube]") -> "ReferenceTube":
        """One tube holding the cells of all ``tubes``."""
        return ReferenceTube(
            speed=np.concatenate([t.speed for t in tubes]),
            offset=np.concatenate([t.offset for t in tubes]),
            yaw_rate=np.concatenate([t.yaw_rate for t in tubes]),
            accel=np.concatenate([t.accel for t in tubes]),
            yaw_accel=np.concatenate([t.yaw_accel for t in tubes]),
        )
