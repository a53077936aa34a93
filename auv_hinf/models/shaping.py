"""Start shaping of a fleet reference: the blend basis and the per-vehicle correction.

A shaped start adds ``c_i(t)`` to each vehicle's desired position and ``delta_i(t)`` to its
desired heading; both start at the vehicle's actual mismatch and are blended out to exactly
zero by ``t = T_b`` (:class:`Shaping`). The basis polynomials and their sup norms here are what
:mod:`auv_hinf.models.tubes` uses to bound the shaped reference for all time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.models.paths import SMOOTHSTEP, poly_sup, times

#: Blend basis on ``tau`` in [0, 1]: ``h0 = 1 - b`` (septic smoothstep) and
#: ``h1 = tau (1 - tau)^4 (1 + 4 tau)``: ``h0(0) = 1``, ``h1'(0) = 1``, ``h0'(0) = h1(0) = 0``,
#: ``h0''(0) = h1''(0) = 0`` (the start keeps the mission's initial acceleration), and both
#: vanish at ``tau = 1`` with their first three derivatives. The low degrees keep the peaks
#: of ``|h0'|`` (35/16) and ``|h1'|`` (1, at ``tau = 0``) small.
BLEND_H0 = 1.0 - SMOOTHSTEP
BLEND_H1 = Polynomial([0.0, 1.0]) * Polynomial([1.0, -1.0]) ** 4 * Polynomial([1.0, 4.0])
#: ``sup |h0^(k)|`` and ``sup |h1^(k)|`` on [0, 1], ``k = 0..3``, from the coefficients.
H0_SUP = np.array([poly_sup(BLEND_H0.deriv(k)) for k in range(4)])
H1_SUP = np.array([poly_sup(BLEND_H1.deriv(k)) for k in range(4)])
#: Coefficients (increasing powers of tau, degree <= 7) of h0, h1 and their first three
#: derivatives, stacked as eight rows (h0 and its derivatives, then h1 and its derivatives):
#: one small matrix product evaluates all eight at every right-hand-side call.
_BLEND_COEFS = np.array(
    [np.pad(p.deriv(k).coef, (0, 8 - len(p.deriv(k).coef))) for p in (BLEND_H0, BLEND_H1) for k in range(4)]
)


def blend_basis(t: FloatArray, blend_time: float) -> tuple[FloatArray, FloatArray]:
    """``d^k h0(t/T_b)/dt^k`` and ``T_b d^k h1(t/T_b)/dt^k``, ``k = 0..3``: shape ``(4,) + t.shape``.

    Exactly zero for ``t >= T_b``. For ``t < 0`` the polynomials are continued (the reference
    is meant for ``t >= 0``; continuing keeps the derivatives consistent across ``t = 0``).
    """
    tau = np.asarray(t, dtype=float) / blend_time
    if np.all(tau >= 1.0):
        zero = np.zeros((4, *tau.shape))
        return zero, zero.copy()
    live = tau < 1.0
    powers = np.minimum(tau, 1.0)[..., None] ** np.arange(8)
    vals = np.where(live, np.moveaxis(powers @ _BLEND_COEFS.T, -1, 0), 0.0)  # (8,) + t.shape
    shape = (4,) + (1,) * tau.ndim
    scale0 = (blend_time ** -np.arange(4.0)).reshape(shape)
    scale1 = (blend_time ** (1.0 - np.arange(4.0))).reshape(shape)
    return vals[:4] * scale0, vals[4:] * scale1


@dataclass(frozen=True)
class Shaping:
    """Start correction of a fleet reference, blended out over ``[0, T_b]``.

    ``c_i(t) = dp_i h0(t/T_b) + T_h dv_i h1(t/T_h)`` is added to the desired position (m) and
    ``delta_i(t) = dpsi_i h0(t/T_h) + T_h dr_i h1(t/T_h)`` to the desired heading (rad); both
    vanish for ``t >= T_b`` (basis :data:`BLEND_H0`, :data:`BLEND_H1`). The position error is
    blended out slowly, over ``T_b``; the velocity and heading mismatches over the shorter
    turn time ``T_h``, so that the initial velocity error is not extrapolated over the whole
    blend (a vehicle 20 m off its slot moving 2 m/s the wrong way would otherwise be sent
    ``T_b * 2 m/s`` further before turning back). Leading batch axes ``...`` hold independent
    scenarios.

    Parameters
    ----------
    blend_time : float
        ``T_b`` (s), > 0.
    dp, dv : array_like, shape (..., N, 2)
        Position (m) and velocity (m/s) corrections at ``t = 0``, inertial frame.
    dpsi, dr : array_like, shape (..., N)
        Heading (rad) and yaw-rate (rad/s) offsets at ``t = 0``.
    turn_time : float or None
        ``T_h`` (s), ``0 < T_h <= T_b``; ``None`` means ``T_b``.
    """

    blend_time: float
    dp: FloatArray
    dv: FloatArray
    dpsi: FloatArray
    dr: FloatArray
    turn_time: float | None = None

    def __post_init__(self) -> None:
        tb = require_finite("Shaping.blend_time", self.blend_time)
        if tb <= 0:
            raise ParameterError(f"Shaping.blend_time must be > 0 (s), got {tb!r}")
        object.__setattr__(self, "blend_time", tb)
        th = tb if self.turn_time is None else require_finite("Shaping.turn_time", self.turn_time)
        if not 0 < th <= tb:
            raise ParameterError(f"Shaping.turn_time must be in (0, blend_time = {tb!r}] (s), got {th!r}")
        object.__setattr__(self, "turn_time", th)
        dp = np.asarray(self.dp, dtype=float)
        if dp.ndim < 2 or dp.shape[-1] != 2:
            raise ParameterError(f"Shaping.dp must have shape (..., N, 2) (m), got {dp.shape}")
        for name, shape in (("dp", dp.shape), ("dv", dp.shape), ("dpsi", dp.shape[:-1]), ("dr", dp.shape[:-1])):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.shape != shape or not np.all(np.isfinite(arr)):
                raise ParameterError(f"Shaping.{name} must be finite with shape {shape}, got {arr!r}")
            object.__setattr__(self, name, arr)

    def terms(self, t: ArrayLike) -> tuple[list[FloatArray], list[FloatArray]]:
        """``[c, c', c'', c''']`` (m .. m/s^3, shape ``B + (N, 2)``) and ``[delta, delta', delta'']``
        (rad .. rad/s^2, shape ``B + (N,)``); ``B`` broadcasts ``np.shape(t)`` with the batch shape."""
        tt = times(t)
        h0, _ = blend_basis(tt, self.blend_time)
        g0, g1 = blend_basis(tt, self.th)
        c = [h0[k][..., None, None] * self.dp + g1[k][..., None, None] * self.dv for k in range(4)]
        d = [g0[k][..., None] * self.dpsi + g1[k][..., None] * self.dr for k in range(3)]
        return c, d

    @property
    def th(self) -> float:
        """The turn time ``T_h`` (s) as a float."""
        return float(self.turn_time if self.turn_time is not None else self.blend_time)


__all__ = ["BLEND_H0", "BLEND_H1", "H0_SUP", "H1_SUP", "Shaping", "blend_basis"]
