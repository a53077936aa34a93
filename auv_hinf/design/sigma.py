"""Certified bounds on sigma = ||A_Delta||_2 over an operating envelope.

Vehicle coordinates (exact)
---------------------------
``A_Delta`` in vehicle coordinates is ``blockdiag(G_i - lam I)``. Its norm is the largest
block norm, and ``||G_i - lam I||`` does not depend on ``psi_i``
(``R`` is orthogonal), so it equals ``||B(|u|, |v|, r) - lam I||`` with ``B`` the body-frame block
``[[-d11/m11, (m22-m11) r/m11], [(m22-m11) r/m22, -d22/m22]]``. Every entry of ``B`` is
affine in ``(|u|, |v|, r)``, and the spectral norm is convex, so the supremum over the box
``|u| x |v| x r`` is attained at one of its 8 vertices. The vertex maximum is therefore the
exact supremum; the certified upper bound adds only a round-off allowance
(:data:`ROUNDOFF_RTOL`), and the lower bound is the same vertex, returned as a witness.

Jacobi-coordinate bounds are in :mod:`auv_hinf.design.jacobi_sigma`. The small-gain certificate uses
vehicle coordinates, which is legitimate because the nominal loop ``(lam - alpha) I`` is the
same in every coordinate system (``docs/derivations/sigma.md``).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import EnvelopeError
from auv_hinf.models.envelope import Envelope, abs_range
from auv_hinf.models.vehicle import VehicleParams, body_block

#: Relative allowance for round-off in the closed-form 2x2 norm (a few ulps, generous).
ROUNDOFF_RTOL = 1e-12


def sigma_max_2x2(m: ArrayLike) -> FloatArray:
    """Largest singular value of stacked 2x2 matrices, closed form, shape ``(...)``.

    For ``[[a, b], [c, d]]``:
    ``(sqrt((a+d)^2 + (b-c)^2) + sqrt((a-d)^2 + (b+c)^2)) / 2``.

    Parameters
    ----------
    m : array_like, shape (..., 2, 2)
        The matrices.
    """
    x = np.asarray(m, dtype=float)
    a, b, c, d = x[..., 0, 0], x[..., 0, 1], x[..., 1, 0], x[..., 1, 1]
    out: FloatArray = 0.5 * (np.hypot(a + d, b - c) + np.hypot(a - d, b + c))
    return out


def _signed(value: float, interval: tuple[float, float]) -> float:
    """A point of ``interval`` whose absolute value is ``value``."""
    return value if interval[0] <= value <= interval[1] else -value


@dataclass(frozen=True)
class SigmaWitness:
    """A configuration of the fleet at which a sigma lower bound is attained.

    Attributes
    ----------
    u, v : tuple of float
        Per-vehicle surge and sway (m/s, body frame).
    r : tuple of float
        Per-vehicle yaw rate (rad/s).
    psi : tuple of float
        Per-vehicle heading (rad).
    vector : tuple of float or None
        For a matrix-free Jacobi bound, the unit vector ``x`` (length 2N) with
        ``||M x|| = lower``; ``None`` when the bound is an exact norm.
    """

    u: tuple[float, ...]
    v: tuple[float, ...]
    r: tuple[float, ...]
    psi: tuple[float, ...]
    vector: tuple[float, ...] | None = None

    def to_dict(self) -> dict[str, list[float]]:
        """JSON-safe dictionary (``vector`` only when present)."""
        out = {"u": list(self.u), "v": list(self.v), "r": list(self.r), "psi": list(self.psi)}
        if self.vector is not None:
            out["vector"] = list(self.vector)
        return out


def _witness(envelope: Envelope, psi: ArrayLike, a: ArrayLike, b: ArrayLike, r: ArrayLike) -> SigmaWitness:
    """Witness from per-vehicle headings and vertex values of ``|u|, |v|, r``."""
    return SigmaWitness(
        u=tuple(_signed(float(x), envelope.u) for x in np.ravel(a)),
        v=tuple(_signed(float(x), envelope.v) for x in np.ravel(b)),
        r=tuple(float(x) for x in np.ravel(r)),
        psi=tuple(float(x) for x in np.ravel(psi)),
    )


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
    witness : SigmaWitness
        The configuration reaching ``lower``.
    lam : float
        The lambda used (1/s).
    """

    upper: float
    lower: float
    coords: str
    method: str
    witness: SigmaWitness
    lam: float = 0.0

    @property
    def gap(self) -> float:
        """``upper - lower`` (1/s)."""
        return self.upper - self.lower

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "upper": self.upper,
            "lower": self.lower,
            "gap": self.gap,
            "coords": self.coords,
            "method": self.method,
            "witness": self.witness.to_dict(),
            "lambda": self.lam,
        }


def _vehicle_bounds(params: VehicleParams, envelope: Envelope, lam: float, n: int) -> SigmaBounds:
    a_rng, b_rng = abs_range(*envelope.u), abs_range(*envelope.v)
    verts = np.array(list(itertools.product(a_rng, b_rng, envelope.r)))
    blocks = body_block(params, verts[:, 0], verts[:, 1], verts[:, 2]) - lam * np.eye(2)
    norms = sigma_max_2x2(blocks)
    k = int(np.argmax(norms))
    best = float(norms[k])
    a, b, r = verts[k]
    witness = _witness(envelope, np.zeros(n), np.full(n, a), np.full(n, b), np.full(n, r))
    return SigmaBounds(
        upper=best * (1.0 + ROUNDOFF_RTOL) + 1e-300,
        lower=best,
        coords="vehicle",
        method="exact: convex norm of an affine block, maximised at the 8 box vertices",
        witness=witness,
        lam=lam,
    )


def vehicle_sigma(params: VehicleParams, envelope: Envelope, lam: float, n: int = 1) -> SigmaBounds:
    """Exact vehicle-coordinate sigma: the largest ``||B - lam I||`` over the 8 box vertices.

    Parameters
    ----------
    params : VehicleParams
        Vehicle parameters (all vehicles alike).
    envelope : Envelope
        Ranges of u, v (m/s) and r (rad/s); the norm does not depend on psi.
    lam : float
        Constant lambda of the decomposition (1/s).
    n : int
        Number of vehicles in the witness (each gets the same vertex).

    Returns
    -------
    SigmaBounds
        ``upper`` certified (vertex value plus :data:`ROUNDOFF_RTOL`), ``lower`` the vertex value.
    """
    if not np.isfinite(lam):
        raise EnvelopeError(f"lambda must be finite, got {lam!r}")
    return _vehicle_bounds(params, envelope, float(lam), n)


def sigma_grid(
    params: VehicleParams,
    lam: float,
    x_values: ArrayLike,
    r_values: ArrayLike,
    *,
    axis: Literal["u", "v"] = "u",
    other: float = 0.0,
) -> FloatArray:
    """Vehicle-coordinate sigma on a slice, shape ``(len(r_values), len(x_values))``.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    lam : float
        Envelope lambda (1/s).
    x_values : array_like, shape (K,)
        Surge (``axis="u"``) or sway (``axis="v"``) speeds (m/s, body frame): the columns.
    r_values : array_like, shape (R,)
        Yaw rates (rad/s): the rows.
    axis : {"u", "v"}
        Which speed ``x_values`` sweeps.
    other : float
        The other speed (m/s), held fixed.
    """
    x = np.asarray(x_values, dtype=float)
    r = np.asarray(r_values, dtype=float)
    xx, rr = np.meshgrid(x, r)
    if axis == "u":
        blocks = body_block(params, xx, other, rr)
    else:
        blocks = body_block(params, other, xx, rr)
    return sigma_max_2x2(blocks - lam * np.eye(2))


__all__ = ["ROUNDOFF_RTOL", "SigmaBounds", "SigmaWitness", "sigma_grid", "sigma_max_2x2", "vehicle_sigma"]
