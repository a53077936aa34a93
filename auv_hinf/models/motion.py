"""The desired motion of every vehicle at one or more times (what a control law tracks)."""

from __future__ import annotations

from dataclasses import dataclass

from auv_hinf._typing import FloatArray


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


__all__ = ["Motion"]
