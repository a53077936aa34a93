"""Mission references: the centre path ``q(t)`` of a formation, with provable bounds.

Every path (sine, line, circle, and the lawn-mower survey pattern with smooth turns) is a
frozen dataclass, callable on an array of times ``t`` (s) and returning the inertial position
``q`` (m), velocity ``q'`` (m/s), acceleration ``q''`` (m/s^2) and jerk ``q'''`` (m/s^3), each
of shape ``np.shape(t) + (2,)``. :meth:`bounds` gives analytic bounds valid for every
``t >= 0``; each is widened outward by the relative margin :data:`BOUND_RTOL` so that
floating-point rounding cannot make a sampled value escape it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import cached_property
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, require_finite

#: Outward relative margin on every analytic bound. Evaluating a bound or a sampled
#: quantity (a few flops, atan2/sin/cos) costs a few ulps (~1e-15 relative); 1e-12 covers
#: that with a wide margin while staying far below any physical resolution.
BOUND_RTOL = 1e-12


#: Gauss-Legendre nodes for positions inside turns. The integrand cos/sin of a degree-7
#: polynomial of at most pi/2 is entire; 24 nodes reach machine precision (checked in tests
#: against 64 nodes and adaptive quadrature).
GL_NODES = 24


#: Septic smoothstep ``b(s) = 35 s^4 - 84 s^5 + 70 s^6 - 20 s^7`` on [0, 1]: ``b(0) = 0``,
#: ``b(1) = 1``, and ``b', b'', b'''`` vanish at both ends.
SMOOTHSTEP = Polynomial([0.0, 0.0, 0.0, 0.0, 35.0, -84.0, 70.0, -20.0])


Derivatives = tuple[FloatArray, FloatArray, FloatArray, FloatArray]


def poly_sup(p: Polynomial) -> float:
    """Sound ``sup |p(s)|`` over ``s`` in [0, 1] (dimensionless).

    The maximum of ``|p|`` is at an end point or at a real root of ``p'``. All roots of
    ``p'`` (real parts, clipped into [0, 1]) are candidates: spurious ones cannot raise the
    maximum above the true supremum, and multiple roots perturbed off the real axis are not
    lost. The result is widened by :data:`BOUND_RTOL`.

    Parameters
    ----------
    p : numpy.polynomial.Polynomial
        The polynomial ``p(s)``.
    """
    crit = np.concatenate([[0.0, 1.0], np.clip(p.deriv().roots().real, 0.0, 1.0)])
    return float(np.max(np.abs(p(crit)))) * (1.0 + BOUND_RTOL)


def times(t: ArrayLike) -> FloatArray:
    """``t`` as a float array (s); raise :class:`ParameterError` if any entry is not finite.

    Parameters
    ----------
    t : array_like
        Times (s).
    """
    arr = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"times t must be finite (s), got non-finite entries in {arr!r}")
    return arr


def _check(obj: object, name: str, unit: str, *, positive: bool = True, nonneg: bool = False) -> None:
    value = require_finite(f"{type(obj).__name__}.{name}", getattr(obj, name))
    if (positive and not nonneg and value <= 0) or (nonneg and value < 0):
        rng = ">= 0" if nonneg else "> 0"
        raise ParameterError(f"{type(obj).__name__}.{name} must be {rng} ({unit}), got {value!r}")
    object.__setattr__(obj, name, value)


def _check_point(obj: object, name: str) -> None:
    arr = np.asarray(getattr(obj, name), dtype=float)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ParameterError(f"{type(obj).__name__}.{name} must be 2 finite numbers (m), got {arr!r}")
    object.__setattr__(obj, name, (float(arr[0]), float(arr[1])))


def _vec(x: FloatArray, y: FloatArray) -> FloatArray:
    x, y = np.broadcast_arrays(x, y)
    return np.stack([x, y], axis=-1)


@dataclass(frozen=True)
class MissionBounds:
    """Bounds of a mission path valid for every ``t >= 0``.

    Attributes
    ----------
    speed_min, speed_max : float
        Range of the ground speed ``|q'|`` (m/s).
    accel_max, jerk_max : float
        Upper bounds of ``|q''|`` (m/s^2) and ``|q'''|`` (m/s^3).
    turn_rate_min, turn_rate_max : float
        Range of the course rate ``chi' = (x'y'' - y'x'')/|q'|^2`` (rad/s), ``chi = atan2(q')``.
    turn_accel_max : float
        Upper bound of ``|chi''|`` (rad/s^2).
    snap_max : float
        Upper bound of the fourth derivative ``|q^(4)|`` (m/s^4); ``inf`` when the path gives none.
    """

    speed_min: float
    speed_max: float
    accel_max: float
    jerk_max: float
    turn_rate_min: float
    turn_rate_max: float
    turn_accel_max: float
    snap_max: float = math.inf

    @staticmethod
    def widened(**values: float) -> MissionBounds:
        """Bounds from exact values, widened outward by :data:`BOUND_RTOL` of each one's scale.

        Course terms are computed from ``q', q'', q'''``, so their rounding scales with
        ``A/S`` (rate) and ``J/S + 2 (A/S)^2`` (its derivative), not with their values, which
        may be exactly zero (the ``chi''`` of a circle).

        Parameters
        ----------
        **values : float
            The exact bounds, one keyword per attribute of :class:`MissionBounds` (``snap_max``
            may be left out), in the attributes' units.
        """
        v = values
        s, a = v["speed_min"], v["accel_max"]
        scale = {k: abs(x) for k, x in v.items()}
        scale["turn_rate_min"] = scale["turn_rate_max"] = max(abs(v["turn_rate_max"]), abs(v["turn_rate_min"]), a / s)
        scale["turn_accel_max"] = max(v["turn_accel_max"], v["jerk_max"] / s + 2.0 * (a / s) ** 2)
        out = {k: x + scale[k] * BOUND_RTOL for k, x in v.items()}
        for k in ("speed_min", "turn_rate_min"):
            out[k] = v[k] - scale[k] * BOUND_RTOL
        return MissionBounds(**out)


class MissionReference(Protocol):
    """A centre path: ``kind``, ``__call__(t)``, ``snap(t)``, ``bounds()``, ``to_dict()``.

    ``__call__(t)`` gives ``(q, q', q'', q''')``: position (m), velocity (m/s), acceleration
    (m/s^2) and jerk (m/s^3), inertial frame, each of shape ``np.shape(t) + (2,)``.
    """

    kind: ClassVar[str]

    def __call__(self, t: ArrayLike) -> Derivatives: ...

    def snap(self, t: ArrayLike) -> FloatArray:
        """Fourth derivative of ``q`` (m/s^4, inertial frame), shape ``np.shape(t) + (2,)``.

        Parameters
        ----------
        t : array_like
            Times (s), finite.
        """
        ...

    def bounds(self) -> MissionBounds:
        """Bounds of the path valid for every ``t >= 0``."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """Parameters as plain JSON types, with ``kind``."""
        ...


class _Base:
    kind: ClassVar[str]
    __dataclass_fields__: ClassVar[dict[str, Any]]

    def to_dict(self) -> dict[str, Any]:
        """Parameters as plain JSON types, with ``kind``; ``reference_from_dict(**d)`` inverts it."""
        params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}
        return {"kind": self.kind, **params}


@dataclass(frozen=True)
class SineReference(_Base):
    """Section V path ``q = [s t, A sin(w t)]``.

    Parameters
    ----------
    speed : float
        Along-track speed ``s`` (m/s), > 0.
    amplitude : float
        Cross-track amplitude ``A`` (m), >= 0.
    omega : float
        Angular frequency ``w`` (rad/s), > 0.

    Notes
    -----
    Bounds (write ``a = A w``, ``c = cos(w t)``, ``k = a^2/s^2``):

    * ``|q'|^2 = s^2 + a^2 c^2``: speed in ``[s, sqrt(s^2 + a^2)]`` exactly (``c = 0, 1``).
    * ``|q''| = a w |sin| <= A w^2``, ``|q'''| = a w^2 |c| <= A w^3``, both attained.
    * ``chi' = -s a w sin / (s^2 + a^2 c^2)``. With ``c^2 = 1 - sin^2`` the numerator grows
      and the denominator shrinks with ``|sin|``, so ``|chi'| <= a w / s = A w^2/s``,
      attained at ``c = 0``.
    * ``chi'' = -(a w^2/s) c (1 + 2k - k c^2) / (1 + k c^2)^2 =: -(a w^2/s) h(c)``. With
      ``z = k c^2`` the sign of ``h'(c)`` is that of ``z^2 - 6(1+k) z + (1+2k)``, positive at
      ``z = 0`` with smaller root ``z* = (1+2k)/(3(1+k) + sqrt(9(1+k)^2 - 1 - 2k))`` (the
      larger one exceeds ``k``). So ``h`` rises up to ``c* = sqrt(z*/k)`` and falls after;
      ``sup|chi''| = (a w^2/s) h(min(c*, 1))`` exactly (``h(1) = 1/(1+k)``).
    """

    speed: float = 1.0
    amplitude: float = 30.0
    omega: float = 0.1
    kind: ClassVar[str] = "sine"

    def __post_init__(self) -> None:
        _check(self, "speed", "m/s")
        _check(self, "amplitude", "m", nonneg=True)
        _check(self, "omega", "rad/s")

    def __call__(self, t: ArrayLike) -> Derivatives:
        """Position (m), velocity (m/s), acceleration (m/s^2) and jerk (m/s^3), shape ``t.shape + (2,)``."""
        tt = times(t)
        s, a, w = self.speed, self.amplitude, self.omega
        sn, cs = np.sin(w * tt), np.cos(w * tt)
        zero = np.zeros_like(tt)
        return (
            _vec(s * tt, a * sn),
            _vec(s + zero, a * w * cs),
            _vec(zero, -a * w * w * sn),
            _vec(zero, -a * w**3 * cs),
        )

    @property
    def period(self) -> float:
        """``2 pi / w`` (s)."""
        return 2.0 * math.pi / self.omega

    def snap(self, t: ArrayLike) -> FloatArray:
        """Fourth derivative of ``q`` (m/s^4), shape ``t.shape + (2,)``.

        Parameters
        ----------
        t : array_like
            Times (s), finite.
        """
        tt = times(t)
        return _vec(np.zeros_like(tt), self.amplitude * self.omega**4 * np.sin(self.omega * tt))

    def bounds(self) -> MissionBounds:
        """Exact bounds (see Notes), widened by :data:`BOUND_RTOL`."""
        s, w = self.speed, self.omega
        a = self.amplitude * w
        k = (a / s) ** 2
        z = (1 + 2 * k) / (3 * (1 + k) + math.sqrt(9 * (1 + k) ** 2 - 1 - 2 * k))
        c = 1.0 if z >= k else math.sqrt(z / k)
        h = c * (1 + 2 * k - k * c * c) / (1 + k * c * c) ** 2
        return MissionBounds.widened(
            speed_min=s,
            speed_max=math.hypot(s, a),
            accel_max=a * w,
            jerk_max=a * w * w,
            turn_rate_min=-a * w / s,
            turn_rate_max=a * w / s,
            turn_accel_max=a * w * w / s * h,
            snap_max=a * w**3,
        )


@dataclass(frozen=True)
class LineReference(_Base):
    """Straight line ``q = start + s t [cos h, sin h]``.

    Parameters
    ----------
    speed : float
        Speed ``s`` (m/s), > 0.
    heading : float
        Course ``h`` (rad, inertial frame).
    start : tuple of float
        ``q(0)`` (m). Bounds are exact: speed ``s``, everything else zero.
    """

    speed: float
    heading: float = 0.0
    start: tuple[float, float] = (0.0, 0.0)
    kind: ClassVar[str] = "line"

    def __post_init__(self) -> None:
        _check(self, "speed", "m/s")
        _check(self, "heading", "rad", positive=False)
        _check_point(self, "start")

    def __call__(self, t: ArrayLike) -> Derivatives:
        """Position (m), velocity (m/s), acceleration, jerk (zero), shape ``t.shape + (2,)``."""
        tt = times(t)[..., None]
        d = self.speed * np.array([math.cos(self.heading), math.sin(self.heading)])
        zero = np.zeros((*tt.shape[:-1], 2))
        return np.asarray(self.start) + tt * d, d + zero, zero, zero.copy()

    def snap(self, t: ArrayLike) -> FloatArray:
        """Fourth derivative of ``q`` (zero), shape ``t.shape + (2,)``.

        Parameters
        ----------
        t : array_like
            Times (s), finite.
        """
        return np.zeros((*times(t).shape, 2))

    def bounds(self) -> MissionBounds:
        """Speed ``s``; acceleration, jerk and turn terms zero (exact)."""
        s = self.speed
        return MissionBounds.widened(
            speed_min=s,
            speed_max=s,
            accel_max=0.0,
            jerk_max=0.0,
            turn_rate_min=0.0,
            turn_rate_max=0.0,
            turn_accel_max=0.0,
            snap_max=0.0,
        )


@dataclass(frozen=True)
class CircleReference(_Base):
    """Counter-clockwise circle ``q = center + R [cos th, sin th]``, ``th = -pi/2 + s t / R``.

    The start angle ``-pi/2`` puts ``q(0)`` below the centre with ``q'(0) = [s, 0]``.

    Parameters
    ----------
    speed : float
        Speed ``s`` (m/s), > 0.
    radius : float
        ``R`` (m), > 0.
    center : tuple of float
        Centre (m).

    Notes
    -----
    Exact constants: ``|q'| = s``, ``|q''| = s^2/R``, ``|q'''| = s^3/R^2``, ``chi' = s/R``,
    ``chi'' = 0``.
    """

    speed: float
    radius: float
    center: tuple[float, float] = (0.0, 0.0)
    kind: ClassVar[str] = "circle"

    def __post_init__(self) -> None:
        _check(self, "speed", "m/s")
        _check(self, "radius", "m")
        _check_point(self, "center")

    def __call__(self, t: ArrayLike) -> Derivatives:
        """Position (m), velocity (m/s), acceleration (m/s^2), jerk (m/s^3), shape ``t.shape + (2,)``."""
        s, rad = self.speed, self.radius
        th = -0.5 * np.pi + (s / rad) * times(t)
        e, n = _vec(np.cos(th), np.sin(th)), _vec(-np.sin(th), np.cos(th))
        return np.asarray(self.center) + rad * e, s * n, -(s * s / rad) * e, -(s**3 / rad**2) * n

    @property
    def period(self) -> float:
        """One lap, ``2 pi R / s`` (s)."""
        return 2.0 * math.pi * self.radius / self.speed

    def snap(self, t: ArrayLike) -> FloatArray:
        """Fourth derivative ``(s^4/R^3) [cos th, sin th]`` of ``q`` (m/s^4), shape ``t.shape + (2,)``.

        Parameters
        ----------
        t : array_like
            Times (s), finite.
        """
        s, rad = self.speed, self.radius
        th = -0.5 * np.pi + (s / rad) * times(t)
        out: FloatArray = (s**4 / rad**3) * _vec(np.cos(th), np.sin(th))
        return out

    def bounds(self) -> MissionBounds:
        """Exact constants (see Notes), widened by :data:`BOUND_RTOL`."""
        s, rad = self.speed, self.radius
        return MissionBounds.widened(
            speed_min=s,
            speed_max=s,
            accel_max=s * s / rad,
            jerk_max=s**3 / rad**2,
            turn_rate_min=s / rad,
            turn_rate_max=s / rad,
            turn_accel_max=0.0,
            snap_max=s**4 / rad**3,
        )


def heading_from_velocity(v: ArrayLike, a: ArrayLike, j: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Course angle of a velocity and its first two time derivatives.

    Parameters
    ----------
    v, a, j : array_like, shape (..., 2)
        Velocity (m/s), acceleration (m/s^2) and jerk (m/s^3), inertial frame.

    Returns
    -------
    chi : ndarray, shape (...)
        ``atan2(v_y, v_x)`` in (-pi, pi] (rad).
    chi_dot : ndarray, shape (...)
        ``(v x a)/|v|^2`` (rad/s).
    chi_ddot : ndarray, shape (...)
        ``(v x j)/|v|^2 - 2 chi' (v . a)/|v|^2`` (rad/s^2).

    Raises
    ------
    ParameterError
        If any ``|v|`` is zero (the course is undefined) or an input is not finite.
    """
    vv, aa, jj = (np.asarray(x, dtype=float) for x in (v, a, j))
    s2 = vv[..., 0] ** 2 + vv[..., 1] ** 2
    if not np.all(s2 > 0):
        raise ParameterError("velocity v must be nonzero (m/s) for the course to be defined, got |v| = 0")
    chi_dot = (vv[..., 0] * aa[..., 1] - vv[..., 1] * aa[..., 0]) / s2
    cross_j = vv[..., 0] * jj[..., 1] - vv[..., 1] * jj[..., 0]
    chi_ddot = (cross_j - 2.0 * chi_dot * (vv[..., 0] * aa[..., 0] + vv[..., 1] * aa[..., 1])) / s2
    if not (np.all(np.isfinite(chi_dot)) and np.all(np.isfinite(chi_ddot))):
        raise ParameterError("v, a and j must be finite (m/s, m/s^2, m/s^3)")
    chi: FloatArray = np.arctan2(vv[..., 1], vv[..., 0])
    return chi, chi_dot, chi_ddot


#: Sup norms of the smoothstep derivatives on [0, 1]: ``b'`` peaks at 35/16 (s = 1/2),
#: ``|b''|`` at ``84/(5 sqrt 5)`` (s = 1/2 -+ 1/(2 sqrt 5)); computed from the polynomial.
SMOOTHSTEP_D1_MAX = poly_sup(SMOOTHSTEP.deriv())


SMOOTHSTEP_D2_MAX = poly_sup(SMOOTHSTEP.deriv(2))


#: ``max |b'''|`` on [0, 1] (``b'''`` is 0 at both ends, so the course is C^3 across the joins).
SMOOTHSTEP_D3_MAX = poly_sup(SMOOTHSTEP.deriv(3))


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
    ``|chi''| <= chi''max`` (exact); ``q'''' = s ((chi''' - chi'^3) n - 3 chi' chi'' t)`` (``t, n``
    the unit tangent and normal), so ``|q''''| <= s (chi'''max + 3 chi'max chi''max + chi'max^3)``
    with ``chi'''max = (pi/2) max|b'''| / T90^3``.
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
        """Fourth derivative of ``q`` (m/s^4), shape ``t.shape + (2,)``.

        With ``q' = s T(chi)``, ``q'''' = s ((chi''' - chi'^3) N - 3 chi' chi'' T)`` (``T``, ``N``
        tangent and normal).

        Parameters
        ----------
        t : array_like
            Times (s), finite.
        """
        _, _, _, tan, nor, d1, d2, d3 = self._course(times(t))
        s = self.speed
        out: FloatArray = (s * (d3 - d1**3))[..., None] * nor - (3.0 * s * d1 * d2)[..., None] * tan
        return out

    def bounds(self) -> MissionBounds:
        """Bounds of the class Notes, widened by :data:`BOUND_RTOL`."""
        s = self.speed
        w1 = s / self.turn_radius
        w2 = 0.5 * np.pi * SMOOTHSTEP_D2_MAX / self.t90**2
        w3 = 0.5 * np.pi * SMOOTHSTEP_D3_MAX / self.t90**3
        return MissionBounds.widened(
            speed_min=s,
            speed_max=s,
            accel_max=s * w1,
            jerk_max=s * math.sqrt(w2 * w2 + w1**4),
            turn_rate_min=-w1,
            turn_rate_max=w1,
            turn_accel_max=float(w2),
            snap_max=float(s * (w3 + 3.0 * w1 * w2 + w1**3)),
        )


def course_jerk_bound(speed_min: float, accel: float, jerk: float, snap: float) -> float:
    """Bound of ``|chi'''|`` (rad/s^3) of the course ``chi = atan2(q')`` from bounds of the path's derivatives.

    With ``q' = s (cos chi, sin chi)``: ``|chi'| <= A/s``, ``|s'| <= A``, ``|s''| <= J + A^2/s``,
    ``|chi''| <= J/s + 2 A^2/s^2``, and the normal part of ``q''''`` gives
    ``s chi''' = n . q'''' - 3 s'' chi' + s chi'^3 - 3 s' chi''``, hence
    ``|chi'''| <= S4/s + 6 A J/s^2 + 10 A^3/s^3`` (``s`` the smallest speed, ``A, J, S4`` the
    bounds of ``|q''|, |q'''|, |q''''|``).

    Parameters
    ----------
    speed_min : float
        Smallest speed ``s`` of the path (m/s), > 0.
    accel : float
        Bound ``A`` of ``|q''|`` (m/s^2).
    jerk : float
        Bound ``J`` of ``|q'''|`` (m/s^3).
    snap : float
        Bound ``S4`` of ``|q''''|`` (m/s^4).
    """
    s = speed_min
    return snap / s + 6.0 * accel * jerk / s**2 + 10.0 * accel**3 / s**3


def lawnmower_min_spacing(speed: float, turn_radius: float) -> float:
    """The smallest ``spacing`` a :class:`LawnmowerReference` accepts: two 90-degree turns, ``2 D`` (m).

    ``2 D`` is about ``3.97 turn_radius``; it is computed exactly as the path computes it, on a
    path with the same speed and turn radius and legs far apart, so a spacing at least this large
    is accepted by the path.

    Parameters
    ----------
    speed : float
        Speed along the path (m/s), > 0.
    turn_radius : float
        Smallest radius of the turns (m), > 0.

    Raises
    ------
    ParameterError
        If ``speed`` or ``turn_radius`` is not finite and positive.
    """
    probe = LawnmowerReference(speed=speed, leg_length=1.0, spacing=1e300, turn_radius=turn_radius)  # legs far apart
    return 2.0 * probe._extent


__all__ = [
    "BOUND_RTOL",
    "GL_NODES",
    "SMOOTHSTEP",
    "SMOOTHSTEP_D1_MAX",
    "SMOOTHSTEP_D2_MAX",
    "SMOOTHSTEP_D3_MAX",
    "CircleReference",
    "Derivatives",
    "LawnmowerReference",
    "LineReference",
    "MissionBounds",
    "MissionReference",
    "SineReference",
    "course_jerk_bound",
    "heading_from_velocity",
    "lawnmower_min_spacing",
    "poly_sup",
    "times",
]
