"""The error loops of the deployed law on every plant of the box, and bounds of what drives them.

One vehicle runs the law of :class:`~auv_hinf.law.formation_law.VehicleLaw` on its own slot
path ``p_d(t)``, sampled and delayed as declared (at ``t_k = k h`` the law acts on the
measurement taken at ``t_k - d`` and its command is held until ``t_{k+1}``,
:mod:`auv_hinf.implementation.model`), on a plant anywhere in the ``[uncertainty]`` box, in a
current ``|c| <= C``. The derivation is in ``docs/derivations/composed.md``; in short, with
``e = p - p_d``, ``e' = p' - p_d'`` (ground), the water-relative body velocity ``nu = R^T (p' - c)``
and ``nu_d = R^T (p_d' - c)``, the position error in the desired heading's frame ``epsilon =
R(psi_d)^T e`` and the velocity error in the body frame ``eta = R^T e' = nu - nu_d``:

* **Mean value in the drag.** The plant's body acceleration ``B(nu, r) nu`` and the law's drift
  compensation ``Lambda B_hat(nu_y) R_y^T p_d'`` differ from their values at ``nu_d`` by
  ``a_j eta_j`` (the plant's own slope, on the present velocity error) and ``lambda_j c_j
  eta_mj`` (the law's slope, on the *measured* one), ``a_j = -(d_lin + d_quad theta)/m_j`` and
  ``c_j = d_quad_hat s p_bj / m_hat_j`` with the mean-value slopes ``theta`` and ``s`` of
  :func:`_slope_ranges`; the coupling between the axes is the body frame's turn ``-r S eta`` and
  the Coriolis terms. Where the speed keeps its sign, ``a_j`` is a steady slope (split into cells)
  plus a curvature whose product with ``eta_j``, ``-sign(x_d) d_quad eta_j^2/m``, keeps one sign
  (:attr:`AxisRanges.curvature`, driven through the one-signed peak gains).
* **The position's turns.** ``epsilon' = R(e_psi) eta - r_d S epsilon``: ``q_e = (R(e_psi) - I) eta -
  r_d S epsilon`` is second order on a straight leg (the heading error times the velocity error),
  and the law's measured body-frame error is ``epsilon`` turned by the heading error and noise.
* **One axis.** ``epsilon' = eta + q_e``, ``eta' = a0 eta + lambda0 (c0 eta_m - F) + w + q``,
  ``F = k1 epsilon_m + alpha eta_m (+ ki z)`` the law's feedback on the measurement, held: the
  nominal loop (:func:`axis_loop`, the middle of every range) is a sampled-data LTI loop whose
  peak-to-peak gains are computed exactly (:mod:`auv_hinf.implementation.peak`); ``q`` gathers
  ``(a - a0) eta + (lambda c - lambda0 c0) eta_m - (lambda - lambda0) F`` and the other axis's
  coupling, each bounded by a range's half-width times a peak the small-gain closes on.
* **What drives it.** ``w`` is the *equilibrium deficit* (what the law's model misses at ``nu =
  nu_d``: drag mismatch, the current's drag, the feed-forward's mass error) plus the residual of
  the lag and the noise (:func:`disturbances`); the measurement errors enter as discrete inputs.
* **Heading.** ``e_psi' = e_r``, ``e_r' = a0 e_r + g0 (c0 e_rm - F_psi) + w_psi + q_psi``
  (:func:`heading_loop`), coupled to the position axes through the Munk moment the law cancels on
  old velocities, and the position axes to it through the drift compensation turned by the
  heading's change over the lag.

Every bound here is a sup over the *operating box* (:class:`OperatingBox`), the body velocities
and yaw rates the vehicle can have while its errors stay within the assumed bounds; the
certificate (:mod:`auv_hinf.composed.certificate`) closes the argument by a verified fixed point
and the first-exit argument.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.implementation.model import Implementation
from auv_hinf.implementation.peak import SampledLoop
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.robust.box import ParameterBox

#: Largest heading error (rad) an operating box may assume: beyond a right angle the desired
#: ground velocity no longer points ahead, and the surge range loses its sign.
MAX_SLIP = 0.5 * math.pi


@dataclass(frozen=True)
class MissionBounds:
    """Sound bounds of one fleet's desired motion for all time (every vehicle's slot path).

    Attributes
    ----------
    speed : tuple of float
        ``[min, max]`` of ``|p_d'|`` (m/s).
    offset : float
        Largest ``|psi_d - atan2(p_d')|`` (rad): 0 on a raw mission.
    yaw_rate : float
        Largest ``|r_d|`` (rad/s).
    accel : float
        Largest ``|p_d''|`` (m/s^2).
    yaw_accel : float
        Largest ``|r_d'|`` (rad/s^2).
    jerk : float
        Largest ``|p_d'''|`` (m/s^3).
    yaw_jerk : float
        Largest ``|r_d''|`` (rad/s^3); ``inf`` when the path does not bound it.
    """

    speed: tuple[float, float]
    offset: float
    yaw_rate: float
    accel: float
    yaw_accel: float
    jerk: float
    yaw_jerk: float = math.inf

    @property
    def straight(self) -> bool:
        """The desired motion keeps its course and speed (a line): body-frame currents are constant."""
        return self.yaw_rate == 0.0 and self.accel == 0.0 and self.offset == 0.0

    @classmethod
    def of(cls, tube: ReferenceTube, jerk: float, yaw_jerk: float = math.inf) -> MissionBounds:
        """The bounds of a :class:`~auv_hinf.mission.fleet.ReferenceTube` (every cell, every vehicle).

        Parameters
        ----------
        tube : ReferenceTube
            Bounds of the desired motion per time cell.
        jerk : float
            Bound of ``|p_d'''|`` (m/s^3).
        yaw_jerk : float
            Bound of ``|r_d''|`` (rad/s^3), ``inf`` when unknown.
        """
        return cls(
            speed=(float(tube.speed[:, 0].min()), float(tube.speed[:, 1].max())),
            offset=float(np.abs(tube.offset).max()),
            yaw_rate=float(np.abs(tube.yaw_rate).max()),
            accel=float(tube.accel.max()),
            yaw_accel=float(tube.yaw_accel.max()),
            jerk=float(jerk),
            yaw_jerk=float(yaw_jerk),
        )


@dataclass(frozen=True)
class Errors:
    """Bounds of one vehicle's errors (the assumption of the fixed point, and its result).

    Attributes
    ----------
    position : float
        ``|p - p_d|`` (m).
    velocity : float
        ``|p' - p_d'|`` (m/s, ground).
    heading : float
        ``|psi - psi_d|`` (rad).
    yaw_rate : float
        ``|r - r_d|`` (rad/s).
    deficit : float
        ``|sigma| = |w_c - L ki z|`` (m/s^2), the integral loop's deficit state (0 without).
    surge, sway : float or None
        Bounds of the velocity error's body-frame components ``|u - u_d|``, ``|v - v_d|`` (m/s);
        ``None``: ``velocity``.
    """

    position: float
    velocity: float
    heading: float
    yaw_rate: float
    deficit: float = 0.0
    surge: float | None = None
    sway: float | None = None

    @property
    def axes(self) -> tuple[float, float]:
        """``(|u - u_d|, |v - v_d|)`` bounds (m/s)."""
        return (
            self.velocity if self.surge is None else min(self.surge, self.velocity),
            self.velocity if self.sway is None else min(self.sway, self.velocity),
        )

    def as_array(self) -> np.ndarray:
        """``(position, velocity, heading, yaw_rate, deficit, surge, sway)``."""
        su, sw = self.axes
        return np.array([self.position, self.velocity, self.heading, self.yaw_rate, self.deficit, su, sw])

    @classmethod
    def from_array(cls, x: np.ndarray) -> Errors:
        """The inverse of :meth:`as_array`.

        Parameters
        ----------
        x : ndarray, shape (7,)
            ``(position, velocity, heading, yaw_rate, deficit, surge, sway)``.
        """
        return cls(*(float(v) for v in x[:7]))

    def to_dict(self) -> dict[str, float]:
        """``{position, velocity, heading, yaw_rate}`` (m, m/s, rad, rad/s)."""
        return {
            "position": self.position,
            "velocity": self.velocity,
            "heading": self.heading,
            "yaw_rate": self.yaw_rate,
        }


@dataclass(frozen=True)
class OperatingBox:
    """What the vehicle's motion can be while its errors stay within :class:`Errors`.

    Body velocities are relative to the water; ``u`` is signed (surge), ``v`` and ``r`` are
    bounded in magnitude. ``p_b = R^T p_d'`` is the desired ground velocity in the body frame
    and ``nu_d = (u_d, v_d) = p_b - R^T c`` its water-relative part; ``nu = nu_d + R^T e'``.

    Attributes
    ----------
    slip : float
        Largest angle between the heading and the desired ground velocity (rad).
    u : tuple of float
        ``[min, max]`` of the surge speed ``u`` (m/s).
    v : float
        Largest ``|v|`` (m/s).
    r : float
        Largest ``|r|`` (rad/s).
    p_bx : tuple of float
        ``[min, max]`` of the desired ground velocity's surge component (m/s).
    p_by : float
        Largest ``|p_by|`` (m/s).
    u_d : tuple of float
        ``[min, max]`` of ``u_d`` (m/s).
    v_d : float
        Largest ``|v_d|`` (m/s).
    ground_speed : tuple of float
        ``[min, max]`` of the desired ground speed ``|p_d'|`` (m/s).
    heading : float
        Largest heading error ``|psi - psi_d|`` (rad).
    """

    slip: float
    u: tuple[float, float]
    v: float
    r: float
    p_bx: tuple[float, float]
    p_by: float
    u_d: tuple[float, float]
    v_d: float
    ground_speed: tuple[float, float]
    heading: float

    @classmethod
    def of(cls, mission: MissionBounds, current: float, errors: Errors) -> OperatingBox:
        """The box of a mission in a current ``|c| <= current`` (m/s) with errors within ``errors``.

        Parameters
        ----------
        mission : MissionBounds
            The desired motion.
        current : float
            Bound of the current's speed (m/s).
        errors : Errors
            Bounds of the errors.
        """
        s_lo, s_hi = mission.speed
        slip = min(mission.offset + errors.heading, MAX_SLIP)
        sway = s_hi * math.sin(slip)
        ahead = s_lo * math.cos(slip)
        du, dv = errors.axes
        u_d = (ahead - current, s_hi + current)
        v_d = sway + current
        return cls(
            slip=slip,
            u=(u_d[0] - du, u_d[1] + du),
            v=v_d + dv,
            r=mission.yaw_rate + errors.yaw_rate,
            p_bx=(ahead, s_hi),
            p_by=sway,
            u_d=u_d,
            v_d=v_d,
            ground_speed=(s_lo, s_hi),
            heading=errors.heading,
        )

    @property
    def speed(self) -> float:
        """Largest ``|nu|`` (m/s)."""
        return math.hypot(max(abs(self.u[0]), abs(self.u[1])), self.v)

    def margins(self, envelope: Envelope) -> dict[str, float]:
        """Margin (m/s, rad/s) of each side of the box inside ``envelope`` (negative: outside).

        Parameters
        ----------
        envelope : Envelope
            The declared envelope.
        """
        return envelope.box_margins(self.u, self.v, self.r)

    def within(self, envelope: Envelope) -> bool:
        """The box lies inside ``envelope`` (every margin ``>= 0``).

        Parameters
        ----------
        envelope : Envelope
            The declared envelope.
        """
        return min(self.margins(envelope).values()) >= 0.0

    def to_dict(self) -> dict[str, float]:
        """``{u_min, u_max, v_max, r_max}`` (m/s, rad/s): the envelope the certificate needs."""
        return {"u_min": self.u[0], "u_max": self.u[1], "v_max": self.v, "r_max": self.r}


def _slope_ranges(desired: tuple[float, float], width: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Ranges of ``theta = (|x| x - |y| y)/(x - y)`` and ``s = (|x| - |y|)/(x - y)``.

    ``y`` in ``desired``, ``|x - y| <= width``.

    When ``x`` and ``y`` keep one sign, ``theta = |x| + |y| = 2 |y| + (|x| - |y|)`` and ``s`` is the
    sign; otherwise ``0 <= theta <= |x| + |y|`` and ``|s| <= 1``.
    """
    lo, hi = desired
    top = max(abs(lo), abs(hi))
    if lo - width > 0.0:
        return (2.0 * lo - width, 2.0 * hi + width), (1.0, 1.0)
    if hi + width < 0.0:
        return (2.0 * abs(hi) - width, 2.0 * abs(lo) + width), (-1.0, -1.0)
    return (0.0, 2.0 * top + width), (-1.0, 1.0)


def _ratio_range(num: tuple[float, float], den: tuple[float, float]) -> tuple[float, float]:
    """Range of ``x / y`` for ``x`` in ``num`` and ``y > 0`` in ``den``."""
    values = [n / d for n in num for d in den]
    return min(values), max(values)


@dataclass(frozen=True)
class Plant:
    """The controller's model, the declared box around it and the current: what the loops depend on.

    Attributes
    ----------
    model : VehicleParams
        The controller's parameters (the hats).
    box : ParameterBox
        The plants (:class:`~auv_hinf.robust.box.ParameterBox`; exact when nothing is declared).
    current : float
        Bound of the current's speed (m/s).
    current_rate : float
        Bound of ``|c'|`` (m/s^2); 0 for a constant current.
    """

    model: VehicleParams
    box: ParameterBox
    current: float = 0.0
    current_rate: float = 0.0

    def interval(self, name: str) -> tuple[float, float]:
        """``[min, max]`` of a plant coefficient over the box (SI units).

        Parameters
        ----------
        name : str
            One of :data:`~auv_hinf.robust.box.PARAMETERS`.
        """
        return self.box.interval(name)

    def spread(self, name: str) -> float:
        """``max |p - p_hat|`` of a coefficient over the box (SI units), against the model's ``p_hat``.

        The box may be a cell of a larger one, centred elsewhere (its own nominal plant).

        Parameters
        ----------
        name : str
            One of :data:`~auv_hinf.robust.box.PARAMETERS`.
        """
        return self.box.spread(name, self.model)

    def input_gains(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Ranges of ``lambda_j = m_jj_hat/m_jj`` on the surge and sway axes (dimensionless)."""
        m11, m22 = self.interval("m11"), self.interval("m22")
        return (self.model.m11 / m11[1], self.model.m11 / m11[0]), (self.model.m22 / m22[1], self.model.m22 / m22[0])

    def input_gain_range(self) -> tuple[float, float]:
        """Range of ``lambda_j`` over both horizontal axes (dimensionless)."""
        (a, b), (c, d) = self.input_gains()
        return min(a, c), max(b, d)

    def heading_gains(self) -> tuple[float, float]:
        """Range of ``g = m33_hat/m33`` (dimensionless)."""
        return _ratio_range((self.model.m33, self.model.m33), self.interval("m33"))

    def munk(self) -> tuple[float, float]:
        """Range of ``m22 - m11`` (kg) over the box."""
        m11, m22 = self.interval("m11"), self.interval("m22")
        return m22[0] - m11[1], m22[1] - m11[0]

    def coriolis(self) -> float:
        """Largest ``|rho1|, |rho2|`` (``m22/m11 - 1``, ``1 - m11/m22``; dimensionless) over the box."""
        m11, m22 = self.interval("m11"), self.interval("m22")
        rho1 = [b / a - 1.0 for a in m11 for b in m22]
        rho2 = [1.0 - a / b for a in m11 for b in m22]
        return max(abs(x) for x in rho1 + rho2)

    def damping(self, axis: str, speed: float) -> tuple[float, float]:
        """``[min, max]`` of ``d(x) = d_lin + d_quad |x|`` over the box at ``|x| <= speed`` (kg/s or kg m^2/s).

        Parameters
        ----------
        axis : {"11", "22", "33"}
            Surge, sway or yaw.
        speed : float
            Largest ``|x|`` (m/s or rad/s); the minimum is taken at ``x = 0``.
        """
        lin, quad = self.interval(f"d{axis}_lin"), self.interval(f"d{axis}_quad")
        return lin[0], lin[1] + quad[1] * speed

    def damping_mismatch(self, axis: str, speed: float) -> float:
        """Largest ``|d_hat(x) - d(x)|`` over the box at ``|x| <= speed`` (kg/s or kg m^2/s).

        Parameters
        ----------
        axis : {"11", "22", "33"}
            Surge, sway or yaw.
        speed : float
            Largest ``|x|``.
        """
        return self.spread(f"d{axis}_lin") + self.spread(f"d{axis}_quad") * speed


#: Largest width (1/s) of a cell of a loop's constant damping (its trim): every cell's nominal loop
#: is computed, so narrower cells cost time and leave less to the small gain.
CELL_WIDTH = 1.0
#: Most cells a loop's trim is split into.
MAX_CELLS = 8


@dataclass(frozen=True)
class AxisRanges:
    """The ranges of one loop axis's plant quantities, their nominal values and half-widths.

    Attributes
    ----------
    damping : tuple of float
        ``a``: the plant's own slope on the present velocity error (1/s).
    compensation : tuple of float
        ``c``: the law's drift-compensation slope on the measured velocity error (1/s, the law's
        own mass).
    gain : tuple of float
        ``lambda``: the multiple of the law's commands the plant applies (``m_hat/m``).
    cells : tuple of (float, float)
        Sub-ranges of ``a`` that cover it: a constant plant in a constant current on a straight
        mission holds its trim ``-(d_lin + 2 d_quad |x_d|)/m`` but for the heading error's turn of
        the body frame, so it lies in one cell for ever (the time-varying part and that turn are in
        every cell); each cell gets its own nominal loop.
    residual : float or None
        When set, the axis's drag is not a slope perturbation but a residual: the one cell is the
        nominal slope itself, and ``residual`` bounds ``|f(y + eta) - f(y) - a0 eta|``
        (:func:`drag_residual`; m/s^2 or rad/s^2), a direct term of the perturbation channel.
    curvature : float
        When the speed keeps its sign, the cells hold the drag's steady slope only, and its
        quadratic part ``-sign(x_d) d_quad eta^2/m`` is a perturbation of one sign, at most
        ``curvature |eta|`` (1/s; :func:`_damping`); 0 otherwise.
    """

    damping: tuple[float, float]
    compensation: tuple[float, float]
    gain: tuple[float, float]
    cells: tuple[tuple[float, float], ...] = ()
    residual: float | None = None
    curvature: float = 0.0

    @property
    def parts(self) -> tuple[tuple[float, float], ...]:
        """The cells of ``a`` (the whole range when none were made)."""
        return self.cells or (self.damping,)

    def nominal(self, cell: int = 0) -> tuple[float, float, float]:
        """``(a0, c0, lambda0)`` of a cell: the middle of each range.

        Parameters
        ----------
        cell : int
            Index into :attr:`parts`.
        """
        lo, hi = self.parts[cell]
        return 0.5 * (lo + hi), 0.5 * sum(self.compensation), 0.5 * sum(self.gain)

    @property
    def deviations(self) -> tuple[float, float, float]:
        """``(|a - a0|, |lambda c - lambda0 c0|, |lambda - lambda0|)`` at most, in any cell."""
        _, c0, g0 = self.nominal()
        lc = max(abs(g * c - g0 * c0) for g in self.gain for c in self.compensation)
        da = max(0.5 * (hi - lo) for lo, hi in self.parts)
        return da, lc, 0.5 * (self.gain[1] - self.gain[0])


#: Points of the grid of the velocity error on which :func:`drag_residual` evaluates the residual;
#: between them it moves by at most its Lipschitz constant times half the spacing, which is added.
RESIDUAL_GRID = 2001
#: Iterations of the golden-section search of the nominal slope (the residual is convex in it): the
#: bracket shrinks to 0.618^24, about 1e-5 of the slope range.
RESIDUAL_SEARCH = 24


#: Grids of :func:`_residual_terms` kept (each about 0.6 MB: 8 box vertices, 5 candidates, the grid): a
#: golden-section search reads one grid 26 times, and a round asks for a few.
RESIDUAL_TERMS_CACHE = 16


def drag_residual(plant: Plant, axis: str, desired: tuple[float, float], width: float, a0: float) -> float:
    """``sup |f(y + eta) - f(y) - a0 eta|`` over the box, ``y`` in ``desired``, ``|eta| <= width`` (m/s^2 or rad/s^2).

    ``f(x) = -(d_lin x + d_quad |x| x)/m`` is the plant's drag acceleration on the axis; the
    residual is what the loop with the constant slope ``a0`` leaves out. The function is
    multilinear in ``(d_lin, d_quad, 1/m)``, so its extremes over the box are at the vertices. For
    fixed ``eta`` and signs of ``y`` and ``y + eta`` it is affine in ``y`` (same signs) or a
    quadratic with its vertex at ``y = -eta/2`` (opposite signs): its supremum over ``y`` is at
    ``y`` in ``{lo, hi, 0, -eta, -eta/2}`` (clipped). Over ``eta`` it is evaluated on a grid of
    :data:`RESIDUAL_GRID` points, plus the Lipschitz bound of the step between them.

    Parameters
    ----------
    plant : Plant
        Model and box.
    axis : {"22", "33", "11"}
        The axis (sway, yaw or surge).
    desired : tuple of float
        ``[min, max]`` of ``y``, the desired water-relative speed (m/s or rad/s).
    width : float
        Bound of ``|eta|`` (m/s or rad/s).
    a0 : float
        The nominal loop's slope (1/s).
    """
    drag, eta, lipschitz, step = _residual_terms(plant, axis, desired, width)
    worst = float(np.abs(drag - a0 * eta).max())
    # between grid points: |dg/deta| <= (d_lin + 2 d_quad (|y| + width))/m + |a0|
    return worst + 0.5 * (lipschitz + abs(a0)) * step


@functools.lru_cache(maxsize=RESIDUAL_TERMS_CACHE)
def _residual_terms(
    plant: Plant, axis: str, desired: tuple[float, float], width: float
) -> tuple[FloatArray, FloatArray, float, float]:
    """What :func:`drag_residual` evaluates for every nominal slope: the drag's increment ``f(y + eta) - f(y)``
    at every box vertex, candidate ``y`` and grid point; the grid; the increment's Lipschitz constant in
    ``eta`` (without the slope's own); and the grid's step."""
    lins, quads, masses = plant.interval(f"d{axis}_lin"), plant.interval(f"d{axis}_quad"), plant.interval(f"m{axis}")
    lo, hi = desired
    eta = np.linspace(-width, width, RESIDUAL_GRID)
    cands = np.stack([np.full_like(eta, lo), np.full_like(eta, hi), np.zeros_like(eta), -eta, -0.5 * eta])
    ys = np.clip(cands, lo, hi)
    x = ys + eta
    sq = np.abs(x) * x - np.abs(ys) * ys  # |x| x - |y| y
    # |g| is largest at a vertex: for each (d_lin/m, d_quad/m) vertex the largest |g| over the grid
    vertices = np.array([(dl / m, dq / m) for dl, dq, m in itertools.product(lins, quads, masses)])
    drag = -vertices[:, 0, None, None] * eta - vertices[:, 1, None, None] * sq[None]
    top = max(abs(lo), abs(hi))
    lipschitz = (lins[1] + 2.0 * quads[1] * (top + width)) / masses[0]
    return drag, eta, lipschitz, 2.0 * width / (RESIDUAL_GRID - 1)


@functools.lru_cache(maxsize=1024)
def residual_nominal(
    plant: Plant, axis: str, desired: tuple[float, float], width: float, slopes: tuple[float, float]
) -> tuple[float, float]:
    """The nominal slope in ``slopes`` with the least :func:`drag_residual`, and that residual.

    The residual is a supremum of absolute values of affine functions of ``a0``, so convex: a
    golden-section search over :data:`RESIDUAL_SEARCH` steps finds its least value; the residual
    returned is the one evaluated at the slope returned.

    Parameters
    ----------
    plant : Plant
        Model and box.
    axis : str
        The axis.
    desired : tuple of float
        ``[min, max]`` of the desired speed.
    width : float
        Bound of the velocity error.
    slopes : tuple of float
        The range of the mean-value slope, which brackets the best nominal slope.
    """
    a, b = slopes
    ratio = 0.5 * (math.sqrt(5.0) - 1.0)
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = drag_residual(plant, axis, desired, width, c), drag_residual(plant, axis, desired, width, d)
    for _ in range(RESIDUAL_SEARCH):
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - ratio * (b - a)
            fc = drag_residual(plant, axis, desired, width, c)
        else:
            a, c, fc = c, d, fd
            d = a + ratio * (b - a)
            fd = drag_residual(plant, axis, desired, width, d)
    best = c if fc <= fd else d
    return best, min(fc, fd)


def _quotient_range(nums: list[float], masses: tuple[float, float]) -> tuple[float, float]:
    values = [x / m for x in nums for m in masses]
    return min(values), max(values)


def _damping(
    plant: Plant, axis: str, desired: tuple[float, float], width: float, drift: float | None
) -> tuple[tuple[float, float], tuple[tuple[float, float], ...], float]:
    """Range of ``a = -(d_lin + d_quad theta)/m``, its cells and its curvature (see :class:`AxisRanges`).

    ``x_d`` in ``desired``, ``|x - x_d| <= width``. The first value is the whole range of the
    mean-value slope. When ``x`` may change sign (``desired`` widened by ``width`` holds 0) that is
    all: :func:`_axis` takes the drag's residual instead, and there are no cells and no curvature.

    Otherwise ``x`` keeps the sign of ``x_d`` and ``theta = 2 |x_d| + tw`` with ``tw = |x| - |x_d| =
    sign(x_d) eta``: the slope's part ``-d_quad tw/m`` times ``eta`` is ``-sign(x_d) d_quad eta^2/m``,
    which keeps one sign. Its coefficient's bound, ``d_quad,max width/m_min``, is the curvature (the
    certificate drives the loop with it through the one-signed gains); the cells split the *steady*
    slope ``-(d_lin + 2 d_quad |x_d|)/m`` alone. On a straight mission in a constant current that is
    one plant's trim, which moves only as the heading error turns the body frame: ``|x_d|`` stays
    within ``drift`` of its value at the start (:func:`trim_drift`), so the trim within ``2 d_quad
    drift/m``, and a cell of start trims ``[t_k, t_k+1]`` is widened by that. ``drift`` is ``None``
    when the trim is not held (turns, a varying current): the one cell is the steady slope's range.
    """
    lins, quads, masses = plant.interval(f"d{axis}_lin"), plant.interval(f"d{axis}_quad"), plant.interval(f"m{axis}")

    def slopes(thetas: tuple[float, float]) -> tuple[float, float]:
        return _quotient_range([-dl - dq * th for dl in lins for dq in quads for th in thetas], masses)

    whole = slopes(_slope_ranges(desired, width)[0])
    if desired[0] - width <= 0.0 <= desired[1] + width:
        return whole, (), 0.0
    curvature = quads[1] * width / masses[0]
    steady = slopes(_slope_ranges(desired, 0.0)[0])
    if drift is None:
        return whole, (steady,), curvature
    lo, hi = desired
    mags = (min(abs(lo), abs(hi)), max(abs(lo), abs(hi)))
    trim = _quotient_range([-dl - 2.0 * dq * x for dl in lins for dq in quads for x in mags], masses)
    wobble = quads[1] * 2.0 * drift / masses[0]
    count = min(MAX_CELLS, max(1, math.ceil((trim[1] - trim[0]) / CELL_WIDTH)))
    edges = np.linspace(trim[0], trim[1], count + 1)
    cells = tuple(
        (max(float(t_lo) - wobble, steady[0]), min(float(t_hi) + wobble, steady[1]))
        for t_lo, t_hi in itertools.pairwise(edges)
    )
    return whole, cells, curvature


def turn_bounds(angle: float) -> tuple[float, float]:
    """Per-axis bounds of a turn by at most ``angle`` (rad): ``(max |1 - cos t|, max |sin t|)`` over ``|t| <= angle``.

    ``R(t) x - x`` has components ``(cos t - 1) x_j -+ sin t x_other``, so each is at most the first
    value times ``|x_j|`` plus the second times ``|x_other|``. The first grows up to ``t = pi`` (to 2),
    the second up to ``t = pi/2`` (to 1).

    Parameters
    ----------
    angle : float
        Bound of the turn's angle (rad, nonnegative).
    """
    return 1.0 - math.cos(min(angle, math.pi)), math.sin(min(angle, 0.5 * math.pi))


def trim_drift(op: OperatingBox, current: float) -> tuple[float, float]:
    """How far ``|u_d|`` and ``|v_d|`` of one plant in one constant current move on a straight mission (m/s).

    On a line ``w = R(psi_d)^T (p_d' - c)`` is constant, with ``|w_x| <= U + C`` and ``|w_y| <= C``
    (the desired ground velocity is along the course), and ``nu_d = R(e_psi)^T w`` turns with the
    heading error ``|e_psi| <= E`` (the operating box's slip): ``u_d = w_x cos e_psi + w_y sin
    e_psi`` moves by at most ``|w_x| (1 - cos E) + 2 |w_y| sin E``, and ``v_d`` by at most
    ``2 |w_x| sin E + |w_y| (1 - cos E)``.

    Parameters
    ----------
    op : OperatingBox
        The operating box (its slip and the desired ground speed ``U``).
    current : float
        Bound ``C`` of the current's speed (m/s).
    """
    big, small = op.ground_speed[1] + current, current
    turn, tilt = turn_bounds(op.slip)
    return big * turn + 2.0 * small * tilt, 2.0 * big * tilt + small * turn


def position_axes(
    plant: Plant, op: OperatingBox, heading_noise: float, straight: bool = False
) -> tuple[AxisRanges, AxisRanges]:
    """The surge and sway axes' ranges of ``a``, ``c`` and ``lambda`` (vertex argument), with cells of ``a``.

    ``a_j = -(d_lin + d_quad theta)/m_j`` is affine in ``(d_lin, d_quad, theta)`` and monotone in
    ``1/m_j``, and ``c_j = d_quad_hat s p_bj / m_hat_j`` bilinear in ``(s, p_bj)``, so their
    extremes over the box and the operating box are at the corners of those intervals. ``p_bj``
    is the desired ground velocity in the body frame the law measures (its heading noise widens
    the slip).

    Parameters
    ----------
    plant : Plant
        Model, box and current.
    op : OperatingBox
        The operating box.
    heading_noise : float
        Bound of the heading measurement's error (rad).
    straight : bool
        The mission keeps its course (no turns): in a constant current the trims then move only
        as the heading error turns the body frame (:func:`trim_drift`), and get cells
        (:func:`_damping`).
    """
    drifts: tuple[float | None, float | None] = (None, None)
    if straight and plant.current_rate == 0.0:
        drifts = trim_drift(op, plant.current)
    slip_y = min(op.slip + heading_noise, MAX_SLIP)
    p_x = (op.ground_speed[0] * math.cos(slip_y), op.ground_speed[1])
    p_y = op.ground_speed[1] * math.sin(slip_y)
    mdl = plant.model
    out = []
    axes = (
        ("11", op.u_d, op.u[1] - op.u_d[1], p_x, mdl.d11_quad / mdl.m11, 0),
        ("22", (-op.v_d, op.v_d), op.v - op.v_d, (-p_y, p_y), mdl.d22_quad / mdl.m22, 1),
    )
    gains = plant.input_gains()
    for axis, desired, width, p_range, slope_hat, k in axes:
        _, slope = _slope_ranges(desired, width)
        law_side = [slope_hat * a * b for a in slope for b in p_range]
        out.append(_axis(plant, axis, desired, width, (min(law_side), max(law_side)), gains[k], drifts[k]))
    return out[0], out[1]


def _axis(
    plant: Plant,
    axis: str,
    desired: tuple[float, float],
    width: float,
    compensation: tuple[float, float],
    gain: tuple[float, float],
    drift: float | None,
) -> AxisRanges:
    """An axis's ranges: trim cells when its speed keeps one sign, else a drag residual about the best slope.

    When the speed may cross zero (``desired`` widened by ``width`` contains 0) the mean-value
    slope's range spans everything from no drag to twice the largest, and a symmetric slope
    perturbation of half that range over-counts the drag's increment by about 3x (the increment is
    ``-k |eta| eta`` about zero speed); the residual of :func:`residual_nominal` is exact instead.
    """
    whole, cells, curvature = _damping(plant, axis, desired, width, drift)
    if desired[0] - width <= 0.0 <= desired[1] + width and width > 0.0:
        a0, residual = residual_nominal(plant, axis, desired, width, whole)
        return AxisRanges(whole, compensation, gain, ((a0, a0),), residual)
    return AxisRanges(whole, compensation, gain, cells, curvature=curvature)


def heading_axis(plant: Plant, op: OperatingBox, mission: MissionBounds, straight: bool = False) -> AxisRanges:
    """The heading loop's ranges: ``a = -(d33_lin + d33_quad theta_r)/m33``, ``c = d33_quad_hat s r_d/m33_hat``, ``g``.

    Parameters
    ----------
    plant : Plant
        Model, box and current.
    op : OperatingBox
        The operating box (its ``r``).
    mission : MissionBounds
        The desired motion (its ``yaw_rate``).
    straight : bool
        The mission keeps its course: ``r_d = 0`` for ever, so the trim of ``a`` is held and gets
        cells (:func:`_damping`).
    """
    desired = (-mission.yaw_rate, mission.yaw_rate)
    width = op.r - mission.yaw_rate
    _, slope = _slope_ranges(desired, width)
    comp = plant.model.d33_quad * mission.yaw_rate / plant.model.m33
    law_side = [comp * a * b for a in slope for b in (-1.0, 1.0)]
    drift = 0.0 if straight else None
    return _axis(plant, "33", desired, width, (min(law_side), max(law_side)), plant.heading_gains(), drift)


#: The outputs of a position axis's loop, in order: the position and velocity errors, the held
#: command, the measured velocity error, the law's feedback, the velocity error's change since
#: it was measured (noise included), and with integral action the integrator.
AXIS_OUTPUTS = ("e", "v", "u", "v_m", "F", "dv")
#: Its continuous inputs: the disturbance and the perturbation (both into eta'), the coupling
#: into epsilon'.
AXIS_INPUTS = ("w", "q", "q_e")
#: Its discrete inputs: the position and velocity measurement errors, and (integral action) the
#: integrator's turn.
AXIS_DISCRETE = ("n_e", "n_v", "p_z")
#: The outputs of the heading loop, in order (as :data:`AXIS_OUTPUTS`, ``dpsi`` the heading
#: error's change since it was measured, noise included).
HEADING_OUTPUTS = ("e", "v", "u", "v_m", "F", "dpsi")
#: The heading loop's continuous inputs (into ``e_r'``) and discrete inputs.
HEADING_INPUTS = ("w", "q")
HEADING_DISCRETE = ("n_e", "n_v")


def axis_loop(gains: Gains, ranges: AxisRanges, sample_time: float, delay: float, cell: int = 0) -> SampledLoop:
    """The nominal sampled-data loop of one position axis (see the module docstring).

    ``epsilon' = eta + q_e``, ``eta' = a0 eta + u + w + q``; the law measures ``(epsilon, eta)``
    at ``t_k - d`` (plus ``n_e, n_v``) and holds ``u_k = lambda0 (c0 y_v - F_k)``,
    ``F_k = k1 y_e + alpha y_v + ki z_k``, ``z_{k+1} = z_k + h y_e + p_z``.

    Parameters
    ----------
    gains : Gains
        ``alpha`` (1/s), ``k1`` (1/s^2), ``ki`` (1/s^3).
    ranges : AxisRanges
        The axis's ranges (their middles are the nominal loop).
    sample_time, delay : float
        ``h > 0`` and ``d >= 0`` (s).
    cell : int
        The cell of ``a`` whose middle is the nominal (:attr:`AxisRanges.parts`).
    """
    a0, c0, g0 = ranges.nominal(cell)
    k1, al, ki = gains.k1, gains.alpha, gains.ki
    integral = ki > 0.0
    a = np.array([[0.0, 1.0], [0.0, a0]])
    b_u = np.array([[0.0], [1.0]])
    b_w = np.array([[0.0, 0.0, 1.0], [1.0, 1.0, 0.0]])
    d_n = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    d_c = g0 * np.array([[-k1, c0 - al]])
    if integral:
        a_c, b_c = np.array([[1.0]]), np.array([[sample_time, 0.0]])
        c_c, b_cn = np.array([[-g0 * ki]]), np.array([[0.0, 0.0, 1.0]])
    else:
        a_c, b_c, c_c, b_cn = np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), np.zeros((0, 3))

    # rows on (epsilon, eta, [z], u, y_e, y_v); F = c0 y_v - u / lambda0
    def row(
        eps: float = 0.0, eta: float = 0.0, z: float = 0.0, u: float = 0.0, ye: float = 0.0, yv: float = 0.0
    ) -> list[float]:
        return [eps, eta, *([z] if integral else []), u, ye, yv]

    rows = [
        row(eps=1.0),
        row(eta=1.0),
        row(u=1.0),
        row(yv=1.0),
        row(u=-1.0 / g0, yv=c0),
        row(eta=1.0, yv=-1.0),
    ]
    names: tuple[str, ...] = AXIS_OUTPUTS
    if integral:
        rows.append(row(z=1.0))
        names = (*AXIS_OUTPUTS, "z")
    return SampledLoop(a, b_u, b_w, np.eye(2), d_n, b_cn, a_c, b_c, c_c, d_c, sample_time, delay, np.array(rows), names)


def heading_loop(gains: Gains, ranges: AxisRanges, sample_time: float, delay: float, cell: int = 0) -> SampledLoop:
    """The nominal sampled-data heading loop: ``e_psi' = e_r``, ``e_r' = a0 e_r + u + w + q``.

    The law measures ``(e_psi, e_r)`` at ``t_k - d`` (plus ``n_e, n_v``) and holds
    ``u_k = g0 (c0 y_v - F_k)``, ``F_k = k1psi y_e + k2psi y_v``.

    Parameters
    ----------
    gains : Gains
        ``k_psi = (k1psi, k2psi)`` (1/s^2, 1/s).
    ranges : AxisRanges
        The heading's ranges (:func:`heading_axis`).
    sample_time, delay : float
        ``h > 0`` and ``d >= 0`` (s).
    cell : int
        The cell of ``a`` whose middle is the nominal (:attr:`AxisRanges.parts`).
    """
    a0, c0, g0 = ranges.nominal(cell)
    k1, k2 = gains.k_psi
    a = np.array([[0.0, 1.0], [0.0, a0]])
    rows = np.array(
        [
            [1.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0 / g0, 0.0, c0],
            [1.0, 0.0, 0.0, -1.0, 0.0],
        ]
    )
    return SampledLoop(
        a,
        np.array([[0.0], [1.0]]),
        np.array([[0.0, 0.0], [1.0, 1.0]]),
        np.eye(2),
        np.eye(2),
        np.zeros((0, 2)),
        np.zeros((0, 0)),
        np.zeros((0, 2)),
        np.zeros((1, 0)),
        g0 * np.array([[-k1, c0 - k2]]),
        sample_time,
        delay,
        rows,
        HEADING_OUTPUTS,
    )


def nominal_loops(
    plant: Plant,
    op: OperatingBox,
    mission: MissionBounds,
    heading_noise: float,
    gains: Gains,
    sample_time: float,
    delay: float,
) -> tuple[tuple[str, AxisRanges, list[SampledLoop]], ...]:
    """The surge, sway and heading axes' ranges on ``op`` and their nominal sampled loops, one per cell.

    Parameters
    ----------
    plant : Plant
        Model, box and current.
    op : OperatingBox
        The operating box.
    mission : MissionBounds
        The desired motion (a straight one gets trim cells).
    heading_noise : float
        Bound of the heading measurement's error (rad).
    gains : Gains
        The law's gains.
    sample_time, delay : float
        ``h > 0`` and ``d >= 0`` (s).
    """
    straight = mission.straight
    surge, sway = position_axes(plant, op, heading_noise, straight)
    head = heading_axis(plant, op, mission, straight)
    return (
        ("surge", surge, [axis_loop(gains, surge, sample_time, delay, k) for k in range(len(surge.parts))]),
        ("sway", sway, [axis_loop(gains, sway, sample_time, delay, k) for k in range(len(sway.parts))]),
        ("heading", head, [heading_loop(gains, head, sample_time, delay, k) for k in range(len(head.parts))]),
    )


@dataclass(frozen=True)
class Disturbances:
    """Bounds of what drives the loops beyond their channels (see the module docstring).

    Attributes
    ----------
    deficit : float
        ``W_c``: the equilibrium deficit ``|w_c|`` (m/s^2).
    deficit_axes : tuple of float
        Bounds of its surge and sway components (m/s^2): each axis's loop sees its own.
    deficit_rate : float
        Bound of the deficit's rate ``|d w_c / dt|`` in the body frame (m/s^3): a slowly varying
        input, whose effect on outputs that settle is its step response's peak and area.
    residual : float
        ``W_r``: the residual of the lag, the reference and the current's rate in ``eta'`` (m/s^2).
    heading : float
        ``W_psi``: what drives ``e_r'`` beyond its channels (rad/s^2).
    misrotation : tuple of float
        Gains (m/s^2 per rad) of the heading's change since its measurement on the surge and sway
        components of ``eta'``: the drift compensation and the feed-forward turned by it
        (:func:`misrotation_gains`).
    munk : tuple of float
        Gains (rad/s^2 per m/s) of the surge and sway velocity errors' changes since their
        measurement on ``e_r'`` (the Munk moment the law cancels on old velocities).
    parts : dict
        Each term of ``W_c``, ``W_r`` and ``W_psi`` by name (their units).
    """

    deficit: float
    deficit_axes: tuple[float, float]
    deficit_rate: float
    residual: float
    heading: float
    misrotation: tuple[float, float]
    munk: tuple[float, float]
    parts: dict[str, float]


def disturbances(
    plant: Plant,
    op: OperatingBox,
    mission: MissionBounds,
    impl: Implementation,
    gains: Gains,
    errors: Errors,
) -> Disturbances:
    """Sound bounds of ``w_c``, ``w_r`` and ``w_psi`` while the errors stay within ``errors``.

    Parameters
    ----------
    plant : Plant
        Model, box and current.
    op : OperatingBox
        The operating box of ``errors``.
    mission : MissionBounds
        The desired motion.
    impl : Implementation
        Sample time, delay and noise bounds.
    gains : Gains
        The law's gains.
    errors : Errors
        Assumed bounds of the errors.
    """
    mdl = plant.model
    n = impl.noise
    tau = impl.max_lag
    c, c_rate = plant.current, plant.current_rate
    s_hi = mission.speed[1]
    m11, m22, m33 = plant.interval("m11"), plant.interval("m22"), plant.interval("m33")
    m_lo = min(m11[0], m22[0])
    lam_lo, lam_hi = plant.input_gain_range()
    g_lo, g_hi = plant.heading_gains()
    munk = plant.munk()
    munk_abs = max(abs(munk[0]), abs(munk[1]))
    munk_hat = mdl.m22 - mdl.m11
    d_munk = max(abs(munk[0] - munk_hat), abs(munk[1] - munk_hat))
    u_abs = max(abs(op.u[0]), abs(op.u[1]))
    u_y, v_y, r_y = u_abs + n.velocity, op.v + n.velocity, op.r + n.yaw_rate
    # --- w_c: the equilibrium deficit at nu = nu_d (drag mismatch, current, feed-forward mass error)
    # per body axis: on a straight line in still water the drag mismatch is along the surge axis
    mismatch_axes = (
        (plant.damping_mismatch("11", u_abs) * op.p_bx[1] + d_munk * mission.yaw_rate * op.p_by) / m11[0],
        (plant.damping_mismatch("22", op.v) * op.p_by + d_munk * mission.yaw_rate * op.p_bx[1]) / m22[0],
    )
    # the current's body-frame components are each at most its speed
    drag_axes = (plant.damping("11", u_abs)[1] / m11[0], plant.damping("22", op.v)[1] / m22[0])
    current_axes = tuple((d + munk_abs * mission.yaw_rate / m_lo) * c for d in drag_axes)
    feed = max(abs(lam_lo - 1.0), abs(lam_hi - 1.0)) * mission.accel
    deficit_axes = (
        mismatch_axes[0] + current_axes[0] + feed,
        mismatch_axes[1] + current_axes[1] + feed,
    )
    mismatch = math.hypot(*mismatch_axes)
    current_drag = math.hypot(*current_axes)
    w_c = mismatch + current_drag + feed
    # --- w_r: the lag, the reference's change over it, and the current's rate
    # the law's drift compensation Lambda B_hat(nu_y) R_y^T p_d'(t'): its slope on the old error is in
    # the loop (c), its turn by the heading's change is the misrotation channel; what remains is nu_d's
    # change over the lag, p_d''s change over it, and the desired heading's turn over it
    slope_hat = max(mdl.d11_quad / mdl.m11, mdl.d22_quad / mdl.m22)
    b1, b2, off = compensation_bounds(mdl, (u_y, v_y, r_y))
    b_hat = max(b1, b2) + off
    reference_turn = min(mission.yaw_rate * tau, math.pi)
    nu_d_rate = op.r * (s_hi + c) + mission.accel + c_rate
    feed_lag = lam_hi * (min(mission.jerk * tau, 2.0 * mission.accel) + reference_turn * mission.accel)
    compensation = lam_hi * (
        s_hi * slope_hat * nu_d_rate * tau + b_hat * (reference_turn * s_hi + min(mission.accel * tau, 2.0 * s_hi))
    )
    nu_d = math.hypot(u_abs, op.v)
    r_gap = errors.yaw_rate + n.yaw_rate + min(mission.yaw_accel * tau, 2.0 * mission.yaw_rate)
    coriolis_rate = (errors.yaw_rate * munk_abs * nu_d + r_gap * abs(munk_hat) * s_hi) / m_lo
    w_r = feed_lag + compensation + coriolis_rate + c_rate
    misrotation = misrotation_gains(plant, op, mission, impl, lam_hi, (u_y, v_y, r_y))
    # --- heading: what is not a channel of its loop
    d33_hat = mdl.d33_lin + mdl.d33_quad * mission.yaw_rate
    nu_d_change = nu_d_rate * tau  # the desired relative velocity's change over the lag
    psi_terms = {
        "mass": max(abs(g_lo - 1.0), abs(g_hi - 1.0)) * mission.yaw_accel,
        "reference_lag": g_hi * min(mission.yaw_jerk * tau, 2.0 * mission.yaw_accel),
        "drag": plant.damping_mismatch("33", mission.yaw_rate) * mission.yaw_rate / m33[0],
        "compensation_lag": (mdl.d33_quad * n.yaw_rate * mission.yaw_rate + d33_hat * mission.yaw_accel * tau) / m33[0],
        # the law cancels (m22_hat - m11_hat) u_y v_y on old, noisy velocities: the velocity errors'
        # changes since measured are the munk channels; nu_d's change and the heading noise's turn
        # of the measured ground velocity (N_psi (S + C)) remain here
        "munk": (d_munk * u_abs * op.v + abs(munk_hat) * (nu_d_change + n.heading * (s_hi + c)) * (u_y + v_y)) / m33[0],
    }
    parts = {
        "drag_mismatch": mismatch,
        "current_drag": current_drag,
        "feed_forward_mass": feed,
        "reference_lag": feed_lag,
        "compensation": compensation,
        "coriolis": coriolis_rate,
        "current_rate": c_rate,
        **{f"heading_{k}": v for k, v in psi_terms.items()},
    }
    munk_gain = abs(munk_hat) / m33[0]
    return Disturbances(
        deficit=w_c,
        deficit_axes=deficit_axes,
        deficit_rate=_deficit_rate(plant, op, mission),
        residual=w_r,
        heading=sum(psi_terms.values()),
        misrotation=misrotation,
        munk=(munk_gain * v_y, munk_gain * u_y),
        parts=parts,
    )


def compensation_bounds(mdl: VehicleParams, measured: tuple[float, float, float]) -> tuple[float, float, float]:
    """Bounds of the law's drift-compensation matrix ``B_hat(nu_y)`` at measured velocities within ``measured``.

    ``B_hat = [[d11(u)/m11, (m22 - m11) r/m11], [(m22 - m11) r/m22, d22(v)/m22]]`` of the law's model
    (:meth:`~auv_hinf.law.formation_law.VehicleLaw.unsaturated`).

    Parameters
    ----------
    mdl : VehicleParams
        The law's model.
    measured : tuple of float
        Bounds of the measured ``|u_y|, |v_y|`` (m/s) and ``|r_y|`` (rad/s).

    Returns
    -------
    tuple of float
        Its diagonal entries' bounds ``b1, b2`` and its off-diagonal ones' bound
        ``max(|m22/m11 - 1|, |1 - m11/m22|) r_y`` (1/s).
    """
    u_y, v_y, r_y = measured
    rho = max(abs(mdl.m22 / mdl.m11 - 1.0), abs(1.0 - mdl.m11 / mdl.m22))
    return (mdl.d11_lin + mdl.d11_quad * u_y) / mdl.m11, (mdl.d22_lin + mdl.d22_quad * v_y) / mdl.m22, rho * r_y


def misrotation_gains(
    plant: Plant,
    op: OperatingBox,
    mission: MissionBounds,
    impl: Implementation,
    lam_hi: float,
    measured: tuple[float, float, float],
) -> tuple[float, float]:
    """Gains (m/s^2 per rad) of the heading's change since measured on the surge and sway parts of ``eta'``.

    The law turns its drift compensation ``B_hat(nu_y) R_y^T p_d'`` and its feed-forward
    ``R_y^T p_d''`` with the measured heading ``psi_y``; with ``delta = psi - psi_y`` the error is
    ``B_hat (R(delta) - I) p`` with ``p = R^T p_d'`` the desired ground velocity in the body frame,
    ``|p_x| <= S`` and ``|p_y| <= S sin(slip)`` (``slip`` the mission's heading offset plus the heading
    error, :class:`OperatingBox`). Componentwise ``|((R(delta) - I) p)_x| <= |delta| (|p_y| + |p_x|
    delta_m/2)`` and ``|(..)_y| <= |delta| (|p_x| + |p_y| delta_m/2)``, from ``|sin delta| <= |delta|`` and
    ``1 - cos delta <= delta^2/2 <= |delta| delta_m/2``, with ``delta_m = r_max (h + d) + n_psi`` the
    largest ``|delta|`` in the operating box (the yaw rate over the largest lag, plus the heading
    noise). ``B_hat`` is the diagonal ``(d_jj_lin + d_jj_quad |nu_y,j|)/m_jj`` plus Coriolis terms of at
    most ``rho_hat r_y`` off the diagonal. On a straight line (``p_y`` small) the surge part is second
    order in ``delta``: the compensation is turned across the track, not along it. Each axis keeps the
    smaller of this and the norm bound ``lambda (|B_hat| S + |p_d''|)``; the feed-forward's turn
    (``|p_d''|``, of any direction) is counted whole on both.

    Parameters
    ----------
    plant : Plant
        Model, box and current.
    op : OperatingBox
        The operating box.
    mission : MissionBounds
        The desired motion.
    impl : Implementation
        Sample time, delay and noise bounds.
    lam_hi : float
        Largest input gain ``m_hat/m``.
    measured : tuple of float
        Bounds of the measured ``|u_y|, |v_y|`` (m/s) and ``|r_y|`` (rad/s).
    """
    s_hi = mission.speed[1]
    b1, b2, off = compensation_bounds(plant.model, measured)
    whole = lam_hi * ((max(b1, b2) + off) * s_hi + mission.accel)
    p_y = s_hi * math.sin(min(op.slip, MAX_SLIP))
    half = 0.5 * min(op.r * impl.max_lag + impl.noise.heading, math.pi)
    along = b1 * (p_y + s_hi * half) + off * (s_hi + p_y * half)
    across = b2 * (s_hi + p_y * half) + off * (p_y + s_hi * half)
    return (
        min(whole, lam_hi * (along + mission.accel)),
        min(whole, lam_hi * (across + mission.accel)),
    )


def _deficit_rate(plant: Plant, op: OperatingBox, mission: MissionBounds) -> float:
    """Bound (m/s^3) of ``|omega'|``: the body-frame deficit follows the desired motion and the turning frame.

    ``omega`` is a function of ``p_b = R^T p_d'``, ``c_b = R^T c``, ``a_b = R^T p_d''`` and ``r_d``
    with ``|p_b'| <= |r| S + A``, ``|c_b'| <= |r| C + C'``, ``|a_b'| <= |r| A + J``; its partial
    derivatives are bounded over the box, their nominal parts cancelling: ``d omega_x / d p_bx =
    (dd_lin + d_quad_hat c_bx + 2 dd_quad u_d)/m11`` (``dd`` the spread about the model).
    """
    mdl = plant.model
    c = plant.current
    m11, m22 = plant.interval("m11"), plant.interval("m22")
    m_lo = min(m11[0], m22[0])
    u_abs = max(abs(op.u[0]), abs(op.u[1]))
    s_hi, acc = mission.speed[1], mission.accel
    lam_lo, lam_hi = plant.input_gain_range()
    munk = plant.munk()
    munk_abs = max(abs(munk[0]), abs(munk[1]))
    d_munk = max(abs(munk[0] - (mdl.m22 - mdl.m11)), abs(munk[1] - (mdl.m22 - mdl.m11)))
    dp = (
        max(
            (plant.spread("d11_lin") + mdl.d11_quad * c + 2.0 * plant.spread("d11_quad") * u_abs) / m11[0],
            (plant.spread("d22_lin") + mdl.d22_quad * c + 2.0 * plant.spread("d22_quad") * op.v) / m22[0],
        )
        + (d_munk + munk_abs) * mission.yaw_rate / m_lo
    )
    dc = (
        max(
            (plant.interval("d11_lin")[1] + 2.0 * plant.interval("d11_quad")[1] * u_abs + mdl.d11_quad * s_hi) / m11[0],
            (plant.interval("d22_lin")[1] + 2.0 * plant.interval("d22_quad")[1] * op.v + mdl.d22_quad * s_hi) / m22[0],
        )
        + munk_abs * mission.yaw_rate / m_lo
    )
    dr = (d_munk * s_hi + munk_abs * c) / m_lo
    da = max(abs(lam_lo - 1.0), abs(lam_hi - 1.0))
    return (
        dp * (op.r * s_hi + acc)
        + dc * (op.r * c + plant.current_rate)
        + da * (op.r * acc + mission.jerk)
        + dr * mission.yaw_accel
    )


__all__ = [
    "AXIS_DISCRETE",
    "AXIS_INPUTS",
    "AXIS_OUTPUTS",
    "CELL_WIDTH",
    "HEADING_DISCRETE",
    "HEADING_INPUTS",
    "HEADING_OUTPUTS",
    "MAX_CELLS",
    "MAX_SLIP",
    "AxisRanges",
    "Disturbances",
    "Errors",
    "MissionBounds",
    "OperatingBox",
    "Plant",
    "axis_loop",
    "compensation_bounds",
    "disturbances",
    "heading_axis",
    "heading_loop",
    "misrotation_gains",
    "nominal_loops",
    "position_axes",
    "turn_bounds",
]
