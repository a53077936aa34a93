"""Operating envelope and the constant lambda of the decomposition A = lam I + A_Delta."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .exceptions import EnvelopeError
from .vehicle import VehicleParams


def _interval(name: str, value: Any) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in value)
    except (TypeError, ValueError):
        raise EnvelopeError(f"envelope {name} must be a pair (min, max), got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise EnvelopeError(f"envelope {name} must be finite, got ({lo!r}, {hi!r})")
    if lo > hi:
        raise EnvelopeError(f"envelope {name} is empty: min {lo!r} > max {hi!r}")
    return lo, hi


def abs_range(lo: float, hi: float) -> tuple[float, float]:
    """Range of ``|x|`` for ``x`` in ``[lo, hi]``; contains 0 when the interval straddles it."""
    if lo <= 0.0 <= hi:
        return 0.0, max(-lo, hi)
    return min(abs(lo), abs(hi)), max(abs(lo), abs(hi))


@dataclass(frozen=True)
class Envelope:
    """Operating envelope shared by all vehicles.

    Parameters
    ----------
    u, v : tuple of float
        Surge and sway speed ranges (min, max), m/s, body frame.
    r : tuple of float
        Yaw-rate range, rad/s.
    psi : tuple of float
        Heading range, rad (default the full circle).

    Raises
    ------
    EnvelopeError
        If a range is reversed (empty), not a pair, or not finite.
    """

    u: tuple[float, float]
    v: tuple[float, float]
    r: tuple[float, float]
    psi: tuple[float, float] = (-math.pi, math.pi)

    def __post_init__(self) -> None:
        for name in ("u", "v", "r", "psi"):
            object.__setattr__(self, name, _interval(name, getattr(self, name)))

    def contains(self, u: Any, v: Any, r: Any) -> np.ndarray:
        """Boolean mask: is ``(u, v, r)`` inside the envelope (heading ignored: full circle)."""
        u_, v_, r_ = (np.asarray(a, dtype=float) for a in (u, v, r))
        return (
            (u_ >= self.u[0]) & (u_ <= self.u[1]) & (v_ >= self.v[0]) & (v_ <= self.v[1])
            & (r_ >= self.r[0]) & (r_ <= self.r[1])
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {k: list(v) for k, v in asdict(self).items()}


def envelope_lambda(params: VehicleParams, envelope: Envelope) -> float:
    """Most negative ``min(-d11/m11, -d22/m22)`` over the envelope (1/s).

    Damping grows with ``|u|`` and ``|v|``, so the minimum is at the largest ``|u|`` and
    ``|v|`` of the envelope. A constant lambda is what an LTI small-gain certificate needs
    (PAPER-NOTES item 8); lowering lambda by delta raises sigma by at most delta, so the
    required gain ``sigma + lam`` never gets worse.
    """
    umax = abs_range(*envelope.u)[1]
    vmax = abs_range(*envelope.v)[1]
    d11, d22, _ = params.damping(umax, vmax, 0.0)
    return float(min(-d11 / params.m11, -d22 / params.m22))
