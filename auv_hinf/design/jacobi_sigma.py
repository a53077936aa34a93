"""Certified bounds on the Jacobi-coordinate sigma ``||Phi blockdiag(G_i - lam I) Phi^-1||_2``.

Jacobi coordinates (bounded)
----------------------------
``||Phi B Phi^-1|| <= cond(Phi) ||B||`` gives a certified upper bound
``cond(Phi) * sigma_vehicle`` . For small fleets (N <= :data:`BNB_MAX_N`, full
heading circle) :func:`jacobi_branch_and_bound` tightens it:

* a common rotation of all headings commutes with ``Phi kron I2``, so only the N-1
  headings relative to vehicle N matter;
* for fixed headings the norm is convex in the per-vehicle ``(|u|, |v|, r)``, so its
  supremum is at one of the ``8^N`` vertex combinations;
* in heading ``psi_i`` the matrix moves with derivative ``Phi (e_i e_i^T kron
  [J, G_i - lam I]) Phi^-1``, whose norm is at most
  ``L_i = 2 sigma_vehicle ||Phi e_i|| ||e_i^T Phi^-1||``;
* so on a heading cell with centre ``c`` and half-width ``h`` the supremum is at most
  ``f(c) + h sum_i L_i``. Cells are split until the bound is within ``tol`` of the best
  centre value, or a budget runs out; whatever the stopping point, the returned upper
  bound is valid.

The lower bound is the best evaluated configuration (a witness). Up to
:data:`DENSE_SIGMA_MAX_N` vehicles each configuration is evaluated exactly by a dense 2N x 2N
SVD (:func:`jacobi_sigma`). Larger fleets use :func:`jacobi_sigma_lower`: a Krylov
(Lanczos-type) acceleration of the power iteration on ``M^T M``, ``M = Phi blockdiag(G_i - lam I)
Phi^-1``, with ``M`` and ``M^T`` applied matrix-free through the O(N) Jacobi maps
(``Phi^-1 = Phi^T D^-2``, ``Phi^-T = D^-2 Phi``). For any vector ``x`` the ratio
``||M x|| / ||x||`` is at most ``||M||``, so the value returned, which is that ratio at the
returned witness vector, is a valid lower bound however far the iteration got. Time and memory
are O(N) per configuration.
The small-gain certificate uses vehicle coordinates, which is legitimate because the
nominal loop ``(lam - alpha) I`` is the same in every coordinate system.

The norm itself at given states: :func:`jacobi_sigma` evaluates ``||M||_2`` exactly with a
dense SVD (small fleets); :func:`jacobi_apply` applies ``M`` or ``M^T`` in O(N) through the
Jacobi maps, and :func:`jacobi_sigma_lower` gives the matrix-free lower bound.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike
from tqdm.auto import tqdm

from auv_hinf._typing import FloatArray, JacobiKind
from auv_hinf.design.sigma import ROUNDOFF_RTOL, SigmaBounds, _witness, sigma_max_2x2, vehicle_sigma
from auv_hinf.exceptions import FormationError
from auv_hinf.models.envelope import Envelope, abs_range
from auv_hinf.models.jacobi import (
    JacobiTransform,
    block_diag_stack,
    jacobi_coordinates,
    jacobi_inverse_transpose,
    jacobi_transpose,
    positions_from_jacobi,
)
from auv_hinf.models.vehicle import VehicleParams, inertial_block
from auv_hinf.numerics.progress import PROGRESS_DELAY

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
    """``||Phi blockdiag(G_i - lam I) Phi^-1||_2`` at stacked states ``(..., N)`` (1/s), by a dense SVD.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters shared by all vehicles.
    lam : float
        Envelope lambda (1/s).
    transform : JacobiTransform
        The Jacobi transform for N vehicles (dense, so ``N <= DENSE_MAX_N``).
    psi, u, v, r : array_like, shape (..., N)
        Heading (rad), surge and sway (m/s, body frame) and yaw rate (rad/s) per vehicle.
    """
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


#: Chunk size (points) of vectorised evaluations: bounds memory for fine grids.
CHUNK = 200_000


#: Largest fleet for the Jacobi branch-and-bound (8^N vertex combinations per cell).
BNB_MAX_N = 3


#: Largest number of matrix evaluations the branch-and-bound may spend.
BNB_BUDGET = 6_000_000


#: Largest fleet whose Jacobi search evaluates each configuration by a dense 2N x 2N SVD
#: (exact, O(N^3)); larger fleets use the matrix-free :func:`jacobi_sigma_lower` (O(N)).
DENSE_SIGMA_MAX_N = 12


def refinable(n: int, envelope: Envelope) -> bool:
    """Whether :func:`jacobi_branch_and_bound` runs for ``n`` vehicles: ``n <= BNB_MAX_N`` on the full heading circle.

    Parameters
    ----------
    n : int
        Number of vehicles.
    envelope : Envelope
        The envelope (its heading range ``psi``, rad).
    """
    return n <= BNB_MAX_N and envelope.psi[1] - envelope.psi[0] >= 2.0 * np.pi


def jacobi_sigma_bounds(
    params: VehicleParams,
    envelope: Envelope,
    lam: float,
    transform: JacobiTransform,
    *,
    samples: int = 20_000,
    seed: int = 0,
    progress: bool = False,
    refine_jacobi: bool = False,
    budget: int = BNB_BUDGET,
) -> SigmaBounds:
    """Certified upper and witnessed lower bounds on the Jacobi-coordinate ``||A_Delta||``.

    The upper bound is ``cond(Phi) * sigma_vehicle`` (or the branch-and-bound value when
    ``refine_jacobi`` and it is smaller); the lower bound is the best of ``samples`` random
    vertex configurations with uniform headings, returned as a witness.

    Parameters
    ----------
    params, envelope, lam
        As in :func:`vehicle_sigma`.
    transform : JacobiTransform
        The Jacobi transform for N vehicles.
    samples : int
        Random configurations for the lower bound.
    seed : int
        Seed of the search (``numpy.random.default_rng``).
    progress : bool
        Show a tqdm bar.
    refine_jacobi : bool
        Run :func:`jacobi_branch_and_bound` (N <= :data:`BNB_MAX_N`, full heading circle).
    budget : int
        Evaluation budget of the branch-and-bound.
    """
    veh = vehicle_sigma(params, envelope, lam, transform.n)
    lam = float(lam)
    nv = transform.n
    rng = np.random.default_rng(seed)
    a_rng, b_rng = abs_range(*envelope.u), abs_range(*envelope.v)
    best, best_x = -np.inf, None
    best_vec: FloatArray | None = None
    dense = nv <= DENSE_SIGMA_MAX_N
    if dense:
        chunk = max(1, min(samples, CHUNK // (4 * nv * nv)))
    else:
        chunk = max(1, min(samples, KRYLOV_BATCH_FLOATS // (2 * nv * (KRYLOV_DIM + 3))))
    done = 0
    with tqdm(total=samples, disable=not progress, desc="Jacobi sigma search", unit="cfg", delay=PROGRESS_DELAY) as bar:
        while done < samples:
            m = min(chunk, samples - done)
            a = np.asarray(a_rng)[rng.integers(0, 2, (m, nv))]
            b = np.asarray(b_rng)[rng.integers(0, 2, (m, nv))]
            r = np.asarray(envelope.r)[rng.integers(0, 2, (m, nv))]
            psi = rng.uniform(envelope.psi[0], envelope.psi[1], (m, nv))
            if dense:
                vals = jacobi_sigma(params, lam, transform, psi, a, b, r)
                vecs = None
            else:
                vals, vecs = jacobi_sigma_lower(params, lam, transform, psi, a, b, r, rng=rng)
            k = int(np.argmax(vals))
            if vals[k] > best:
                best, best_x = float(vals[k]), (psi[k], a[k], b[k], r[k])
                best_vec = None if vecs is None else vecs[k]
            done += m
            bar.update(m)
    assert best_x is not None
    witness = _witness(envelope, *best_x)
    how = "exact dense SVD" if dense else f"matrix-free Krylov lower bound, {KRYLOV_DIM} steps"
    if best_vec is not None:
        witness = replace(witness, vector=tuple(float(x) for x in best_vec.ravel()))
    upper = transform.cond * veh.upper * (1.0 + ROUNDOFF_RTOL)
    method = (
        f"cond(Phi) * sigma_vehicle (cond = {transform.cond:.4g}, closed form); lower from {samples} "
        f"random vertex configurations ({how})"
    )
    if refine_jacobi and refinable(nv, envelope):
        bnb = jacobi_branch_and_bound(
            params, envelope, float(lam), transform, veh.upper, progress=progress, budget=budget
        )
        if bnb.upper < upper:
            upper = bnb.upper
            method = (
                f"Lipschitz branch-and-bound over relative headings x 8^{nv} vertices "
                f"({bnb.levels} levels, {bnb.evaluations} evaluations); "
                f"cond(Phi) bound {transform.cond * veh.upper:.4g}"
            )
        if bnb.lower > best:
            best = bnb.lower
            witness = _witness(envelope, *bnb.witness)
    return SigmaBounds(
        upper=max(upper, best),
        lower=best,
        coords="jacobi",
        method=method,
        witness=witness,
        lam=float(lam),
    )


@dataclass(frozen=True)
class JacobiBnbResult:
    """Result of :func:`jacobi_branch_and_bound`: certified ``upper``, witnessed ``lower`` (1/s).

    Attributes
    ----------
    upper : float
        Certified upper bound of the Jacobi sigma (1/s), round-off allowance included.
    lower : float
        Best evaluated value (1/s), attained at ``witness``.
    witness : tuple of ndarray
        ``(psi, |u|, |v|, r)`` of the vehicles at the lower bound (rad, m/s, m/s, rad/s; the last
        vehicle's heading is 0).
    levels : int
        Refinement levels run.
    evaluations : int
        Configurations evaluated.
    """

    upper: float
    lower: float
    witness: tuple[FloatArray, FloatArray, FloatArray, FloatArray]
    levels: int
    evaluations: int


def jacobi_branch_and_bound(
    params: VehicleParams,
    envelope: Envelope,
    lam: float,
    transform: JacobiTransform,
    sigma_vehicle: float,
    *,
    tol: float = 1e-3,
    initial_cells: int = 16,
    budget: int = BNB_BUDGET,
    progress: bool = False,
) -> JacobiBnbResult:
    """Certified Lipschitz branch-and-bound of the Jacobi sigma over relative headings.

    See the module docstring for the argument.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters shared by all vehicles.
    envelope : Envelope
        Operating envelope (full heading circle assumed).
    lam : float
        Envelope lambda (1/s).
    transform : JacobiTransform
        The Jacobi transform for N vehicles (``N <= BNB_MAX_N`` in practice: ``8^N`` vertex
        combinations per cell).
    sigma_vehicle : float
        Certified vehicle-coordinate sigma (1/s), in the Lipschitz constants ``L_i``.
    tol : float
        Stop when the upper bound is within this fraction of the best centre value.
    initial_cells : int
        Cells per relative heading on the first level.
    budget : int
        Stop before a level whose evaluations (configurations) would pass this count.
    progress : bool
        Show a progress bar (one step per level).
    """
    nv = transform.n
    a_rng, b_rng = abs_range(*envelope.u), abs_range(*envelope.v)
    verts = np.array(list(itertools.product(a_rng, b_rng, envelope.r)))  # (8, 3)
    combos = np.array(list(itertools.product(range(len(verts)), repeat=nv)))  # (8^N, N)
    va, vb, vr = (verts[combos, k] for k in range(3))  # each (8^N, N)
    lip = 2.0 * sigma_vehicle * np.linalg.norm(transform.phi, axis=0) * np.linalg.norm(transform.phi_inv, axis=1)
    lip_sum = float(lip[:-1].sum())  # heading of vehicle N fixed at 0
    d = nv - 1
    h = np.pi / initial_cells
    grid = -np.pi + h * (2 * np.arange(initial_cells) + 1)
    centres = np.array(list(itertools.product(grid, repeat=d))).reshape(-1, d)
    best, best_w = -np.inf, None
    pruned_upper = -np.inf
    evaluations, levels = 0, 0
    upper = np.inf
    with tqdm(disable=not progress, desc="Jacobi branch-and-bound", unit="level") as bar:
        while True:
            m = len(centres)
            vals = np.empty(m)
            for start in range(0, m, max(1, CHUNK // len(combos))):
                cc = centres[start : start + max(1, CHUNK // len(combos))]
                psi = np.concatenate([cc, np.zeros((len(cc), 1))], axis=1)[:, None, :]
                psi = np.broadcast_to(psi, (len(cc), len(combos), nv))
                f = jacobi_sigma(params, lam, transform, psi, va[None], vb[None], vr[None])
                k = np.argmax(f, axis=1)
                vals[start : start + len(cc)] = f[np.arange(len(cc)), k]
                j = int(np.argmax(vals[start : start + len(cc)]))
                if vals[start + j] > best:
                    best = float(vals[start + j])
                    best_w = (psi[j, 0].copy(), va[k[j]], vb[k[j]], vr[k[j]])
            evaluations += m * len(combos)
            bounds = vals + h * lip_sum
            upper = max(float(bounds.max()), pruned_upper)
            levels += 1
            bar.update(1)
            if upper <= best * (1.0 + tol) or evaluations * (1 + 2**d) > budget:
                break
            keep = bounds > best * (1.0 + tol)
            if np.any(~keep):
                pruned_upper = max(pruned_upper, float(bounds[~keep].max()))
            h /= 2.0
            offsets = np.array(list(itertools.product((-h, h), repeat=d)))
            centres = (centres[keep][:, None, :] + offsets[None]).reshape(-1, d)
    assert best_w is not None
    return JacobiBnbResult(
        upper=upper * (1.0 + ROUNDOFF_RTOL), lower=best, witness=best_w, levels=levels, evaluations=evaluations
    )


def sigma_at_witness(params: VehicleParams, bounds: SigmaBounds, transform: JacobiTransform | None = None) -> float:
    """Re-evaluate ``||A_Delta||`` at the witness of ``bounds`` (1/s).

    A matrix-free Jacobi witness (large fleets) also stores the unit vector ``x`` that
    attained it (:attr:`SigmaWitness.vector`); its value is then ``||M x||``, recomputed in O(N), which is
    what :attr:`SigmaBounds.lower` records (a lower bound of the norm at that configuration).

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    bounds : SigmaBounds
        Vehicle- or Jacobi-coordinate bounds with their witness and lambda.
    transform : JacobiTransform, optional
        The Jacobi transform, needed for a Jacobi witness.
    """
    w = bounds.witness
    psi, u, v, r = (np.asarray(x, dtype=float) for x in (w.psi, w.u, w.v, w.r))
    if bounds.coords == "vehicle":
        g = inertial_block(params, psi, u, v, r) - bounds.lam * np.eye(2)
        return float(sigma_max_2x2(g).max())
    if transform is None:
        raise FormationError("a Jacobi witness needs its JacobiTransform")
    if w.vector is not None:
        x = np.asarray(w.vector, dtype=float).reshape(transform.n, 2)
        mx = jacobi_apply(_shifted_blocks(params, bounds.lam, psi, u, v, r), transform.kind, x)
        return float(np.linalg.norm(mx) / np.linalg.norm(x))
    return float(jacobi_sigma(params, bounds.lam, transform, psi, u, v, r))


__all__ = [
    "BNB_BUDGET",
    "BNB_MAX_N",
    "CHUNK",
    "DENSE_SIGMA_MAX_N",
    "KRYLOV_BATCH_FLOATS",
    "KRYLOV_BREAKDOWN",
    "KRYLOV_DIM",
    "JacobiBnbResult",
    "jacobi_apply",
    "jacobi_branch_and_bound",
    "jacobi_sigma",
    "jacobi_sigma_bounds",
    "jacobi_sigma_lower",
    "refinable",
    "sigma_at_witness",
]
