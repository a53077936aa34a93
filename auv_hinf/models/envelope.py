"""Operating envelope and the constant lambda of the decomposition A = lam I + A_Delta."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import EnvelopeError
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.integrators import EventBound, EventFn

#: Names of the envelope ranges, in order: surge, sway (m/s), yaw rate (rad/s), heading (rad).
ENVELOPE_FIELDS = ("u", "v", "r", "psi")
#: Widest heading range (rad): a full turn. Wider ranges would count headings twice.
PSI_MAX_WIDTH = 2.0 * math.pi


def check_interval(name: str, value: Any) -> tuple[float, float]:
    """Validate one envelope range and return it as ``(min, max)`` floats.

    Parameters
    ----------
    name : str
        Range name (``u``, ``v``, ``r`` or ``psi``), used in the message.
    value : Any
        A pair of real numbers ``(min, max)``; ints and numpy scalars are accepted,
        strings and booleans are not.

    Returns
    -------
    tuple of float
        ``(min, max)`` as floats.

    Raises
    ------
    EnvelopeError
        If ``value`` is not a pair of real numbers, is not finite, is reversed (empty),
        or, for ``psi``, is wider than a full turn ``2 pi``.
    """
    try:
        items = list(value)
    except TypeError:
        items = []
    if len(items) != 2 or not all(isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_)) for x in items):
        raise EnvelopeError(f"envelope {name} must be a pair (min, max) of numbers, got {value!r}")
    lo, hi = float(items[0]), float(items[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise EnvelopeError(f"envelope {name} must be finite, got ({lo!r}, {hi!r})")
    if lo > hi:
        raise EnvelopeError(f"envelope {name} is empty: min {lo!r} > max {hi!r}")
    if name == "psi" and hi - lo > PSI_MAX_WIDTH:
        raise EnvelopeError(
            f"envelope psi must span at most a full turn 2 pi rad, got ({lo!r}, {hi!r}) (width {hi - lo:.6g} rad)"
        )
    return lo, hi


def abs_range(lo: float, hi: float) -> tuple[float, float]:
    """Range of ``|x|`` for ``x`` in ``[lo, hi]``; contains 0 when the interval straddles it.

    Parameters
    ----------
    lo, hi : float
        Ends of the interval (``lo <= hi``), in the unit of ``x``.
    """
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
        Heading range, rad (default the full circle); at most ``2 pi`` wide.

    Raises
    ------
    EnvelopeError
        If a range is reversed (empty), not a pair of numbers, not finite, or (``psi``)
        wider than a full turn. See :func:`check_interval`, which also validates the
        ``[envelope]`` table of a configuration file.
    """

    u: tuple[float, float]
    v: tuple[float, float]
    r: tuple[float, float]
    psi: tuple[float, float] = (-math.pi, math.pi)

    def __post_init__(self) -> None:
        for name in ENVELOPE_FIELDS:
            object.__setattr__(self, name, check_interval(name, getattr(self, name)))

    def contains(self, u: Any, v: Any, r: Any) -> np.ndarray:
        """Boolean mask: is ``(u, v, r)`` inside the envelope (heading ignored: full circle).

        Parameters
        ----------
        u, v : array_like
            Surge and sway speed, m/s (body frame).
        r : array_like
            Yaw rate, rad/s.
        """
        u_, v_, r_ = (np.asarray(a, dtype=float) for a in (u, v, r))
        return (
            (u_ >= self.u[0])
            & (u_ <= self.u[1])
            & (v_ >= self.v[0])
            & (v_ <= self.v[1])
            & (r_ >= self.r[0])
            & (r_ <= self.r[1])
        )

    def box_margins(self, u: tuple[float, float], v: float, r: float) -> dict[str, float]:
        """Margin of each side of a box of motions inside the envelope (negative: outside).

        The box is a surge speed range ``u`` and sway speed and yaw rate magnitudes ``|v| <= v``,
        ``|r| <= r``, as the certificates bound them.

        Parameters
        ----------
        u : tuple of float
            ``[min, max]`` of the surge speed (m/s, body frame).
        v : float
            Bound of ``|v|`` (m/s).
        r : float
            Bound of ``|r|`` (rad/s).

        Returns
        -------
        dict of str to float
            ``{u_min, u_max, v_min, v_max, r_min, r_max}`` (m/s, m/s, m/s, m/s, rad/s, rad/s).
        """
        return {
            "u_min": u[0] - self.u[0],
            "u_max": self.u[1] - u[1],
            "v_min": -v - self.v[0],
            "v_max": self.v[1] - v,
            "r_min": -r - self.r[0],
            "r_max": self.r[1] - r,
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary ``{"u": [min, max], ...}`` (also a valid ``[envelope]`` table)."""
        return {f.name: list(getattr(self, f.name)) for f in fields(self)}


#: The envelope of the paper's Section V study: u in [0, 3.5] m/s, v in [-1, 1] m/s,
#: r in [-0.5, 0.5] rad/s, full heading circle. Also the default of a configuration file.
PAPER_ENVELOPE = Envelope(u=(0.0, 3.5), v=(-1.0, 1.0), r=(-0.5, 0.5))


def envelope_lambda(params: VehicleParams, envelope: Envelope) -> float:
    """Most negative ``min(-d11/m11, -d22/m22)`` over the envelope (1/s).

    Damping grows with ``|u|`` and ``|v|``, so the minimum is at the largest ``|u|`` and
    ``|v|`` of the envelope. A constant lambda is what an LTI small-gain certificate needs;
    lowering lambda by delta raises sigma by at most delta, so the required gain
    ``sigma + lam`` never gets worse.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    envelope : Envelope
        Operating envelope (its ``u`` and ``v`` ranges are used).
    """
    umax = abs_range(*envelope.u)[1]
    vmax = abs_range(*envelope.v)[1]
    d11, d22, _ = params.damping(umax, vmax, 0.0)
    return float(min(-d11 / params.m11, -d22 / params.m22))


def envelope_margin(envelope: Envelope, states: FloatArray) -> FloatArray:
    """Smallest distance of ``(u, v, r)`` to the envelope's bounds, shape ``states.shape[:-1]``.

    Positive inside, zero on the boundary, negative outside. Units mix m/s and rad/s; only
    the sign and the roots matter (the first root is the first exit time).

    Parameters
    ----------
    envelope : Envelope
        Operating envelope (heading ignored).
    states : ndarray, shape (..., 6) or wider
        Vehicle states whose components 3-5 are ``u, v`` (m/s, body frame) and ``r`` (rad/s).
    """
    u, v, r = states[..., 3], states[..., 4], states[..., 5]
    margin: FloatArray = np.minimum.reduce(
        [
            u - envelope.u[0],
            envelope.u[1] - u,
            v - envelope.v[0],
            envelope.v[1] - v,
            r - envelope.r[0],
            envelope.r[1] - r,
        ]
    )
    return margin


def envelope_event(envelope: Envelope, n: int, width: int = 6) -> EventFn:
    """The exit event of flat states ``(..., width n)``: the smallest envelope margin of their ``n`` vehicles.

    Parameters
    ----------
    envelope : Envelope
        Operating envelope.
    n : int
        Number of vehicles per system.
    width : int
        State size per vehicle: 6, or 8 with an integrator (see
        :attr:`~auv_hinf.law.formation_law.VehicleLaw.width`).
    """

    def event(t: FloatArray, y: FloatArray) -> FloatArray:
        margin: FloatArray = envelope_margin(envelope, y.reshape((*y.shape[:-1], n, width))).min(axis=-1)
        return margin

    return event


def envelope_bound(envelope: Envelope, n: int, width: int = 6) -> EventBound:
    """Sound lower bound of the envelope event over a box of flat states (see ``EventBound``).

    Each margin is one of ``u``, ``v``, ``r`` minus or plus a constant, so over ``|y' - y| <= radius``
    it is at least its value at ``y`` minus that component's radius.

    Parameters
    ----------
    envelope : Envelope
        Operating envelope.
    n : int
        Number of vehicles per system (1 for vehicle systems).
    width : int
        State size per vehicle.
    """

    def bound(y: FloatArray, radius: FloatArray) -> FloatArray:
        s, rad = y.reshape(*y.shape[:-1], n, width), radius.reshape(*radius.shape[:-1], n, width)
        low: FloatArray = (envelope_margin(envelope, s) - rad[..., 3:6].max(axis=-1)).min(axis=-1)
        return low

    return bound


__all__ = [
    "ENVELOPE_FIELDS",
    "PAPER_ENVELOPE",
    "PSI_MAX_WIDTH",
    "Envelope",
    "abs_range",
    "check_interval",
    "envelope_bound",
    "envelope_event",
    "envelope_lambda",
    "envelope_margin",
]
