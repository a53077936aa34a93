"""Thruster allocation: the body forces a set of fixed horizontal thrusters can deliver.

Thruster ``i`` sits at ``(x_i, y_i)`` (m, body frame, from the yaw centre) and pushes along the
unit vector ``d_i`` with a force ``lower_i <= f_i <= upper_i`` (N). The body force is
``tau = (tau_x, tau_y, tau_psi) = T f`` with ``T`` the ``3 x m`` allocation matrix, so the
feasible set ``{T f : lower <= f <= upper}`` is the linear image of a box: a convex polytope,
in general not a box. :meth:`ThrusterAllocation.contains_box` tests a certificate's box
``|tau_k| <= peak_k`` against it exactly. The BlueROV2 Heavy layout and its sources are in
:func:`bluerov2_heavy_thrusters` and ``docs/vehicles.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import product
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError, SolverError, require_finite

#: Standard gravity (m/s^2): converts the kilogram-force of thruster datasheets to N.
STANDARD_GRAVITY = 9.80665
#: Largest residual ``|T f - tau|`` (N, or N m) accepted when a solver's thruster forces, clipped into
#: their limits, are checked. HiGHS runs with a feasibility tolerance of 1e-9 (below), so a genuine
#: solution misses by about 1e-9 times the matrix entries (at most a few m); 1e-6 N is a wide margin
#: over that and still far below a thruster's force resolution (about 0.1 N for a T200).
FORCE_TOLERANCE = 1e-6
#: Primal feasibility tolerance passed to HiGHS (its default is 1e-7).
HIGHS_FEASIBILITY = 1e-9
#: Round-off accepted in the norm of a direction, which must be a unit vector.
UNIT_TOLERANCE = 1e-9

#: T200 thrust at 16 V, Blue Robotics' published figures: 5.25 kgf forward, 4.10 kgf reverse (N).
T200_FORWARD_16V = 5.25 * STANDARD_GRAVITY
T200_REVERSE_16V = 4.10 * STANDARD_GRAVITY
#: Largest thrust (N, either way) of the symmetric thruster curve of von Benzon et al. (2022): the
#: odd polynomial in the normalised input peaks at 30.62 N (30.4 N at full input). See docs/vehicles.md.
BENZON2022_THRUST = 30.6


def _highs(
    c: FloatArray, a_eq: FloatArray, b_eq: FloatArray, bounds: list[Any], what: str, infeasible_ok: bool = False
) -> Any:
    """Run HiGHS on ``min c x, A_eq x = b_eq``; raise unless status 0 (or 2 when ``infeasible_ok``)."""
    opts = {"primal_feasibility_tolerance": HIGHS_FEASIBILITY}
    from scipy.optimize import linprog  # imported here: the configuration layer imports this module

    res = linprog(c, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method="highs", options=opts)
    if res.status != 0 and not (infeasible_ok and res.status == 2):
        raise SolverError(f"{what}: HiGHS status {res.status} ({res.message})")
    return res


def _array(name: str, value: Any, shape: tuple[int, ...], what: str) -> FloatArray:
    """``value`` as a finite float array of ``shape`` (``-1`` matches any length >= 1)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be numbers ({what}), got {value!r}") from None
    ok = arr.ndim == len(shape) and all(s == n or (s == -1 and n >= 1) for s, n in zip(shape, arr.shape))
    if not ok:
        want = "(" + ", ".join("m" if s == -1 else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ParameterError(f"{name} must have shape {want} ({what}), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"{name} must be finite, got {arr.tolist()!r}")
    return arr


@dataclass(frozen=True)
class ThrusterAllocation:
    """Fixed horizontal thrusters and their force limits, body frame (x forward, y starboard).

    Attributes
    ----------
    directions : tuple of (float, float)
        Unit vector ``(d_x, d_y)`` along which each thruster pushes for a positive force.
    positions : tuple of (float, float)
        ``(x, y)`` of each thruster in m, from the yaw centre.
    lower, upper : tuple of float
        Force limits of each thruster in N, ``lower <= 0 <= upper`` and ``lower < upper``. For a
        T200 the reverse thrust is weaker, ``|lower| < upper``. A switched-off thruster gives 0,
        so 0 must lie in the range.
    name : str
        Label used in reports.

    Raises
    ------
    ParameterError
        If a field has the wrong shape, is not finite, a direction is not a unit vector, or a
        limit pair is out of order. The message names the field, the expected and found values.
    """

    directions: tuple[tuple[float, float], ...]
    positions: tuple[tuple[float, float], ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    name: str = "custom"

    def __post_init__(self) -> None:
        d = _array("directions", self.directions, (-1, 2), "a sequence of (x, y) pairs")
        m = d.shape[0]
        p = _array("positions", self.positions, (m, 2), "one (x, y) pair per thruster")
        lo = _array("lower", self.lower, (m,), "one force per thruster")
        hi = _array("upper", self.upper, (m,), "one force per thruster")
        for i, norm in enumerate(np.hypot(d[:, 0], d[:, 1]).tolist()):
            if abs(norm - 1.0) > UNIT_TOLERANCE:
                raise ParameterError(f"directions[{i}] must be a unit vector, got {d[i].tolist()} (norm {norm!r})")
        for i, (a, b) in enumerate(zip(lo.tolist(), hi.tolist())):
            if not a < b:
                raise ParameterError(f"lower[{i}] must be < upper[{i}], got lower {a!r} N, upper {b!r} N")
            if not a <= 0.0 <= b:
                raise ParameterError(
                    f"thruster {i}: the range [lower, upper] must contain 0 N (a thruster can be off), "
                    f"got [{a!r}, {b!r}] N"
                )
        for field, arr in (("directions", d), ("positions", p), ("lower", lo), ("upper", hi)):
            object.__setattr__(self, field, tuple(map(tuple, arr.tolist())) if arr.ndim == 2 else tuple(arr.tolist()))

    @property
    def count(self) -> int:
        """Number of thrusters ``m``."""
        return len(self.directions)

    def matrix(self) -> FloatArray:
        """Allocation matrix ``T`` (3, m): ``tau = T f`` with ``tau_psi = sum(x_i f_yi - y_i f_xi)``.

        Rows are surge (N per N), sway (N per N) and yaw (N m per N, i.e. the moment arm in m).
        """
        d = np.asarray(self.directions)
        p = np.asarray(self.positions)
        return np.stack([d[:, 0], d[:, 1], p[:, 0] * d[:, 1] - p[:, 1] * d[:, 0]])

    def _check_solution(self, f: FloatArray, tau: FloatArray, tol: float, what: str) -> None:
        """Raise unless the clipped forces ``f`` give ``tau`` within ``tol``."""
        applied = self.matrix() @ np.clip(f, self.lower, self.upper)
        residual = float(np.max(np.abs(applied - tau)))
        if not residual <= tol:
            raise SolverError(
                f"{what}: HiGHS reported a solution whose thruster forces miss by {residual:.3g} > {tol:g}"
            )

    def contains(self, tau: ArrayLike, tol: float = FORCE_TOLERANCE) -> bool:
        """Whether the body force ``tau = (tau_x, tau_y, tau_psi)`` (N, N, N m) can be delivered.

        Solves the feasibility LP ``T f = tau``, ``lower <= f <= upper`` with HiGHS. Status 0 is
        accepted after the forces found are clipped into their limits and checked to give
        ``tau`` within ``tol``: a True answer guarantees a deliverable force within ``tol`` of
        ``tau``. Status 2 (infeasible) gives False.

        Parameters
        ----------
        tau : array_like, shape (3,)
            Body force and moment.
        tol : float
            Residual accepted in the check of the solver's answer (N, N m).

        Raises
        ------
        SolverError
            If HiGHS returns another status, or a solution that fails the check.
        """
        t = _array("tau", tau, (3,), "a body force")
        what = f"thruster feasibility LP for tau={t.tolist()}"
        res = _highs(
            np.zeros(self.count), self.matrix(), t, list(zip(self.lower, self.upper)), what, infeasible_ok=True
        )
        if res.status == 2:
            return False
        self._check_solution(np.asarray(res.x), t, tol, what)
        return True

    def contains_box(self, peak: ArrayLike, tol: float = FORCE_TOLERANCE) -> bool:
        """Whether every force of the box ``|tau_k| <= peak_k`` (k = x, y, psi) can be delivered.

        Exact: the feasible set is the image of the box of thruster forces under the linear map
        ``T``, hence convex, and the force box is the convex hull of its 8 corners. If every
        corner is feasible, so is each convex combination of corners, i.e. the whole box; if
        some corner is not, the box is not contained. So the box is contained if and only if
        its corners are, each checked with :meth:`contains`.

        Parameters
        ----------
        peak : array_like, shape (3,)
            Half-widths ``(peak_x, peak_y, peak_psi)`` >= 0 in N, N, N m.
        tol : float
            Residual accepted per corner, as in :meth:`contains`.
        """
        return all(self.contains(corner, tol) for corner in box_corners(peak))

    def _max_scale(self, corners: FloatArray, tol: float) -> float:
        """Largest ``s >= 0`` such that every ``s * corner`` is deliverable (one LP, one f per corner)."""
        if not np.any(corners):
            return math.inf
        k, m = len(corners), self.count
        c = np.zeros(1 + k * m)
        c[0] = -1.0
        a_eq = np.zeros((3 * k, 1 + k * m))
        mat = self.matrix()
        for j, corner in enumerate(corners):
            a_eq[3 * j : 3 * j + 3, 0] = -corner
            a_eq[3 * j : 3 * j + 3, 1 + j * m : 1 + (j + 1) * m] = mat
        bounds = [(0.0, None), *(list(zip(self.lower, self.upper)) * k)]
        res = _highs(c, a_eq, np.zeros(3 * k), bounds, f"largest-box LP for corners {corners.tolist()}")
        x = np.asarray(res.x)
        s = float(x[0])
        for j, corner in enumerate(corners):
            self._check_solution(x[1 + j * m : 1 + (j + 1) * m], s * corner, tol, "largest-box LP")
        return s

    def largest_box_scale(self, peak: ArrayLike, tol: float = FORCE_TOLERANCE) -> float:
        """Largest ``s`` such that the box ``|tau_k| <= s peak_k`` can be delivered.

        Because 0 is deliverable and the feasible set is convex and closed, the scales that work
        form an interval ``[0, s*]``. ``s*`` is the optimum of one LP: maximise ``s`` subject to
        ``T f_c = s corner_c`` with a separate ``f_c`` within the limits for each corner ``c``.

        Parameters
        ----------
        peak : array_like, shape (3,)
            Box half-widths ``>= 0`` (N, N, N m).
        tol : float
            Residual accepted when the solver's forces are checked.

        Returns
        -------
        float
            ``s*`` (dimensionless; ``inf`` if ``peak`` is zero). The box is deliverable iff ``s* >= 1``.
            Raises :class:`~auv_hinf.exceptions.SolverError` unless HiGHS returns status 0 and its
            forces pass the check.
        """
        return self._max_scale(box_corners(peak), tol)

    def channel_limits(self, tol: float = FORCE_TOLERANCE) -> tuple[float, float, float]:
        """Per-channel limits ``(tau_x, tau_y, tau_psi)`` (N, N, N m), one channel at a time.

        Channel ``k``'s limit is the largest ``c`` such that every ``t e_k`` with ``|t| <= c`` (the
        other two channels zero) is deliverable: the smaller of the largest push either way, one
        LP per channel. The limits do not hold all at once; use :meth:`contains_box` for that.

        Parameters
        ----------
        tol : float
            Residual (N, N m) accepted when the solver's forces are checked.
        """
        eye = np.eye(3)
        x, y, psi = (self._max_scale(np.stack([eye[k], -eye[k]]), tol) for k in range(3))
        return (x, y, psi)

    def _null_space(self) -> FloatArray:
        """Orthonormal basis (m, k) of the thruster forces that give no body force."""
        mat = self.matrix()
        _, sv, vt = np.linalg.svd(mat)
        rank = int(np.sum(sv > 1e-12 * max(float(sv[0]), 1.0)))
        return np.asarray(vt[rank:].T)

    def allocation_is_exact(self) -> bool:
        """Whether :meth:`saturate` delivers every deliverable command unchanged (at most one redundant direction)."""
        return bool(self._null_space().shape[1] <= 1)

    def saturate(self, tau: ArrayLike) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Body forces delivered for commanded ``tau`` (..., 3), and where saturation is active.

        This is the simulator's saturation model: the common pseudo-inverse allocation
        ``f = pinv(T) tau`` with each thruster clipped to its limits. When the layout has exactly
        one redundant direction ``n`` (``T n = 0``; the BlueROV2's four horizontal thrusters), ``f``
        is first slid along ``n`` by the smallest amount that fits the limits, if one does.
        Without that, pseudo-inverse allocation clips commands the thrusters could deliver when
        forward and reverse limits differ (a BlueROV2 surge of 120 N asks 42.4 N of reverse
        thrust from the two front thrusters, beyond their 40.2 N). With it the allocation is exact
        (:meth:`allocation_is_exact`): every deliverable command comes out unchanged. Layouts with
        two or more redundant directions use plain pseudo-inverse allocation. A certified run
        never saturates, so the model only matters for uncertified runs. Vectorised over the
        leading axes (vehicles, time).

        Parameters
        ----------
        tau : array_like, shape (..., 3)
            Commanded ``(tau_x, tau_y, tau_psi)`` in N, N, N m.

        Returns
        -------
        applied : ndarray, shape (..., 3)
            ``T f`` with the clipped thruster forces: always deliverable.
        active : ndarray of bool, shape (...)
            ``applied`` differs from ``tau`` by more than :data:`FORCE_TOLERANCE`.
        """
        t = np.asarray(tau, dtype=float)
        if t.ndim < 1 or t.shape[-1] != 3:
            raise ParameterError(f"tau must have shape (..., 3), got shape {t.shape}")
        mat = self.matrix()
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        f = t @ np.linalg.pinv(mat).T
        null = self._null_space()
        if null.shape[1] == 1:
            n = null[:, 0]
            moves = np.abs(n) > 1e-12
            ends_a = (lo[moves] - f[..., moves]) / n[moves]
            ends_b = (hi[moves] - f[..., moves]) / n[moves]
            s_lo = np.max(np.minimum(ends_a, ends_b), axis=-1)
            s_hi = np.min(np.maximum(ends_a, ends_b), axis=-1)
            shift = np.where(s_lo <= s_hi, np.clip(0.0, s_lo, s_hi), 0.5 * (s_lo + s_hi))
            f = f + shift[..., None] * n
        applied = np.clip(f, lo, hi) @ mat.T
        active = np.max(np.abs(applied - t), axis=-1) > FORCE_TOLERANCE
        return applied, active


def box_corners(peak: ArrayLike) -> FloatArray:
    """The distinct corners ``(+-peak_x, +-peak_y, +-peak_psi)`` of a box, shape (<= 8, 3).

    Parameters
    ----------
    peak : array_like, shape (3,)
        Half-widths of the box (N, N, N m), finite and >= 0, else :class:`ParameterError` is
        raised; a zero half-width gives one value instead of two.
    """
    p = _array("peak", peak, (3,), "a box half-width per channel")
    if np.any(p < 0):
        raise ParameterError(f"peak must be >= 0 in every channel, got {p.tolist()}")
    signs = product(*[(v, -v) if v > 0 else (0.0,) for v in p.tolist()])
    return np.array(list(signs), dtype=float)


def bluerov2_heavy_thrusters(
    forward: float = T200_FORWARD_16V, reverse: float = T200_REVERSE_16V
) -> ThrusterAllocation:
    """The BlueROV2 Heavy's four horizontal T200 thrusters in the vectored 45-degree layout.

    Geometry from von Benzon et al., J. Mar. Sci. Eng. 10 (2022) 1898, appendix table: thrusters
    at ``(x, y) = (+-0.156, +-0.111) m`` pointing at 45 degrees to the hull axis. Each direction is
    the thruster's stronger (forward) side: the negative of the paper's unit vector, after Blue
    Robotics' description of the stock frame (front pair facing backwards, rear pair forwards).
    Flipping all four mirrors the feasible set through 0, so it changes no box test or channel
    limit, only :meth:`ThrusterAllocation.saturate` on unsymmetric commands. See docs/vehicles.md.

    Default limits: Blue Robotics' T200 figures at 16 V, 5.25 kgf forward and 4.10 kgf reverse
    (51.5 N, 40.2 N). They give channel limits of 129.7 N surge and sway and 34.6 N m yaw. The
    paper's own thruster curve is symmetric and peaks at :data:`BENZON2022_THRUST` (30.6 N);
    ``forward = reverse = BENZON2022_THRUST`` gives 86.5 N, 86.5 N and 23.1 N m.

    Parameters
    ----------
    forward : float
        Largest forward thrust of one thruster, N (> 0).
    reverse : float
        Largest reverse thrust of one thruster, N (> 0, a magnitude).
    """
    fwd = require_finite("forward", forward)
    rev = require_finite("reverse", reverse)
    if fwd <= 0 or rev <= 0:
        raise ParameterError(f"forward and reverse thrust must be > 0 N, got forward {fwd!r}, reverse {rev!r}")
    c = math.sqrt(0.5)
    return ThrusterAllocation(
        directions=((-c, c), (-c, -c), (c, c), (c, -c)),
        positions=((0.156, 0.111), (0.156, -0.111), (-0.156, 0.111), (-0.156, -0.111)),
        lower=(-rev,) * 4,
        upper=(fwd,) * 4,
        name=f"bluerov2-heavy horizontal T200 x4 (+{fwd:.4g}/-{rev:.4g} N)",
    )


__all__ = [
    "BENZON2022_THRUST",
    "FORCE_TOLERANCE",
    "HIGHS_FEASIBILITY",
    "STANDARD_GRAVITY",
    "T200_FORWARD_16V",
    "T200_REVERSE_16V",
    "UNIT_TOLERANCE",
    "ThrusterAllocation",
    "bluerov2_heavy_thrusters",
    "box_corners",
]
