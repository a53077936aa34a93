"""Norm of the Jacobi-coordinate perturbation ``M = Phi blockdiag(G_i - lam I) Phi^-1`` at given states.

:func:`jacobi_sigma` evaluates ``||M||_2`` exactly with a dense SVD (small fleets);
:func:`jacobi_apply` applies ``M`` or ``M^T`` in O(N) through the Jacobi maps, and
:func:`jacobi_sigma_lower` gives a matrix-free lower bound ``||M x||`` at a unit witness vector
``x`` from a Krylov-accelerated power iteration on ``M^T M`` (see :mod:`auv_hinf.design.jacobi_sigma`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray, JacobiKind
from auv_hinf.exceptions import FormationError
from auv_hinf.models.formation import JacobiTransform, block_diag_stack
from auv_hinf.models.jacobi_maps import (
    jacobi_coordinates,
    jacobi_inverse_transpose,
    jacobi_transpose,
    positions_from_jacobi,
)
from auv_hinf.models.vehicle import VehicleParams, inertial_block

#: Krylov dimension of :func:`jacobi_sigma_lower`: applications of ``M^T M`` per configuration.
#: 24 steps agree with the dense SVD to ~1e-8 relative on the fleets of the tests (N <= 50);
#: fewer would only give a smaller, still valid, lower bound.
KRYLOV_DIM = 24

#: Floats held at once by a batch of :func:`jacobi_sigma_lower` (32 MB): bounds its memory.
KRYLOV_BATCH_FLOATS = 4_000_000

#: A Krylov residual below this fraction of the operator scale (``||M^T M v||``) means the
#: subspace is invariant; the next basis vector is then drawn at random (round-off level).
KRYLOV_BREAKDOWN = 1e-13


def jacobi_sigma(
    params: VehicleParams,
    lam: float,
    transform: JacobiTransform,
    psi: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    r: ArrayLike,
) -> FloatArray:
    """``||Phi blockdiag(G_i - lam I) Phi^-1||_2`` at stacked states ``(..., N)``."""
    a = transform.matrix @ block_diag_stack(_shifted_blocks(params, lam, psi, u, v, r)) @ transform.matrix_inv
    return np.linalg.svd(a, compute_uv=False)[..., 0]


def _shifted_blocks(
    params: VehicleParams, lam: float, psi: ArrayLike, u: ArrayLike, v: ArrayLike, r: ArrayLike
) -> FloatArray:
    """``G_i - lam I`` at stacked states ``(..., N)``: shape ``(..., N, 2, 2)`` (1/s)."""
    out: FloatArray = inertial_block(params, psi, u, v, r) - lam * np.eye(2)
    return out


def _block_mul(blocks: FloatArray, y: FloatArray, transpose: bool) -> FloatArray:
    """``blocks_i y_i`` (or ``blocks_i^T y_i``) for stacks ``(..., N, 2, 2)`` and ``(..., N, 2)``."""
    b = blocks.swapaxes(-1, -2) if transpose else blocks
    out: FloatArray = np.stack(
        [b[..., 0, 0] * y[..., 0] + b[..., 0, 1] * y[..., 1], b[..., 1, 0] * y[..., 0] + b[..., 1, 1] * y[..., 1]],
        axis=-1,
    )
    return out


def jacobi_apply(blocks: FloatArray, kind: JacobiKind, x: FloatArray, *, transpose: bool = False) -> FloatArray:
    """``M x`` (or ``M^T x``) with ``M = (Phi kron I2) blockdiag(blocks) (Phi^-1 kron I2)``, O(N).

    Parameters
    ----------
    blocks : ndarray, shape (..., N, 2, 2)
        The per-vehicle blocks (1/s).
    kind : {"paper", "orthonormal"}
        The Jacobi form of ``Phi``.
    x : ndarray, shape (..., N, 2)
        Stacked vectors (the pair index is the ``kron I2`` factor).
    transpose : bool
        Apply ``M^T = Phi^-T blockdiag(blocks^T) Phi^T`` instead.

    Returns
    -------
    ndarray, shape (..., N, 2)
        In the units of ``blocks`` times those of ``x``.
    """
    if transpose:
        return jacobi_inverse_transpose(_block_mul(blocks, jacobi_transpose(x, kind), True), kind)
    return jacobi_coordinates(_block_mul(blocks, positions_from_jacobi(x, kind), False), kind)


def jacobi_sigma_lower(
    params: VehicleParams,
    lam: float,
    transform: JacobiTransform,
    psi: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    r: ArrayLike,
    *,
    dim: int = KRYLOV_DIM,
    rng: np.random.Generator | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Matrix-free lower bounds of ``||Phi blockdiag(G_i - lam I) Phi^-1||_2`` with witness vectors.

    A Krylov basis of ``M^T M`` (the power iteration's iterates, orthonormalised twice by
    Gram-Schmidt) is built from a random start; the best unit vector ``x`` of its span (the
    top Ritz vector) is returned with ``||M x||``, recomputed directly. Since
    ``||M x|| <= ||M||`` for every unit ``x``, the value is a valid lower bound whatever the
    convergence; it is at least the last power iterate's. O(N dim^2) time, O(N dim) memory
    per configuration.

    Parameters
    ----------
    params : VehicleParams
        Vehicle parameters (all vehicles alike).
    lam : float
        Constant lambda (1/s).
    transform : JacobiTransform
        The Jacobi transform for N vehicles.
    psi, u, v, r : array_like, shape (m, N)
        Heading (rad), surge and sway (m/s), yaw rate (rad/s) of ``m`` configurations.
    dim : int
        Krylov dimension (capped at 2N).
    rng : numpy.random.Generator, optional
        Source of the start vectors (default: seed 0).

    Returns
    -------
    values : ndarray, shape (m,)
        ``||M x||`` at the unit witness vectors (1/s).
    vectors : ndarray, shape (m, N, 2)
        The unit witness vectors ``x``.
    """
    blocks = _shifted_blocks(
        params, float(lam), *np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (psi, u, v, r)))
    )
    if blocks.ndim != 4 or blocks.shape[1] != transform.n:
        raise FormationError(f"configurations must have shape (m, {transform.n}), got {blocks.shape[:-2]}")
    gen = rng if rng is not None else np.random.default_rng(0)
    m, n, kind = blocks.shape[0], transform.n, transform.kind
    k_max = max(1, min(int(dim), 2 * n))
    basis = np.empty((m, k_max, 2 * n))  # orthonormal rows v_k (flattened stacks)
    images = np.empty((m, k_max, 2 * n))  # M v_k

    def orthogonalise(w: FloatArray, q: FloatArray) -> FloatArray:
        # classical Gram-Schmidt, repeated once for orthogonality to round-off; einsum keeps
        # these memory-bound products single-threaded (threaded BLAS only adds contention here)
        for _ in range(2):
            w = w - np.einsum("mk,mkd->md", np.einsum("mkd,md->mk", q, w), q)
        return w

    w: FloatArray = gen.standard_normal((m, 2 * n))
    for k in range(k_max):
        w = orthogonalise(w, basis[:, :k])
        norm = np.linalg.norm(w, axis=-1)
        bad = norm <= KRYLOV_BREAKDOWN * max(float(norm.max()), 1e-300)
        if np.any(bad):  # invariant subspace found for some configurations: continue at random
            w[bad] = orthogonalise(gen.standard_normal((int(bad.sum()), 2 * n)), basis[bad, :k])
            norm = np.linalg.norm(w, axis=-1)
        basis[:, k] = w / norm[:, None]
        images[:, k] = jacobi_apply(blocks, kind, basis[:, k].reshape(m, n, 2)).reshape(m, 2 * n)
        w = jacobi_apply(blocks, kind, images[:, k].reshape(m, n, 2), transpose=True).reshape(m, 2 * n)
    gram = np.einsum("mid,mjd->mij", images, images)  # V^T M^T M V, (m, k, k)
    _, vecs = np.linalg.eigh(gram)
    x = np.einsum("mk,mkd->md", vecs[..., -1], basis).reshape(m, n, 2)  # top Ritz vector
    x /= np.linalg.norm(x.reshape(m, -1), axis=-1)[:, None, None]
    mx = jacobi_apply(blocks, kind, x)
    return np.linalg.norm(mx.reshape(m, -1), axis=-1), x
