"""Lawn-mower survey pattern with smooth turns (a mission reference, see :mod:`auv_hinf.models.paths`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError
from auv_hinf.models.paths import (
    GL_NODES,
    SMOOTHSTEP,
    Derivatives,
    MissionBounds,
    _Base,
    _check,
    _check_point,
    _vec,
    poly_sup,
    times,
)

#: Sup norms of the smoothstep derivatives on [0, 1]: ``b'`` peaks at 35/16 (s = 1/2),
#: ``|b''|`` at ``84/(5 sqrt 5)`` (s = 1/2 -+ 1/(2 sqrt 5)); computed from the polynomial.
SMOOTHSTEP_D1_MAX = poly_sup(SMOOTHSTEP.deriv())
SMOOTHSTEP_D2_MAX = poly_sup(SMOOTHSTEP.deriv(2))
#: Smoothstep derivatives and the Gauss-Legendre rule, built once (paths are evaluated at
#: every right-hand-side call).
_SMOOTHSTEP_D1 = SMOOTHSTEP.deriv()
_SMOOTHSTEP_D2 = SMOOTHSTEP.deriv(2)
_SMOOTHSTEP_D3 = SMOOTHSTEP.deriv(3)
_SMOOTHSTEP_DERIVS = (_SMOOTHSTEP_D1, _SMOOTHSTEP_D2, _SMOOTHSTEP_D3)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(GL_NODES)


@dataclass(frozen=True)
class LawnmowerReference(_Base):
    """Survey pattern: legs along +x, -x, +x, ..., each shifted by ``spacing`` in +y.

    Constant speed ``s``. Each 180-degree turn is a 90-degree turn, a straight transit along
    +y and another 90-degree turn, alternately left (after +x legs) and right (after -x
    legs). A 90-degree turn has course ``chi(tau) = chi0 +- (pi/2) b(tau/T90)`` with ``b`` the
    septic smoothstep, so the course is C^3 in time and ``q`` is C^4.
    ``T90 = (pi/2) max(b') R / s`` makes the peak curvature ``1/R``. A turn advances
    ``D = s T90 int_0^1 cos((pi/2) b)`` along both axes (``b(1-x) = 1 - b(x)``), so the
    transit is ``spacing - 2 D`` (``2 D`` is about ``3.97 R``), which must be >= 0. The pattern starts at
    ``start`` at the beginning of a +x leg and repeats for ever; for ``t < 0`` the first leg is
    continued backwards. Positions in turns integrate ``s (cos chi, sin chi)`` by
    :data:`GL_NODES`-point Gauss-Legendre quadrature.

    Parameters
    ----------
    speed : float
        ``s`` (m/s), > 0.
    leg_length : float
        Length of each straight leg (m), > 0.
    spacing : float
        Lateral distance between legs (m), > 0.
    turn_radius : float
        Minimum radius of curvature ``R`` (m), > 0.
    start : tuple of float
        ``q(0)`` (m).

    Notes
    -----
    Bounds, with ``chi'max = s/R`` and ``chi''max = (pi/2) max|b''| / T90^2``:
    speed ``s`` (exact); ``|q''| = s |chi'| <= s^2/R`` (exact); ``|q'''| = s sqrt(chi''^2 +
    chi'^4) <= s sqrt(chi''max^2 + chi'max^4)``; ``chi'`` in ``[-s/R, s/R]`` (exact);
    ``|chi''| <= chi''max`` (exact).
    """

    speed: float
    leg_length: float
    spacing: float
    turn_radius: float
    start: tuple[float, float] = (0.0, 0.0)
    kind: ClassVar[str] = "lawnmower"

    def __post_init__(self) -> None:
        for name, unit in (("speed", "m/s"), ("leg_length", "m"), ("spacing", "m"), ("turn_radius", "m")):
            _check(self, name, unit)
        _check_point(self, "start")
        if self._transit < 0:
            raise ParameterError(
                f"LawnmowerReference.spacing must be >= {2 * self._extent!r} m (two 90-degree turns of "
                f"turn_radius {self.turn_radius!r} m), got {self.spacing!r}: spacing too small for the turn radius"
            )

    @property
    def t90(self) -> float:
        """Duration of a 90-degree turn (s)."""
        return 0.5 * math.pi * (35.0 / 16.0) * self.turn_radius / self.speed

    @cached_property
    def _extent(self) -> float:
        """Advance ``D`` (m) of a 90-degree turn along each axis."""
        return float(self._advance(np.array(self.t90), np.array(1.0), np.array(0.0), np.zeros(2))[0])

    @property
    def _transit(self) -> float:
        return self.spacing - 2.0 * self._extent

    @cached_property
    def _table(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """Segments of one period: start times (9, last = period), turn sign (0 on straights),
        initial course (rad), straight unit direction, start positions (9, relative to ``start``)."""
        tl, t90, tt, hp = self.leg_length / self.speed, self.t90, self._transit / self.speed, 0.5 * np.pi
        dur = np.array([tl, t90, tt, t90, tl, t90, tt, t90])
        sign = np.array([0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, -1.0])
        chi0 = np.array([0.0, 0.0, hp, hp, np.pi, np.pi, hp, hp])
        direc = np.array([[1.0, 0.0], [0, 0], [0, 1], [0, 0], [-1, 0], [0, 0], [0, 1], [0, 0]])
        pos = np.concatenate([np.zeros((1, 2)), np.cumsum(self._advance(dur, sign, chi0, direc), axis=0)])
        return np.concatenate([[0.0], np.cumsum(dur)]), sign, chi0, direc, pos

    def _advance(self, tau: FloatArray, sign: FloatArray, chi0: FloatArray, direc: FloatArray) -> FloatArray:
        """Displacement (m) after local time ``tau`` (s) in segments of the given ``sign``, ``chi0``, ``direc``."""
        x, w = _GL_X, _GL_W
        frac = (tau / self.t90)[..., None]
        chi = chi0[..., None] + sign[..., None] * 0.5 * np.pi * SMOOTHSTEP(frac * 0.5 * (x + 1))
        turn = self.speed * self.t90 * frac * 0.5 * _vec(np.sum(w * np.cos(chi), -1), np.sum(w * np.sin(chi), -1))
        out: FloatArray = np.where((sign != 0)[..., None], turn, self.speed * tau[..., None] * direc)
        return out

    @property
    def period(self) -> float:
        """Duration of one period of the pattern: two legs and two 180-degree turns (s)."""
        return float(self._table[0][-1])

    def _course(self, tt: FloatArray) -> tuple[FloatArray, ...]:
        """Per time: period count, segment, local time (s), tangent and normal (unit, inertial),
        and the course rate and its two derivatives (rad/s, rad/s^2, rad/s^3)."""
        t0, sign, chi0, direc, _ = self._table
        n_per = np.floor(np.maximum(tt, 0.0) / t0[-1])
        local = tt - n_per * t0[-1]
        k = np.clip(np.searchsorted(t0, local, side="right") - 1, 0, len(sign) - 1)
        tau = local - t0[k]
        t90 = self.t90
        frac = np.clip(tau / t90, 0.0, 1.0)
        sg = sign[k]
        chi = chi0[k] + sg * 0.5 * np.pi * SMOOTHSTEP(frac)
        d1, d2, d3 = (sg * 0.5 * np.pi * b(frac) / t90**i for i, b in enumerate(_SMOOTHSTEP_DERIVS, start=1))
        tan = np.where((sg != 0)[..., None], _vec(np.cos(chi), np.sin(chi)), direc[k])
        return n_per, k, tau, tan, _vec(-tan[..., 1], tan[..., 0]), d1, d2, d3

    def __call__(self, t: ArrayLike) -> Derivatives:
        """Position (m), velocity (m/s), acceleration (m/s^2), jerk (m/s^3), shape ``t.shape + (2,)``."""
        tt = times(t)
        _, sign, chi0, direc, pos = self._table
        n_per, k, tau, tan, nor, d1, d2, _ = self._course(tt)
        s = self.speed
        q = (
            np.asarray(self.start)
            + (pos[-1] * n_per[..., None] + pos[k])
            + self._advance(tau, sign[k], chi0[k], direc[k])
        )
        return (q, s * tan, (s * d1)[..., None] * nor, (s * d2)[..., None] * nor - (s * d1 * d1)[..., None] * tan)

    def snap(self, t: ArrayLike) -> FloatArray:
        """Fourth derivative of ``q`` (m/s^4), shape ``t.shape + (2,)``: with ``q' = s T(chi)``,
        ``q'''' = s ((chi''' - chi'^3) N - 3 chi' chi'' T)`` (``T``, ``N`` tangent and normal)."""
        _, _, _, tan, nor, d1, d2, d3 = self._course(times(t))
        s = self.speed
        out: FloatArray = (s * (d3 - d1**3))[..., None] * nor - (3.0 * s * d1 * d2)[..., None] * tan
        return out

    def bounds(self) -> MissionBounds:
        """Bounds of the class Notes, widened by :data:`BOUND_RTOL`."""
        s = self.speed
        w1 = s / self.turn_radius
        w2 = 0.5 * np.pi * SMOOTHSTEP_D2_MAX / self.t90**2
        return MissionBounds.widened(
            speed_min=s,
            speed_max=s,
            accel_max=s * w1,
            jerk_max=s * math.sqrt(w2 * w2 + w1**4),
            turn_rate_min=-w1,
            turn_rate_max=w1,
            turn_accel_max=float(w2),
        )
