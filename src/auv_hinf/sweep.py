"""Certified bounds on sigma = ||A_Delta||_2 over an operating envelope.

Vehicle coordinates (exact)
---------------------------
``A_Delta`` in vehicle coordinates is ``blockdiag(G_i - lam I)``. Its norm is the largest
block norm (PAPER-NOTES item 5), and ``||G_i - lam I||`` does not depend on ``psi_i``
(item 4), so it equals ``||B(|u|, |v|, r) - lam I||`` with ``B`` the body-frame block
``[[-d11/m11, (m22-m11) r/m11], [(m22-m11) r/m22, -d22/m22]]``. Every entry of ``B`` is
affine in ``(|u|, |v|, r)``, and the spectral norm is convex, so the supremum over the box
``|u| x |v| x r`` is attained at one of its 8 vertices. The vertex maximum is therefore the
exact supremum; the certified upper bound adds only a round-off allowance
(:data:`ROUNDOFF_RTOL`), and the lower bound is the same vertex, returned as a witness.

Jacobi coordinates (bounded)
----------------------------
``||Phi B Phi^-1|| <= cond(Phi) ||B||`` gives a certified upper bound
``cond(Phi) * sigma_vehicle`` (item 6). The lower bound is the best of a seeded random
search over per-vehicle vertices and headings; the reported gap is honest, not closed.
The small-gain certificate uses vehicle coordinates, which is legitimate because the
nominal loop ``(lam - alpha) I`` is the same in every coordinate system (item 7).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from .envelope import Envelope, abs_range
from .exceptions import EnvelopeError, FormationError
from .formation import JacobiTransform, block_diag_stack
from .vehicle import FloatArray, VehicleParams, body_block, inertial_block

Coords = Literal["vehicle", "jacobi"]

#: Relative allowance for round-off in the closed-form 2x2 norm (a few ulps, generous).
ROUNDOFF_RTOL = 1e-12
#: Chunk size (points) of vectorised evaluations: bounds memory for fine grids.
CHUNK = 200_000


def sigma_max_2x2(m: ArrayLike) -> FloatArray:
    """Largest singular value of stacked 2x2 matrices, closed form, shape ``(...)``.

    For ``[[a, b], [c, d]]``:
    ``(sqrt((a+d)^2 + (b-c)^2) + sqrt((a-d)^2 + (b+c)^2)) / 2``.
    """
    x = np.asarray(m, dtype=float)
    a, b, c, d = x[..., 0, 0], x[..., 0, 1], x[..., 1, 0], x[..., 1, 1]
    return 0.5 * (np.hypot(a + d, b - c) + np.hypot(a - d, b + c))


def _signed(value: float, interval: tuple[float, float]) -> float:
    """A point of ``interval`` whose absolute value is ``value``."""
    return value if interval[0] <= value <= interval[1] else -value


@dataclass(frozen=True)
class SigmaBounds:
    """Bounds on ``sigma = sup ||A_Delta||_2`` over an envelope.

    Attributes
    ----------
    upper : float
        Certified: provably >= the true supremum (1/s).
    lower : float
        Attained at :attr:`witness` (1/s).
    coords : {"vehicle", "jacobi"}
    method : str
        How the upper bound was obtained.
    witness : dict
        Per-vehicle ``u, v`` (m/s), ``r`` (rad/s), ``psi`` (rad) lists reaching ``lower``.
    lam : float
        The lambda used (1/s).
    """

    upper: float
    lower: float
    coords: str
    method: str
    witness: dict[str, list[float]] = field(default_factory=dict)
    lam: float = 0.0

    @property
    def gap(self) -> float:
        """``upper - lower`` (1/s)."""
        return self.upper - self.lower

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "upper": self.upper, "lower": self.lower, "gap": self.gap, "coords": self.coords,
            "method": self.method, "witness": self.witness, "lambda": self.lam,
        }


def _vehicle_bounds(params: VehicleParams, envelope: Envelope, lam: float, n: int) -> SigmaBounds:
    a_rng, b_rng = abs_range(*envelope.u), abs_range(*envelope.v)
    verts = np.array(list(itertools.product(a_rng, b_rng, envelope.r)))
    blocks = body_block(params, verts[:, 0], verts[:, 1], verts[:, 2]) - lam * np.eye(2)
    norms = sigma_max_2x2(blocks)
    k = int(np.argmax(norms))
    best = float(norms[k])
    a, b, r = verts[k]
    witness = {
        "u": [_signed(float(a), envelope.u)] * n,
        "v": [_signed(float(b), envelope.v)] * n,
        "r": [float(r)] * n,
        "psi": [0.0] * n,
    }
    return SigmaBounds(
        upper=best * (1.0 + ROUNDOFF_RTOL) + 1e-300, lower=best, coords="vehicle",
        method="exact: convex norm of an affine block, maximised at the 8 box vertices",
        witness=witness, lam=lam,
    )


def jacobi_sigma(
    params: VehicleParams, lam: float, transform: JacobiTransform,
    psi: ArrayLike, u: ArrayLike, v: ArrayLike, r: ArrayLike,
) -> FloatArray:
    """``||Phi blockdiag(G_i - lam I) Phi^-1||_2`` at stacked states ``(..., N)``."""
    g = inertial_block(params, psi, u, v, r) - lam * np.eye(2)
    a = transform.matrix @ block_diag_stack(g) @ transform.matrix_inv
    return np.linalg.svd(a, compute_uv=False)[..., 0]


def sigma_bounds(
    params: VehicleParams,
    envelope: Envelope,
    lam: float,
    *,
    coords: Coords = "vehicle",
    transform: JacobiTransform | None = None,
    n: int | None = None,
    samples: int = 20_000,
    seed: int = 0,
    progress: bool = False,
) -> SigmaBounds:
    """Certified upper and witnessed lower bounds on ``||A_Delta||`` over ``envelope``.

    Parameters
    ----------
    params : VehicleParams
        Vehicle parameters (all vehicles alike).
    envelope : Envelope
        Ranges of u, v (m/s), r (rad/s), psi (rad).
    lam : float
        Constant lambda of the decomposition (1/s).
    coords : {"vehicle", "jacobi"}
        Coordinates in which the norm is taken. ``"jacobi"`` needs ``transform``.
    transform : JacobiTransform, optional
        Jacobi transform for ``coords="jacobi"``.
    n : int, optional
        Number of vehicles for the witness (defaults to ``transform.n`` or 1).
    samples : int
        Random configurations for the Jacobi lower bound.
    seed : int
        Seed of the Jacobi search (``numpy.random.default_rng``).
    progress : bool
        Show a tqdm bar for the Jacobi search.
    """
    if not np.isfinite(lam):
        raise EnvelopeError(f"lambda must be finite, got {lam!r}")
    nveh = n if n is not None else (transform.n if transform is not None else 1)
    veh = _vehicle_bounds(params, envelope, float(lam), nveh)
    if coords == "vehicle":
        return veh
    if coords != "jacobi":
        raise EnvelopeError(f"coords must be 'vehicle' or 'jacobi', got {coords!r}")
    if transform is None:
        raise FormationError("coords='jacobi' needs a JacobiTransform")
    nv = transform.n
    rng = np.random.default_rng(seed)
    a_rng, b_rng = abs_range(*envelope.u), abs_range(*envelope.v)
    best, best_x = -np.inf, None
    chunk = max(1, min(samples, CHUNK // (4 * nv * nv)))
    done = 0
    with tqdm(total=samples, disable=not progress, desc="Jacobi sigma search", unit="cfg") as bar:
        while done < samples:
            m = min(chunk, samples - done)
            a = np.asarray(a_rng)[rng.integers(0, 2, (m, nv))]
            b = np.asarray(b_rng)[rng.integers(0, 2, (m, nv))]
            r = np.asarray(envelope.r)[rng.integers(0, 2, (m, nv))]
            psi = rng.uniform(envelope.psi[0], envelope.psi[1], (m, nv))
            vals = jacobi_sigma(params, lam, transform, psi, a, b, r)
            k = int(np.argmax(vals))
            if vals[k] > best:
                best, best_x = float(vals[k]), (psi[k], a[k], b[k], r[k])
            done += m
            bar.update(m)
    assert best_x is not None
    psi_w, a_w, b_w, r_w = best_x
    witness = {
        "u": [_signed(float(x), envelope.u) for x in a_w],
        "v": [_signed(float(x), envelope.v) for x in b_w],
        "r": [float(x) for x in r_w],
        "psi": [float(x) for x in psi_w],
    }
    upper = transform.cond * veh.upper * (1.0 + ROUNDOFF_RTOL)
    return SigmaBounds(
        upper=max(upper, best), lower=best, coords="jacobi",
        method=f"cond(Phi) * sigma_vehicle (cond = {transform.cond:.4g}); lower from {samples} random vertex configurations",
        witness=witness, lam=float(lam),
    )


def sigma_at_witness(params: VehicleParams, bounds: SigmaBounds, transform: JacobiTransform | None = None) -> float:
    """Re-evaluate ``||A_Delta||`` at the witness of ``bounds`` (1/s)."""
    w = bounds.witness
    psi, u, v, r = (np.asarray(w[k], dtype=float) for k in ("psi", "u", "v", "r"))
    if bounds.coords == "vehicle":
        g = inertial_block(params, psi, u, v, r) - bounds.lam * np.eye(2)
        return float(np.linalg.norm(block_diag_stack(g), 2))
    if transform is None:
        raise FormationError("a Jacobi witness needs its JacobiTransform")
    return float(jacobi_sigma(params, bounds.lam, transform, psi, u, v, r))


def sigma_grid(
    params: VehicleParams, lam: float, x_values: ArrayLike, r_values: ArrayLike,
    *, axis: Literal["u", "v"] = "u", other: float = 0.0,
) -> FloatArray:
    """Vehicle-coordinate sigma on a slice, shape ``(len(r_values), len(x_values))``.

    ``axis="u"`` sweeps surge (m/s) with sway fixed at ``other``; ``axis="v"`` sweeps sway
    with surge fixed at ``other``. Rows follow ``r_values`` (rad/s).
    """
    x = np.asarray(x_values, dtype=float)
    r = np.asarray(r_values, dtype=float)
    xx, rr = np.meshgrid(x, r)
    if axis == "u":
        blocks = body_block(params, xx, other, rr)
    else:
        blocks = body_block(params, other, xx, rr)
    return sigma_max_2x2(blocks - lam * np.eye(2))
