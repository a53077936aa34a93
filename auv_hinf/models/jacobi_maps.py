"""O(N) Jacobi maps: ``Phi p``, ``Phi^-1 x``, ``Phi^T y`` and ``Phi^-T z`` with cumulative sums.

The Jacobi rows are mutually orthogonal, so ``Phi = D Q`` with ``Q`` orthogonal and
``D = diag(row norms)``; hence ``Phi^-1 = Phi^T D^-2`` and ``Phi^-T = D^-2 Phi``, and no N x N
matrix is ever needed. Also the O(N log N) closest pair of a point set (coincident vehicles).
"""

from __future__ import annotations

from typing import get_args

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray, JacobiKind
from auv_hinf.exceptions import FormationError


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
    """``Phi^-T z = D^-2 Phi z`` in O(N), ``D`` the row norms (:func:`row_norms`)."""
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
