"""The robust certificate as a campaign samples and checks it: start sets, box vertices, bounds.

When a configuration declares an ``[uncertainty]`` box or a ``[disturbance]`` current and its
robust certificate (:func:`~auv_hinf.certificate.parts.robust.robust_summary`) covers them, a campaign
draws every run inside what that certificate is about, and checks every vehicle of every run
against its bounds:

* **Starts.** Per vehicle, ``(e - e_c, e')`` uniform in the 4-D position ellipsoid
  ``sum_axes [e~, e'] P [e~, e']^T <= d^2`` (``e_c = -lam c/(l k1)``, the certificate's
  current-shifted equilibrium; with integral action, the slice of the ``(z~, e, e')``
  ellipsoid at the integrator's start ``z~ = -z*``) and ``(e_psi, e_psi')`` uniform in the heading ellipse
  ``[e_psi, e_psi'] Q [e_psi, e_psi']^T <= h^2``. Uniform in volume puts most starts near the
  boundary, where the bounds are tight.
* **Plants.** Every :data:`CORNER_PERIOD`-th run (run ``i`` with ``i % CORNER_PERIOD == 0``)
  is a vertex of the box, until the ``2^d`` vertices (``d`` declared parameters) are used:
  vertex ``j = i // CORNER_PERIOD`` takes the upper end of parameter ``k`` when bit ``k`` of
  ``j`` is set, with a current of the full declared speed in a random direction. The other runs
  are uniform in the box, with a current uniform in the disc. Corners are thus at most half of
  any campaign and interleaved with interior samples, and the summary states the composition.
* **Check.** Each vehicle's sup over the samples of ``||e||``, ``||e'||``, ``|e_psi|`` and
  ``|e_psi'|`` must lie within the certified bounds, and the run must stay in the envelope;
  the commanded force must stay within the certificate's thrust bound (:attr:`RobustStart.thrust`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.certificate.design_point import DesignPoint
from auv_hinf.certificate.parts.robust import robust_summary
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.exceptions import ParameterError
from auv_hinf.robust.invariant_set import Ellipsoid, RobustCertificate

#: Every CORNER_PERIOD-th run is a box vertex (until all are used): at most 1/CORNER_PERIOD of a
#: campaign's runs are corners, interleaved with interior samples.
CORNER_PERIOD = 2
#: The start sets are shrunk by this relative factor so that round-off in building the initial
#: state (rotations of the body velocity) cannot put a start outside the verified ellipsoid.
START_SHRINK = 1e-9


class BoxVertices:
    """The box-vertex schedule of a campaign that checks a certificate covering a box (see the module docstring).

    A subclass holds ``declared``: the indices of the box parameters with a non-degenerate range
    (the vertex bits).
    """

    declared: tuple[int, ...]

    @property
    def vertices(self) -> int:
        """Number of box vertices."""
        return int(2 ** len(self.declared))

    def vertex_index(self, run: int) -> int | None:
        """The box vertex run ``run`` samples, or ``None`` for an interior run (see the module docstring).

        Parameters
        ----------
        run : int
            Run index within the campaign.
        """
        return vertex_index(run, self.vertices)

    def vertex_runs(self, runs: int) -> int:
        """How many of the first ``runs`` runs are box vertices.

        Parameters
        ----------
        runs : int
            Number of runs.
        """
        return vertex_runs(runs, self.vertices)

    def vertex(self, box: FloatArray, index: int) -> FloatArray:
        """Multipliers of vertex ``index`` of ``box`` (shape (9, 2)); see :func:`box_vertex`.

        Parameters
        ----------
        box : ndarray, shape (9, 2)
            ``[lo, hi]`` multipliers of the nine coefficients.
        index : int
            Vertex index; its bit ``k`` refers to the ``k``-th declared parameter.
        """
        return box_vertex(box, self.declared, index)


@dataclass(frozen=True)
class RobustStart(BoxVertices):
    """A covering robust certificate as a campaign samples from it and checks against it.

    Attributes
    ----------
    certificate : RobustCertificate
        Covers the declared box and current: it has both invariant sets and the bounds.
    declared : tuple of int
        Indices of the box parameters with a non-degenerate range (the vertex bits).
    """

    certificate: RobustCertificate
    declared: tuple[int, ...]

    #: What the campaign's summary calls the certificate.
    kind = "robust"

    def _sets(self) -> tuple[Ellipsoid, Ellipsoid, float, float]:
        c = self.certificate
        pos, head, hp, d = c.position_ellipsoid, c.heading_ellipsoid, c.heading, c.position_disturbance
        if pos is None or head is None or hp is None or d is None:  # pragma: no cover - a covering one has them
            raise ParameterError("a robust campaign needs a certificate with both invariant sets")
        return pos, head, float(d), float(hp.disturbance)

    @property
    def position(self) -> FloatArray:
        """``P`` of the position ellipsoid (per unit disturbance) on ``[e~, e']`` per axis."""
        return self._sets()[0].matrix

    @property
    def position_level(self) -> float:
        """Its level ``d`` (m/s^2): the set is ``V <= d^2``."""
        return self._sets()[2]

    @property
    def heading(self) -> FloatArray:
        """``Q`` of the heading ellipsoid on ``[e_psi, e_psi']``."""
        return self._sets()[1].matrix

    @property
    def heading_level(self) -> float:
        """Its level ``h`` (rad/s^2)."""
        return self._sets()[3]

    @property
    def bounds(self) -> FloatArray:
        """Certified per-vehicle bounds of position (m), velocity (m/s), heading (rad), yaw rate (rad/s)."""
        b = self.certificate.bounds
        if b is None:  # pragma: no cover - a covering certificate has bounds
            raise ParameterError("a robust campaign needs a certificate with bounds")
        return np.array([b.position, b.velocity, b.heading, b.yaw_rate])

    @property
    def thrust(self) -> FloatArray:
        """Certified bound of the commanded ``|tau_x|`` (N), ``|tau_y|`` (N), ``|tau_psi|`` (N m) over the sets."""
        t = self.certificate.thrust
        if t is None:  # pragma: no cover - a covering certificate has thrust bounds
            raise ParameterError("a robust campaign needs a certificate with thrust bounds")
        return np.array(t.as_tuple())

    @property
    def decay_rate(self) -> float:
        """Certified decay rate of the robust Lyapunov functions towards the invariant sets (1/s)."""
        return float(self.certificate.decay_rate or 0.0)

    def sample_errors(
        self, rng: np.random.Generator, n: int, current: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Start errors of ``n`` vehicles inside the certified set for ``current`` (m/s, inertial).

        Returns ``e (n, 2)`` m, ``e' (n, 2)`` m/s, ``e_psi (n,)`` rad, ``e_psi' (n,)`` rad/s.

        Parameters
        ----------
        rng : numpy.random.Generator
            Source of the draws.
        n : int
            Number of vehicles.
        current : ndarray, shape (2,)
            The run's current (m/s, inertial frame), which shifts the position set.
        """
        pos, head, d, h = self._sets()
        scale = 1.0 - START_SHRINK
        shift = self.certificate.equilibrium_shift(current)
        p, radius = pos.matrix, d
        centre: FloatArray = np.zeros((2, 2))
        if p.shape[0] == 3:  # integral action: the slice z~ = -z* of the (z~, e, e') ellipsoid
            p, centre, radius = _integrator_slice(p, -shift, d)
            shift = np.zeros(2)  # the position error's equilibrium is zero
        w = uniform_ball(rng, n, 4) * (radius * scale)  # (n, 4): [x-axis pair, y-axis pair]
        li = np.linalg.inv(np.linalg.cholesky(p).T)  # z = L^-T w gives z^T P z = |w|^2
        xa, ya = w[:, :2] @ li.T + centre[0], w[:, 2:] @ li.T + centre[1]
        e = np.column_stack([xa[:, 0], ya[:, 0]]) + shift
        de = np.column_stack([xa[:, 1], ya[:, 1]])
        hv = uniform_ball(rng, n, 2) * (h * scale) @ np.linalg.inv(np.linalg.cholesky(head.matrix).T).T
        return e, de, hv[:, 0], hv[:, 1]

    def inside(self, e: FloatArray, de: FloatArray, epsi: FloatArray, depsi: FloatArray, current: FloatArray) -> bool:
        """Every vehicle's start errors lie in both certified sets (the test of :meth:`sample_errors`).

        Parameters
        ----------
        e : ndarray, shape (N, 2)
            Position errors (m, inertial frame).
        de : ndarray, shape (N, 2)
            Ground-velocity errors (m/s, inertial frame).
        epsi : ndarray, shape (N,)
            Heading errors (rad).
        depsi : ndarray, shape (N,)
            Yaw-rate errors (rad/s).
        current : ndarray, shape (2,)
            The run's current (m/s, inertial frame).
        """
        return self.certificate.start_inside(e, de, epsi, depsi, current)


def _integrator_slice(p: FloatArray, z: FloatArray, level: float) -> tuple[FloatArray, FloatArray, float]:
    """The ``(e, e')`` ellipse of ``{sum_axes x_a^T P x_a <= level^2}`` at fixed integrator states ``z (2,)``.

    With ``P = [[p_zz, p_zy], [p_yz, P_yy]]`` and ``y_a = (e_a, e'_a)``, completing the square gives
    ``sum_axes (y_a - m_a)^T P_yy (y_a - m_a) <= level^2 - s |z|^2``, ``m_a = -z_a P_yy^-1 p_yz``
    and ``s = p_zz - p_zy P_yy^-1 p_yz``. Returns ``P_yy``, the centres ``m (2 axes, 2)`` and the
    radius ``sqrt(level^2 - s |z|^2)`` (0 when the slice is empty).
    """
    pyy, pyz = p[1:, 1:], p[1:, 0]
    g = np.linalg.solve(pyy, pyz)
    s = float(p[0, 0] - pyz @ g)
    centre: FloatArray = -np.outer(z, g)
    return pyy, centre, math.sqrt(max(level * level - s * float(z @ z), 0.0))


def uniform_ball(rng: np.random.Generator, n: int, dim: int) -> FloatArray:
    """``n`` points uniform in the unit ball of ``R^dim``, shape ``(n, dim)``.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the draws.
    n : int
        Number of points.
    dim : int
        Dimension of the ball.
    """
    g = rng.standard_normal((n, dim))
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    return g * rng.random(n)[:, None] ** (1.0 / dim)


def robust_start(
    point: DesignPoint, box: FloatArray, nominal: ClosedLoopCertificate | None
) -> tuple[RobustStart | None, str | None]:
    """The robust start sets of a design point, or ``None`` with the reason the robust check does not apply.

    ``(None, None)`` when nothing is declared (the nominal certificate applies); ``(None, why)``
    when something is declared but the robust certificate does not cover it.

    Parameters
    ----------
    point : DesignPoint
        The design point (configuration, gains, tube).
    box : ndarray, shape (9, 2)
        ``[lo, hi]`` multipliers of the nine coefficients; those with ``lo < hi`` are declared.
    nominal : ClosedLoopCertificate or None
        The nominal closed-loop certificate when the caller has it (None: the robust summary
        computes it when it needs it).
    """
    summ = robust_summary(point, margins=False, nominal=nominal)
    if not summ.declared:
        return None, None
    c = summ.certificate
    if not summ.covers or c is None or c.bounds is None:
        why = "; ".join(summ.to_dict()["reasons"]) or "the robust certificate does not cover the declared box"
        return None, why
    return RobustStart(c, declared_rows(box)), None


def vertex_current(rng: np.random.Generator, speed: float) -> FloatArray:
    """A current of exactly ``speed`` (m/s) in a uniformly random direction.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the direction (one draw).
    speed : float
        Current speed (m/s).
    """
    ang = 2.0 * math.pi * rng.random()
    return np.array([speed * math.cos(ang), speed * math.sin(ang)]) + 0.0


def vertex_index(run: int, vertices: int) -> int | None:
    """The box vertex run ``run`` samples, or ``None`` for an interior run (see the module docstring).

    Parameters
    ----------
    run : int
        Run index within the campaign.
    vertices : int
        Number of vertices of the box (``2^d``).
    """
    if run % CORNER_PERIOD == 0 and run // CORNER_PERIOD < vertices:
        return run // CORNER_PERIOD
    return None


def vertex_runs(runs: int, vertices: int) -> int:
    """How many of the first ``runs`` runs are box vertices.

    Parameters
    ----------
    runs : int
        Number of runs.
    vertices : int
        Number of vertices of the box.
    """
    return min(vertices, (runs + CORNER_PERIOD - 1) // CORNER_PERIOD)


def declared_rows(box: FloatArray) -> tuple[int, ...]:
    """Rows of ``box`` (shape (p, 2), ``[lo, hi]`` multipliers) with a non-degenerate range: the vertex bits.

    Parameters
    ----------
    box : ndarray, shape (p, 2)
        ``[lo, hi]`` multipliers of the coefficients.
    """
    return tuple(k for k in range(box.shape[0]) if box[k, 0] < box[k, 1])


def sample_plant_and_current(
    rng: np.random.Generator, box: FloatArray, declared: tuple[int, ...], speed: float, corner: int | None
) -> tuple[FloatArray, FloatArray]:
    """Multipliers and current (m/s) of one run (see the module docstring).

    A vertex run (``corner`` not ``None``) takes vertex ``corner`` of the box and a current of
    exactly ``speed`` in a random direction; an interior run draws the multipliers uniformly in
    the box and the current uniformly in the disc of radius ``speed``.

    Parameters
    ----------
    rng : numpy.random.Generator
        The run's source of draws.
    box : ndarray, shape (p, 2)
        ``[lo, hi]`` multipliers.
    declared : tuple of int
        The box's vertex bits (:func:`declared_rows`).
    speed : float
        Bound of the current's speed (m/s).
    corner : int or None
        The vertex of a vertex run, ``None`` for an interior one.
    """
    if corner is not None:
        return box_vertex(box, declared, corner), vertex_current(rng, speed)
    lo, hi = box[:, 0], box[:, 1]
    mult = lo + (hi - lo) * rng.random(lo.size)
    return mult, vertex_current(rng, speed * math.sqrt(rng.random()))  # uniform in the disc


def box_vertex(box: FloatArray, declared: tuple[int, ...], index: int) -> FloatArray:
    """Multipliers of vertex ``index`` of ``box``: bit ``b`` of ``index`` picks the upper end of ``declared[b]``.

    Parameters
    ----------
    box : ndarray, shape (p, 2)
        ``[lo, hi]`` multipliers of the coefficients.
    declared : tuple of int
        Rows of ``box`` with a non-degenerate range, in bit order.
    index : int
        Vertex index, ``0 <= index < 2^len(declared)``.
    """
    mult = box[:, 0].copy()
    for bit, k in enumerate(declared):
        if (index >> bit) & 1:
            mult[k] = box[k, 1]
    return mult


__all__ = [
    "CORNER_PERIOD",
    "START_SHRINK",
    "BoxVertices",
    "RobustStart",
    "box_vertex",
    "declared_rows",
    "robust_start",
    "sample_plant_and_current",
    "uniform_ball",
    "vertex_current",
    "vertex_index",
    "vertex_runs",
]
