"""Jacobi formation coordinates (Yang & Zhang, eqs. 11-20): the transform, the formation matrices, O(N) maps.

Positions of N vehicles are stacked as an array of shape ``(..., N, 2)`` (inertial
frame, m). The Jacobi transform ``Phi`` (N x N) acts on the vehicle index; on the
stacked 2N vector it is ``Phi kron I2``. Rows ``0..N-2`` give the Jacobi shape vectors
``rho_j``; the last row gives the formation centre ``q_c`` (the mean position).

Structure used for O(N) work
----------------------------
The rows of ``Phi`` are mutually orthogonal, so ``Phi = D Q`` with ``Q`` orthogonal and
``D = diag(row norms)``. Hence

* the singular values of ``Phi`` are its row norms: ``sqrt((j+1)/j)`` (``j = 1..N-1``) and
  ``1/sqrt(N)`` for the centroid row in the paper form, so ``cond(Phi) = sqrt(2N)``; ``1``
  (N-1 times) and ``1/sqrt(N)`` in the orthonormal form, so ``cond(Phi) = sqrt(N)``;
* ``Phi^-1 = Phi^T D^-2`` and ``Phi^-T = D^-2 Phi``.

Every product with ``Phi``, ``Phi^T``, ``Phi^-1`` or ``Phi^-T`` is a (reverse) cumulative sum
over the vehicle index (:func:`jacobi_coordinates`, :func:`positions_from_jacobi`,
:func:`jacobi_transpose`, :func:`jacobi_inverse_transpose`), O(N) time and memory; no N x N
matrix is ever needed. The dense matrices (:attr:`JacobiTransform.phi` and friends) are built
lazily and only up to :data:`DENSE_MAX_N` vehicles. Also the O(N log N) closest pair of a
point set (coincident vehicles).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import get_args

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray, JacobiKind
from auv_hinf.exceptions import FormationError, require_finite
from auv_hinf.models.vehicle import VehicleParams, inertial_block, input_matrix


def _check_kind(kind: str) -> None:
    if kind not in get_args(JacobiKind):
        raise FormationError(f"Jacobi kind must be one of {get_args(JacobiKind)}, got {kind!r}")


def _check_vectors(p: ArrayLike, kind: str) -> FloatArray:
    arr = np.asarray(p, dtype=float)
    if arr.ndim < 2 or arr.shape[-1] != 2 or arr.shape[-2] < 2:
        raise FormationError(f"stacked vectors must have shape (..., N >= 2, 2), got {arr.shape}")
    _check_kind(kind)
    return arr


def row_scale(n: int, kind: JacobiKind = "paper") -> FloatArray:
    """Scale of the shape rows ``j = 1..N-1`` of ``Phi``: 1 (paper) or ``sqrt(j/(j+1))`` (orthonormal).

    Parameters
    ----------
    n : int
        Number of vehicles ``N``.
    kind : {"paper", "orthonormal"}
        Row scaling of the shape rows: the paper's, or scaled to unit norm.

    Returns
    -------
    ndarray, shape (N-1,)
        Dimensionless factors multiplying the paper rows.
    """
    _check_kind(kind)
    j = np.arange(1, n, dtype=float)
    return np.ones(n - 1) if kind == "paper" else np.sqrt(j / (j + 1.0))


def row_norms(n: int, kind: JacobiKind = "paper") -> FloatArray:
    """Euclidean norms of the rows of ``Phi`` (dimensionless), shape ``(N,)``, in closed form.

    Paper row ``j`` has ``j`` entries ``1/j`` and one ``-1``: squared norm ``1/j + 1 = (j+1)/j``;
    the orthonormal rows are scaled to norm 1; the centroid row ``(1/N) 1^T`` has norm
    ``1/sqrt(N)``. Since the rows are mutually orthogonal these are the singular values of ``Phi``.

    Parameters
    ----------
    n : int
        Number of vehicles ``N``.
    kind : {"paper", "orthonormal"}
        Row scaling of the shape rows: the paper's, or scaled to unit norm.
    """
    j = np.arange(1, n, dtype=float)
    shape = np.sqrt((j + 1.0) / j) * row_scale(n, kind)
    return np.append(shape, 1.0 / np.sqrt(n))


def jacobi_coordinates(p: ArrayLike, kind: JacobiKind = "paper") -> FloatArray:
    """``X = Phi p`` in O(N) with a cumulative sum (the same as ``JacobiTransform.phi @ p``).

    Row ``j`` (``1 <= j <= N-1``) is ``rho_j = mean(p_1..p_j) - p_{j+1}`` (times
    ``sqrt(j/(j+1))`` for ``"orthonormal"``); the last row is the centre ``mean(p)``.

    Parameters
    ----------
    p : array_like, shape (..., N, 2)
        Positions (m), or velocities / accelerations.
    kind : {"paper", "orthonormal"}

    Returns
    -------
    ndarray, shape (..., N, 2)
        ``N-1`` shape vectors then the centre, in the units of ``p``.
    """
    arr = _check_vectors(p, kind)
    n = arr.shape[-2]
    means = np.cumsum(arr, axis=-2) / np.arange(1, n + 1, dtype=float)[:, None]
    rho = (means[..., :-1, :] - arr[..., 1:, :]) * row_scale(n, kind)[:, None]
    return np.concatenate([rho, means[..., -1:, :]], axis=-2)


def positions_from_jacobi(x: ArrayLike, kind: JacobiKind = "paper") -> FloatArray:
    """``p = Phi^-1 X``, the inverse of :func:`jacobi_coordinates`, in O(N) (reverse cumulative sum).

    With ``m_j = mean(p_1..p_j)``: ``m_N = q_c``, ``m_j = m_{j+1} + rho_j / (j+1)``,
    ``p_{j+1} = m_j - rho_j`` and ``p_1 = m_1``.

    Parameters
    ----------
    x : array_like, shape (..., N, 2)
        Jacobi coordinates (m, or m/s, ...).
    kind : {"paper", "orthonormal"}

    Returns
    -------
    ndarray, shape (..., N, 2)
        Positions (units of ``x``).
    """
    arr = _check_vectors(x, kind)
    n = arr.shape[-2]
    j = np.arange(1, n, dtype=float)[:, None]
    rho = arr[..., :-1, :] / row_scale(n, kind)[:, None]
    tail = np.cumsum((rho / (j + 1.0))[..., ::-1, :], axis=-2)[..., ::-1, :]  # sum_{k>=j} rho_k/(k+1)
    means = arr[..., -1:, :] + tail  # m_1 .. m_{N-1}
    return np.concatenate([means[..., :1, :], means - rho], axis=-2)


def jacobi_transpose(y: ArrayLike, kind: JacobiKind = "paper") -> FloatArray:
    """``Phi^T y`` in O(N) (reverse cumulative sum), ``y`` of shape ``(..., N, 2)``.

    Column ``k`` (1-based) of ``Phi`` holds ``s_j / j`` in rows ``j >= k`` (``j <= N-1``),
    ``-s_{k-1}`` in row ``k-1`` and ``1/N`` in the centroid row, with ``s_j`` of :func:`row_scale`.

    Parameters
    ----------
    y : array_like, shape (..., N, 2)
        Vectors indexed like Jacobi coordinates (any unit; the result has the same).
    kind : {"paper", "orthonormal"}
        Row scaling of the shape rows: the paper's, or scaled to unit norm.
    """
    arr = _check_vectors(y, kind)
    n = arr.shape[-2]
    j = np.arange(1, n, dtype=float)[:, None]
    w = arr[..., :-1, :] * row_scale(n, kind)[:, None]  # s_j y_j, j = 1..N-1
    tail = np.cumsum((w / j)[..., ::-1, :], axis=-2)[..., ::-1, :]  # sum_{j>=k} s_j y_j / j, k = 1..N-1
    zero = np.zeros((*arr.shape[:-2], 1, 2))
    out: FloatArray = np.concatenate([tail, zero], axis=-2) - np.concatenate([zero, w], axis=-2)
    out += arr[..., -1:, :] / n
    return out


def jacobi_inverse_transpose(z: ArrayLike, kind: JacobiKind = "paper") -> FloatArray:
    """``Phi^-T z = D^-2 Phi z`` in O(N), ``D`` the row norms (:func:`row_norms`).

    Parameters
    ----------
    z : array_like, shape (..., N, 2)
        Vectors indexed by vehicle (any unit; the result has the same).
    kind : {"paper", "orthonormal"}
        Row scaling of the shape rows: the paper's, or scaled to unit norm.
    """
    arr = _check_vectors(z, kind)
    out: FloatArray = jacobi_coordinates(arr, kind) / row_norms(arr.shape[-2], kind)[:, None] ** 2
    return out


def closest_pair(points: ArrayLike) -> tuple[int, int, float]:
    """The two closest of ``points`` (shape ``(N, 2)``, N >= 2) and their distance, O(N log N).

    A k-d tree gives every point's nearest other point; the closest pair is the best of
    these. Ties are broken towards the lowest indices.

    Parameters
    ----------
    points : array_like, shape (N, 2)
        Finite coordinates (any length unit).

    Returns
    -------
    i, j : int
        Indices with ``i < j``.
    distance : float
        ``||points[i] - points[j]||`` (units of ``points``).

    Raises
    ------
    FormationError
        If ``points`` is not ``(N >= 2, 2)`` or not finite.
    """

    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
        raise FormationError(f"points must have shape (N >= 2, 2), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise FormationError("points must be finite")
    from scipy.spatial import cKDTree  # local: keeps the k-d tree out of the module's public names

    dist, idx = cKDTree(pts).query(pts, k=2)
    own = np.arange(len(pts))
    # with exact duplicates the point itself may be listed second: take the other one
    other = np.where(idx[:, 0] == own, idx[:, 1], idx[:, 0])
    d = dist[:, 1]  # distance to the nearest other point (0 for a duplicate either way)
    best = float(d.min())
    cand = np.flatnonzero(d == best)
    pairs = np.sort(np.stack([cand, other[cand]], axis=-1), axis=-1)
    k = int(np.lexsort((pairs[:, 1], pairs[:, 0]))[0])
    return int(pairs[k, 0]), int(pairs[k, 1]), best


#: Largest fleet whose dense ``Phi`` (N x N) and ``Phi kron I2`` (2N x 2N) may be built:
#: ``Phi kron I2`` takes ``32 N^2`` bytes (128 MB at N = 2000). Larger fleets must use the
#: O(N) maps of this module.
DENSE_MAX_N = 2000


@dataclass(frozen=True)
class JacobiTransform:
    """Jacobi transform ``Phi`` for ``n`` vehicles.

    Parameters
    ----------
    n : int
        Number of vehicles (>= 2).
    kind : {"paper", "orthonormal"}
        ``"paper"``: the unnormalised chain ``rho_j = mean(p_1..p_j) - p_{j+1}``
        (``rho_1 = p1 - p2``, ``rho_2 = (p1 + p2)/2 - p3``, ...), as in Yang & Zhang.
        ``"orthonormal"``: the same rows scaled by ``sqrt(j/(j+1))`` so that the shape
        rows are orthonormal and orthogonal to the centroid row; only the centroid row
        ``(1/N) 1^T`` is not unit length.

    Raises
    ------
    FormationError
        If ``n < 2`` or ``kind`` is unknown.

    Notes
    -----
    :attr:`singular_values`, :attr:`cond` and the maps :meth:`to_jacobi`, :meth:`to_positions`,
    :meth:`transpose`, :meth:`inverse_transpose` are O(N); the dense matrices :attr:`phi`,
    :attr:`phi_inv`, :attr:`matrix`, :attr:`matrix_inv` are built on first use and refused
    above :data:`DENSE_MAX_N` vehicles.
    """

    n: int
    kind: JacobiKind = "paper"

    def __post_init__(self) -> None:
        if isinstance(self.n, bool) or not isinstance(self.n, (int, np.integer)):
            raise FormationError(f"number of vehicles n must be an integer >= 2, got {self.n!r}")
        if self.n < 2:
            raise FormationError(f"number of vehicles n must be >= 2, got {self.n}")
        _check_kind(self.kind)
        object.__setattr__(self, "n", int(self.n))

    def _dense_allowed(self, what: str) -> None:
        if self.n > DENSE_MAX_N:
            raise FormationError(
                f"the dense {what} of N = {self.n} vehicles is refused (more than DENSE_MAX_N = "
                f"{DENSE_MAX_N}); use the O(N) maps to_jacobi / to_positions / transpose / inverse_transpose"
            )

    @cached_property
    def phi(self) -> FloatArray:
        """The dense N x N transform acting on the vehicle index (dimensionless).

        Raises
        ------
        FormationError
            If ``n > DENSE_MAX_N``.
        """
        self._dense_allowed("Phi")
        n = self.n
        out = np.zeros((n, n))
        j = np.arange(1, n)
        out[:-1] = np.where(np.arange(n)[None, :] < j[:, None], 1.0 / j[:, None], 0.0)
        out[j - 1, j] = -1.0
        out[:-1] *= row_scale(n, self.kind)[:, None]
        out[n - 1, :] = 1.0 / n
        return out

    @cached_property
    def phi_inv(self) -> FloatArray:
        """Dense inverse of :attr:`phi`, ``Phi^T D^-2`` (exact up to round-off)."""
        out: FloatArray = self.phi.T / self.singular_values_by_row[None, :] ** 2
        return out

    @cached_property
    def matrix(self) -> FloatArray:
        """Dense ``Phi kron I2``, the 2N x 2N transform of stacked positions."""
        self._dense_allowed("Phi kron I2")
        return np.kron(self.phi, np.eye(2))

    @cached_property
    def matrix_inv(self) -> FloatArray:
        """Dense ``Phi^-1 kron I2``."""
        self._dense_allowed("Phi^-1 kron I2")
        return np.kron(self.phi_inv, np.eye(2))

    @cached_property
    def singular_values_by_row(self) -> FloatArray:
        """Row norms of ``Phi`` in row order, shape ``(N,)`` (dimensionless); see :func:`row_norms`."""
        return row_norms(self.n, self.kind)

    @cached_property
    def singular_values(self) -> FloatArray:
        """Singular values of ``Phi`` in decreasing order, shape ``(N,)``, in closed form, O(N).

        The rows of ``Phi`` are orthogonal, so ``Phi Phi^T = D^2`` with ``D`` the row norms.
        """
        out: FloatArray = np.sort(self.singular_values_by_row)[::-1].copy()
        return out

    @cached_property
    def cond(self) -> float:
        """2-norm condition number of ``Phi`` (also that of ``Phi kron I2``), in closed form.

        ``sqrt(2N)`` in the paper form (largest row ``j = 1``, norm ``sqrt 2``; centroid row
        ``1/sqrt(N)``) and ``sqrt(N)`` in the orthonormal form.
        """
        s = self.singular_values_by_row
        return float(s.max() / s.min())

    def to_jacobi(self, p: ArrayLike) -> FloatArray:
        """Jacobi coordinates ``X = Phi p`` of positions ``p`` of shape ``(..., N, 2)``, O(N).

        Returns shape ``(..., N, 2)``: ``N-1`` shape vectors then the centre ``q_c`` (m).
        The same map applies to velocities and accelerations.

        Parameters
        ----------
        p : array_like, shape (..., N, 2)
            Positions (m, inertial frame), or velocities / accelerations.
        """
        return jacobi_coordinates(self._check_stack(p, "p"), self.kind)

    def to_positions(self, x: ArrayLike) -> FloatArray:
        """Inverse of :meth:`to_jacobi`: positions ``Phi^-1 X`` from Jacobi coordinates, O(N).

        Parameters
        ----------
        x : array_like, shape (..., N, 2)
            Jacobi coordinates (m, or m/s, ...); the result has their unit.
        """
        return positions_from_jacobi(self._check_stack(x, "X"), self.kind)

    def transpose(self, y: ArrayLike) -> FloatArray:
        """``Phi^T y`` for ``y`` of shape ``(..., N, 2)``, O(N).

        Parameters
        ----------
        y : array_like, shape (..., N, 2)
            Vectors indexed like Jacobi coordinates (any unit; the result has the same).
        """
        return jacobi_transpose(self._check_stack(y, "y"), self.kind)

    def inverse_transpose(self, z: ArrayLike) -> FloatArray:
        """``Phi^-T z`` for ``z`` of shape ``(..., N, 2)``, O(N).

        Parameters
        ----------
        z : array_like, shape (..., N, 2)
            Vectors indexed by vehicle (any unit; the result has the same).
        """
        return jacobi_inverse_transpose(self._check_stack(z, "z"), self.kind)

    def _check_stack(self, a: ArrayLike, name: str) -> FloatArray:
        arr = np.asarray(a, dtype=float)
        if arr.ndim < 2 or arr.shape[-2:] != (self.n, 2):
            raise FormationError(f"{name} must have shape (..., {self.n}, 2), got {arr.shape}")
        return arr


def block_diag_stack(blocks: ArrayLike) -> FloatArray:
    """Block-diagonal matrices from stacked 2x2 blocks.

    Parameters
    ----------
    blocks : array_like, shape (..., N, 2, 2)
        The diagonal blocks, in order.

    Returns
    -------
    ndarray, shape (..., 2N, 2N)
        Zero off the 2x2 diagonal blocks.
    """
    b = np.asarray(blocks, dtype=float)
    n = b.shape[-3]
    out = np.zeros((*b.shape[:-3], 2 * n, 2 * n))
    for i in range(n):
        out[..., 2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = b[..., i, :, :]
    return out


@dataclass(frozen=True)
class FormationMatrices:
    """Formation dynamics ``X'' = A X' + Gamma U`` (eq. 15).

    Attributes
    ----------
    A : ndarray, shape (..., 2N, 2N)
        ``Phi G Phi^-1`` (eq. 16), in 1/s.
    Gamma : ndarray, shape (..., 2N, 2N)
        ``Phi diag(H(psi_i))`` (eq. 17), in 1/kg.
    G : ndarray, shape (..., N, 2, 2)
        The per-vehicle inertial blocks ``G_i`` (eq. 8), in 1/s.
    """

    A: FloatArray
    Gamma: FloatArray
    G: FloatArray


def formation_matrices(
    params: VehicleParams,
    psi: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    r: ArrayLike,
    transform: JacobiTransform,
) -> FormationMatrices:
    """Formation matrices A (eq. 16) and Gamma (eq. 17), vectorised over leading axes.

    Parameters
    ----------
    params : VehicleParams
        Parameters shared by all vehicles.
    psi, u, v, r : array_like, shape (..., N)
        Heading (rad), surge and sway (m/s, body frame) and yaw rate (rad/s) per vehicle.
    transform : JacobiTransform
        The Jacobi transform for N vehicles.
    """
    psi_, u_, v_, r_ = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (psi, u, v, r)))
    if psi_.ndim == 0 or psi_.shape[-1] != transform.n:
        raise FormationError(f"per-vehicle states must have last axis {transform.n}, got shape {psi_.shape}")
    g = inertial_block(params, psi_, u_, v_, r_)
    big_g = block_diag_stack(g)
    a = transform.matrix @ big_g @ transform.matrix_inv
    gamma = transform.matrix @ block_diag_stack(input_matrix(params, psi_))
    return FormationMatrices(A=a, Gamma=gamma, G=g)


def regular_polygon(n: int, radius: float, phase: float = 0.0) -> FloatArray:
    """Vertices of a regular n-gon centred at the origin, shape ``(n, 2)`` in m.

    Parameters
    ----------
    n : int
        Number of vertices (>= 2).
    radius : float
        Circumradius in m (> 0).
    phase : float
        Angle of the first vertex in rad, measured from the x axis.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise FormationError(f"polygon needs an integer n >= 2, got {n!r}")
    rad = require_finite("radius", radius)
    if rad <= 0:
        raise FormationError(f"radius must be > 0 m, got {rad!r}")
    ang = require_finite("phase", phase) + 2.0 * np.pi * np.arange(n) / n
    return rad * np.stack([np.cos(ang), np.sin(ang)], -1)


def shape_from_offsets(offsets: ArrayLike, transform: JacobiTransform) -> FloatArray:
    """Desired Jacobi shape vectors ``rho_d`` (shape ``(N-1, 2)``, m) from vehicle offsets.

    The centroid row is dropped, so a translation of all offsets has no effect.

    Parameters
    ----------
    offsets : array_like, shape (N, 2)
        Desired positions (m, inertial frame) relative to any common point; finite.
    transform : JacobiTransform
        The Jacobi transform for N vehicles.
    """
    arr = np.asarray(offsets, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise FormationError("formation offsets must be finite")
    return transform.to_jacobi(arr)[:-1]


def offsets_from_shape(shape: ArrayLike, transform: JacobiTransform) -> FloatArray:
    """Vehicle offsets from the centre (shape ``(N, 2)``, m) for Jacobi shape vectors.

    Parameters
    ----------
    shape : array_like, shape (N-1, 2)
        Jacobi shape vectors ``rho_j`` (m, inertial frame).
    transform : JacobiTransform
        The Jacobi transform for N vehicles.
    """
    rho = np.asarray(shape, dtype=float)
    if rho.shape != (transform.n - 1, 2):
        raise FormationError(f"shape must have shape ({transform.n - 1}, 2), got {rho.shape}")
    full = np.vstack([rho, np.zeros((1, 2))])
    return transform.to_positions(full)


__all__ = [
    "DENSE_MAX_N",
    "FormationMatrices",
    "JacobiTransform",
    "block_diag_stack",
    "closest_pair",
    "formation_matrices",
    "jacobi_coordinates",
    "jacobi_inverse_transpose",
    "jacobi_transpose",
    "offsets_from_shape",
    "positions_from_jacobi",
    "regular_polygon",
    "row_norms",
    "row_scale",
    "shape_from_offsets",
]
