"""Declared plant uncertainty: the parameter box and sound bounds of the perturbed error loops.

The controller keeps the nominal parameters (hats); the plant is anywhere in the box. With
``Lambda = diag(m11_hat/m11, m22_hat/m22)``, ``L = R Lambda R^T``, the ground-velocity error
``e' = p' - p_d'`` and a constant current ``c`` (inertial, m/s), each vehicle obeys
(``docs/derivations/robust.md``)::

    e''  = G e' - L (alpha e' + k1 e) + d,
    d    = (G - L G_hat) p_d' - G c + (L - I) p_d'',    G - L G_hat = R M^-1 [[dd11, dm r], [dm r, dd22]] R^T
    epsi'' = -K(t) epsi - C(t) epsi' + h,
    K    = (m33_hat k1psi + dM S^2 g)/m33,   C = (m33_hat k2psi + d33(r))/m33,

with ``dd = d_hat - d``, ``dm = (m22 - m11) - (m22_hat - m11_hat) = -dM`` and ``g`` the mean-value
slope of ``sin 2 theta``. :func:`box_sigma` bounds ``||G - lam I||`` over box and envelope by a
multi-affine vertex argument; :func:`position_disturbance` and :func:`heading_perturbation`
bound ``|d|``, ``K``, ``C`` and ``|h|`` from the reference tube and the assumed error bounds.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, require_finite
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import cos_range
from auv_hinf.models.envelope import Envelope, abs_range
from auv_hinf.models.vehicle import VehicleParams

#: The nine coefficients a box may scale, in order.
PARAMETERS = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")
#: Relative inflation of a vertex norm maximum: the closed-form 2x2 norm is accurate to a few
#: ulps of its largest term, far below this.
SIGMA_ROUNDOFF_RTOL = 1e-12
#: A scaled box must keep every multiplier at least this far above 0 (a massless plant is not a
#: plant); :attr:`ParameterBox.max_scale` stops just short of it.
MIN_MULTIPLIER = 1e-3


@dataclass(frozen=True)
class ParameterBox:
    """Relative box of plant parameters around the controller's nominal model.

    Parameters
    ----------
    nominal : VehicleParams
        The controller's parameters (SI units, see :class:`~auv_hinf.models.vehicle.VehicleParams`).
    lo, hi : tuple of float
        Multipliers ``0 < lo <= 1 <= hi`` of the nine :data:`PARAMETERS`, in that order.
    """

    nominal: VehicleParams
    lo: tuple[float, ...] = (1.0,) * 9
    hi: tuple[float, ...] = (1.0,) * 9

    def __post_init__(self) -> None:
        lo = tuple(require_finite("box lower multiplier", x) for x in self.lo)
        hi = tuple(require_finite("box upper multiplier", x) for x in self.hi)
        if len(lo) != 9 or len(hi) != 9 or not all(0.0 < a <= 1.0 <= b for a, b in zip(lo, hi)):
            raise ParameterError(f"a parameter box needs nine ranges with 0 < lo <= 1 <= hi, got {lo!r}, {hi!r}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    @classmethod
    def from_ranges(cls, nominal: VehicleParams, ranges: tuple[tuple[str, tuple[float, float]], ...]) -> ParameterBox:
        """Box from ``(name, (lo, hi))`` pairs (the ``[uncertainty]`` table); others are exact.

        Parameters
        ----------
        nominal : VehicleParams
            The controller's parameters.
        ranges : tuple of (str, (float, float))
            Name (one of :data:`PARAMETERS`) and multipliers ``(lo, hi)`` of each uncertain parameter.
        """
        lo, hi = [1.0] * 9, [1.0] * 9
        for name, (a, b) in ranges:
            if name not in PARAMETERS:
                raise ParameterError(f"unknown uncertain parameter {name!r}; expected one of {PARAMETERS}")
            k = PARAMETERS.index(name)
            lo[k], hi[k] = float(a), float(b)
        return cls(nominal, tuple(lo), tuple(hi))

    @property
    def declared(self) -> bool:
        """Some parameter is uncertain."""
        return any(a < 1.0 or b > 1.0 for a, b in zip(self.lo, self.hi))

    def moving(self) -> tuple[str, ...]:
        """The coefficients the box moves: a range wider than a point on a nonzero nominal value.

        A multiplier of a zero coefficient (the BlueROV2's linear sway and yaw damping) leaves it
        zero, so advice never asks to narrow its range.
        """
        return tuple(
            name
            for name, a, b in zip(PARAMETERS, self.lo, self.hi)
            if (a < 1.0 or b > 1.0) and float(getattr(self.nominal, name)) != 0.0
        )

    @property
    def max_scale(self) -> float:
        """Largest scale for :meth:`scaled` that keeps every multiplier >= :data:`MIN_MULTIPLIER`."""
        caps = [(1.0 - MIN_MULTIPLIER) / (1.0 - a) for a in self.lo if a < 1.0]
        return min(caps) if caps else math.inf

    def scaled(self, s: float) -> ParameterBox:
        """The box scaled by ``s >= 0`` about the nominal: ``lo -> 1 - s (1 - lo)``, ``hi -> 1 + s (hi - 1)``.

        Parameters
        ----------
        s : float
            Scale (dimensionless), in ``[0, max_scale]``.
        """
        if not (0.0 <= s <= self.max_scale):
            raise ParameterError(f"box scale must be in [0, {self.max_scale:g}], got {s!r}")
        return ParameterBox(
            self.nominal,
            tuple(1.0 - s * (1.0 - a) for a in self.lo),
            tuple(1.0 + s * (b - 1.0) for b in self.hi),
        )

    def interval(self, name: str) -> tuple[float, float]:
        """Absolute ``[min, max]`` of parameter ``name`` in the box (SI units).

        Parameters
        ----------
        name : str
            One of :data:`PARAMETERS`.
        """
        k = PARAMETERS.index(name)
        v = float(getattr(self.nominal, name))
        return v * self.lo[k], v * self.hi[k]

    def spread(self, name: str, about: VehicleParams | None = None) -> float:
        """``max |p - p_hat|`` of parameter ``name`` over the box (SI units).

        Parameters
        ----------
        name : str
            One of :data:`PARAMETERS`.
        about : VehicleParams, optional
            The parameters ``p_hat`` is taken from (default: the box's nominal; a cell of a
            larger box is centred elsewhere than the controller's model).
        """
        lo, hi = self.interval(name)
        v = float(getattr(self.nominal if about is None else about, name))
        return max(v - lo, hi - v)

    def plant(self, multipliers: FloatArray) -> VehicleParams:
        """The plant with the nine given multipliers of the nominal parameters.

        Parameters
        ----------
        multipliers : ndarray, shape (9,)
            Multipliers of the :data:`PARAMETERS`, in that order (dimensionless).
        """
        m = np.asarray(multipliers, dtype=float)
        values = {n: float(getattr(self.nominal, n)) * float(x) for n, x in zip(PARAMETERS, m)}
        return VehicleParams(**values, name=f"{self.nominal.name} (perturbed)")

    def vertices(self, names: tuple[str, ...] = PARAMETERS) -> FloatArray:
        """Multipliers ``(V, 9)`` of every corner over the uncertain parameters among ``names``.

        Parameters
        ----------
        names : tuple of str
            Parameters whose ranges give corners; the others stay at 1.
        """
        axes = [
            (self.lo[k], self.hi[k]) if (n in names and self.lo[k] < self.hi[k]) else (1.0,)
            for k, n in enumerate(PARAMETERS)
        ]
        return np.array(list(itertools.product(*axes)), dtype=float)

    def dm_range(self) -> tuple[float, float]:
        """Range of ``dM = (m22_hat - m11_hat) - (m22 - m11)`` (kg): affine, so exact."""
        m11, m22 = self.nominal.m11, self.nominal.m22
        lo11, hi11 = self.lo[0], self.hi[0]
        lo22, hi22 = self.lo[1], self.hi[1]
        return m22 * (1.0 - hi22) - m11 * (1.0 - lo11), m22 * (1.0 - lo22) - m11 * (1.0 - hi11)

    def input_gain(self) -> tuple[float, float]:
        """Centre and radius of the eigenvalues ``m_jj_hat/m_jj`` of ``L`` (dimensionless)."""
        lam_min = min(1.0 / self.hi[0], 1.0 / self.hi[1])
        lam_max = max(1.0 / self.lo[0], 1.0 / self.lo[1])
        return 0.5 * (lam_max + lam_min), 0.5 * (lam_max - lam_min)


def _norm2x2(m: FloatArray) -> FloatArray:
    """Spectral norms of a stack ``(..., 2, 2)`` in closed form."""
    fro2 = (m**2).sum(axis=(-2, -1))
    det = m[..., 0, 0] * m[..., 1, 1] - m[..., 0, 1] * m[..., 1, 0]
    out: FloatArray = np.sqrt(0.5 * (fro2 + np.sqrt(np.maximum(fro2**2 - 4.0 * det**2, 0.0))))
    return out


def _quotient(num: tuple[float, float], den: tuple[float, float]) -> tuple[float, float]:
    """Range of ``a/b`` for ``a >= 0`` in ``num`` and ``b > 0`` in ``den``."""
    return num[0] / den[1], num[1] / den[0]


def box_blocks(box: ParameterBox, envelope: Envelope) -> FloatArray:
    """Vertex matrices ``(V, 2, 2)`` whose convex hull holds the body block ``B`` of every plant.

    ``B = [[-(a1 + b1 |u|), rho1 r], [rho2 r, -(a2 + b2 |v|)]]`` with ``a1 = d11_lin/m11``,
    ``b1 = d11_quad/m11`` (likewise ``a2, b2``), ``rho1 = m22/m11 - 1``, ``rho2 = 1 - m11/m22``;
    each entry is multi-affine in the nine quantities, which range independently over their
    exact intervals (ignoring their coupling through the masses only enlarges the set).
    A convex function of ``B`` is then convex in each quantity separately, so its maximum over
    the box is at one of these vertices.

    Parameters
    ----------
    box : ParameterBox
        The plant parameters.
    envelope : Envelope
        Operating envelope (its ``u``, ``v`` and ``r`` ranges).
    """
    m11, m22 = box.interval("m11"), box.interval("m22")
    a1, b1 = _quotient(box.interval("d11_lin"), m11), _quotient(box.interval("d11_quad"), m11)
    a2, b2 = _quotient(box.interval("d22_lin"), m22), _quotient(box.interval("d22_quad"), m22)
    rho1 = (m22[0] / m11[1] - 1.0, m22[1] / m11[0] - 1.0)
    rho2 = (1.0 - m11[1] / m22[0], 1.0 - m11[0] / m22[1])
    au, av = abs_range(*envelope.u), abs_range(*envelope.v)
    v = np.array(list(itertools.product(a1, b1, au, a2, b2, av, envelope.r, rho1, rho2)))
    blocks = np.empty((len(v), 2, 2))
    blocks[:, 0, 0] = -(v[:, 0] + v[:, 1] * v[:, 2])
    blocks[:, 0, 1] = v[:, 7] * v[:, 6]
    blocks[:, 1, 0] = v[:, 8] * v[:, 6]
    blocks[:, 1, 1] = -(v[:, 3] + v[:, 4] * v[:, 5])
    return blocks


def box_sigma(box: ParameterBox, envelope: Envelope, lam: float) -> float:
    """Certified ``sup ||G - lam I||`` (1/s) over every plant of ``box`` and the envelope.

    ``||R B R^T - lam I|| = ||B - lam I||`` and the norm is convex in ``B``, so the maximum over
    the vertices of :func:`box_blocks` bounds it (exact for a degenerate box, where it equals
    the nominal vehicle sigma).

    Parameters
    ----------
    box : ParameterBox
        The plant parameters.
    envelope : Envelope
        Operating envelope.
    lam : float
        Centre lambda (1/s).
    """
    blocks = box_blocks(box, envelope) - lam * np.eye(2)
    return float(_norm2x2(blocks).max()) * (1.0 + SIGMA_ROUNDOFF_RTOL)


def box_lambda(box: ParameterBox, envelope: Envelope) -> tuple[float, float]:
    """Centre ``lam`` (1/s) minimising :func:`box_sigma`, and that sigma.

    ``box_sigma`` is convex in ``lam`` (a maximum of norms of affine functions); the minimiser is
    found by bounded scalar search between the extreme diagonal entries. Whatever ``lam`` it
    returns, the sigma reported is the vertex bound at that ``lam``, so it is sound.

    Parameters
    ----------
    box : ParameterBox
        The plant parameters.
    envelope : Envelope
        Operating envelope.
    """
    blocks = box_blocks(box, envelope)
    diag = blocks[:, [0, 1], [0, 1]]
    lo, hi = float(diag.min()), float(diag.max())
    if hi - lo <= 0.0:
        return lo, box_sigma(box, envelope, lo)
    res = minimize_scalar(lambda x: float(_norm2x2(blocks - x * np.eye(2)).max()), bounds=(lo, hi), method="bounded")
    lam = float(res.x)
    return lam, box_sigma(box, envelope, lam)


@dataclass(frozen=True)
class TubeSummary:
    """Global extremes of a reference tube used by the robust bounds.

    Attributes
    ----------
    speed : tuple of float
        ``[min, max]`` of the desired ground speed ``S`` (m/s).
    offset : tuple of float
        ``[min, max]`` of the heading offset ``delta`` (rad).
    yaw_rate, accel, yaw_accel : float
        ``max |psi_d'|`` (rad/s), ``max |p_d''|`` (m/s^2), ``max |psi_d''|`` (rad/s^2).
    """

    speed: tuple[float, float]
    offset: tuple[float, float]
    yaw_rate: float
    accel: float
    yaw_accel: float

    @classmethod
    def of(cls, tube: ReferenceTube) -> TubeSummary:
        """Summary of every cell of ``tube``.

        Parameters
        ----------
        tube : ReferenceTube
            The tube.
        """
        return cls(
            (float(tube.speed[:, 0].min()), float(tube.speed[:, 1].max())),
            (float(tube.offset[:, 0].min()), float(tube.offset[:, 1].max())),
            float(np.abs(tube.yaw_rate).max()),
            float(tube.accel.max()),
            float(tube.yaw_accel.max()),
        )


def _abs_sin_max(lo: float, hi: float) -> float:
    c_lo, c_hi = cos_range(np.array(lo - 0.5 * math.pi), np.array(hi - 0.5 * math.pi))
    return float(max(abs(float(c_lo)), abs(float(c_hi))))


def _product_range(*intervals: tuple[float, float]) -> tuple[float, float]:
    """Exact range of a product of independent intervals (its extremes are at endpoints)."""
    vals = [math.prod(p) for p in itertools.product(*intervals)]
    return min(vals), max(vals)


def current_offset(box: ParameterBox, lam: float, current: float, k1: float) -> float:
    """``|e_c| = |lam| c_max/(l k1)`` (m): the shift of the equilibrium by the constant part of ``-G c``.

    Parameters
    ----------
    box : ParameterBox
        The plant parameters; ``l`` is the centre of its input gain.
    lam : float
        Centre lambda (1/s).
    current : float
        Largest current speed ``c_max`` (m/s).
    k1 : float
        Position gain (1/s^2).
    """
    return abs(lam) * current / (box.input_gain()[0] * k1)


def position_disturbance(
    box: ParameterBox,
    envelope: Envelope,
    tube: TubeSummary,
    current: float,
    heading: float,
    lam: float,
    sigma: float,
) -> float:
    """Bound of ``|d~|`` (m/s^2) while ``|e_psi| <= heading`` (rad) and the state is in the envelope.

    The loop is written about the shifted error ``e~ = e - e_c``, ``e_c = -lam c/(l k1)``, which
    absorbs the constant part ``-lam c`` of ``-G c = -lam c - D c`` (``||D|| <= sigma``). Then
    ``|d~| <= |(G - L G_hat) p_d'| + sigma c_max + delta |lam| c_max/l + |(L - I) p_d''|`` with
    ``|(G - L G_hat) p_d'| <= S_max sqrt(x^2 + y^2)``,
    ``x = (|dd11| + |dm| r_max s)/m11_min``, ``y = (|dm| r_max + |dd22| s)/m22_min``,
    ``s = max |sin theta|`` over ``theta`` in ``[delta_min - E, delta_max + E]`` and
    ``|(L - I) p_d''| <= max |m_jj_hat/m_jj - 1| a_max``.

    Parameters
    ----------
    box : ParameterBox
        The plant parameters.
    envelope : Envelope
        Operating envelope.
    tube : TubeSummary
        Extremes of the reference tube.
    current : float
        Largest current speed ``c_max`` (m/s).
    heading : float
        Bound ``E`` of the heading error (rad).
    lam : float
        Centre lambda (1/s).
    sigma : float
        Bound of ``||G - lam I||`` over box and envelope (1/s).
    """
    r_max = abs_range(*envelope.r)[1]
    u_max, v_max = abs_range(*envelope.u)[1], abs_range(*envelope.v)[1]
    dd11 = box.spread("d11_lin") + box.spread("d11_quad") * u_max
    dd22 = box.spread("d22_lin") + box.spread("d22_quad") * v_max
    dm = max(abs(x) for x in box.dm_range())
    s = _abs_sin_max(tube.offset[0] - heading, tube.offset[1] + heading)
    x = (dd11 + dm * r_max * s) / box.interval("m11")[0]
    y = (dm * r_max + dd22 * s) / box.interval("m22")[0]
    mismatch = tube.speed[1] * math.hypot(x, y)
    centre, spread = box.input_gain()
    drift = (sigma + spread * abs(lam) / centre) * current
    gain = max(abs(1.0 / end[k] - 1.0) for end in (box.lo, box.hi) for k in (0, 1))
    return mismatch + drift + gain * tube.accel


@dataclass(frozen=True)
class HeadingPerturbation:
    """Coefficient ranges and disturbance bound of the perturbed heading loop.

    Attributes
    ----------
    stiffness : tuple of float
        ``[min, max]`` of ``K(t)`` (1/s^2).
    damping : tuple of float
        ``[min, max]`` of ``C(t)`` (1/s).
    disturbance : float
        Bound of ``|h(t)|`` (rad/s^2).
    """

    stiffness: tuple[float, float]
    damping: tuple[float, float]
    disturbance: float


def heading_perturbation(
    box: ParameterBox,
    envelope: Envelope,
    tube: TubeSummary,
    k_psi: tuple[float, float],
    current: float,
    velocity: float,
    heading: float,
) -> HeadingPerturbation:
    """Sound ranges of ``K``, ``C`` and ``|h|`` while ``||e'|| <= velocity``, ``|e_psi| <= heading``.

    With ``W = velocity + current`` (m/s), ``u v = -S^2 sin(2 theta)/2 + S (w2 cos - w1 sin) + w1 w2``,
    ``|w| <= W``; ``sin 2 theta = sin 2 delta + 2 e_psi g`` with ``g`` in the exact ``cos`` range
    of ``[2 delta_min - 2 E, 2 delta_max + 2 E]`` (mean value theorem). Then
    ``K = (m33_hat k1psi + dM S^2 g)/m33``, ``C = (m33_hat k2psi + d33(r))/m33`` and
    ``|h| <= |m33_hat/m33 - 1| psi_d''_max + |dd33| psi_d'_max/m33_min
    + |dM| (S_max^2 |sin 2 delta|_max / 2 + S_max W + W^2/2)/m33_min``.

    Parameters
    ----------
    box : ParameterBox
        The plant parameters.
    envelope : Envelope
        Operating envelope (its ``r`` range).
    tube : TubeSummary
        Extremes of the reference tube.
    k_psi : tuple of float
        Heading gains ``(k1psi, k2psi)`` (1/s^2, 1/s).
    current : float
        Largest current speed (m/s).
    velocity : float
        Bound of the velocity error ``||e'||`` (m/s).
    heading : float
        Bound ``E`` of the heading error (rad).
    """
    m33_hat = box.nominal.m33
    m33 = box.interval("m33")
    inv33 = (1.0 / m33[1], 1.0 / m33[0])
    g = cos_range(np.array(2.0 * (tube.offset[0] - heading)), np.array(2.0 * (tube.offset[1] + heading)))
    dm = box.dm_range()
    s2 = (tube.speed[0] ** 2, tube.speed[1] ** 2)
    munk = _product_range(dm, s2, (float(g[0]), float(g[1])))
    num_k = (m33_hat * k_psi[0] + munk[0], m33_hat * k_psi[0] + munk[1])
    stiffness = _product_range(num_k, inv33)
    r_lo, r_hi = abs_range(*envelope.r)
    d33l, d33q = box.interval("d33_lin"), box.interval("d33_quad")
    num_c = (m33_hat * k_psi[1] + d33l[0] + d33q[0] * r_lo, m33_hat * k_psi[1] + d33l[1] + d33q[1] * r_hi)
    damping = _product_range(num_c, inv33)
    w = velocity + current
    dm_max = max(abs(x) for x in dm)
    sin2 = _abs_sin_max(2.0 * tube.offset[0], 2.0 * tube.offset[1])
    mu = max(abs(m33_hat * x - 1.0) for x in inv33)
    dd33 = box.spread("d33_lin") + box.spread("d33_quad") * r_hi
    h = (
        mu * tube.yaw_accel
        + dd33 * tube.yaw_rate * inv33[1]
        + dm_max * (0.5 * s2[1] * sin2 + tube.speed[1] * w + 0.5 * w * w) * inv33[1]
    )
    return HeadingPerturbation(stiffness, damping, h)


__all__ = [
    "MIN_MULTIPLIER",
    "PARAMETERS",
    "SIGMA_ROUNDOFF_RTOL",
    "HeadingPerturbation",
    "ParameterBox",
    "TubeSummary",
    "box_blocks",
    "box_lambda",
    "box_sigma",
    "current_offset",
    "heading_perturbation",
    "position_disturbance",
]
