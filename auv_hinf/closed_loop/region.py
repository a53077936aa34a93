"""Invariant regions of the per-vehicle error loops and their operating-envelope margins.

Vehicle i's errors obey, while its body velocities ``(u, v, r)`` stay in the envelope,

* position: ``e'' = (lam - alpha) e' + D(t) e' - k1 e`` with ``||D(t)|| <= sigma``;
* heading:  ``e_psi'' = -k1psi e_psi - c(t) e_psi'`` with ``c(t)`` in ``[c_lo, c_hi]``;

and its body velocities are ``u = S cos(delta + e_psi) + w1``,
``v = -S sin(delta + e_psi) + w2`` (``|w| = ||e'||``), ``r = psi_d' + e_psi'``. A quadratic
Lyapunov function ``V`` that does not increase (LMI at ``beta = 0``) bounds the errors by
its sub-level set through the start set; the bounds give the velocities by interval
arithmetic over the reference tube (:func:`envelope_margins`).

First-exit argument (why margins ``>= 0`` suffice). ``sigma`` and the range of ``c`` are
taken over the envelope inflated by ``eta`` = :data:`~auv_hinf.mission.margins.ENVELOPE_INFLATION_RTOL` times its
scale (:func:`inflate_envelope`). Let ``T`` be the first time the body velocities leave the
inflated box. On ``[0, T)`` the loops satisfy their LMIs, so the errors obey the bounds
and, the computed margins being ``>= 0``, the velocities lie in the nominal box up to
floating-point round-off (about 1e-15 of the scale, far below ``eta``). By continuity they
are in that closed set at ``T`` too, which is interior to the inflated box, so they stay in
it a little longer: a contradiction, hence ``T = inf``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import partial
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.closed_loop.lyapunov import LyapunovResult, lmi_heading_region, lmi_position_region
from auv_hinf.design.sigma import vehicle_sigma
from auv_hinf.exceptions import DesignError, SolverError
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import (
    MAX_HEADING_ERROR,
    ErrorBounds,
    Margins,
    envelope_margins,
    heading_c_range,
    inflate_envelope,
)
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.bisection import bisect, largest_holding
from auv_hinf.numerics.quadratic_forms import ellipsoid_extent

#: Relative width at which the bisections on a region scale stop.
REGION_RTOL = 1e-5
#: Absolute width (m, m/s, rad or rad/s) at which a start radius search stops: a radius below it is
#: no start region (it keeps a search from bisecting towards zero when no size certifies).
REGION_ATOL = 1e-12
#: Absolute width (rad) at which the bisection on the heading budget stops.
ANGLE_ATOL = 1e-12
#: Doublings allowed while bracketing a single-axis radius (2^60 times the initial 1 unit).
_MAX_DOUBLINGS = 60


@dataclass(frozen=True)
class Region:
    """Simultaneous start set of one vehicle's errors.

    Every start with ``||e(0)|| <= position`` (m), ``||e'(0)|| <= velocity`` (m/s),
    ``|e_psi(0)| <= heading`` (rad) and ``|e_psi'(0)| <= yaw_rate`` (rad/s), all at once, is
    covered. The errors are taken against the reference at ``t = 0``.

    Attributes
    ----------
    position : float
        Radius of the position error ``||e(0)||`` (m).
    velocity : float
        Radius of the velocity error ``||e'(0)||`` (m/s).
    heading : float
        Radius of the heading error ``|e_psi(0)|`` (rad).
    yaw_rate : float
        Radius of the yaw-rate error ``|e_psi'(0)|`` (rad/s).
    """

    position: float
    velocity: float
    heading: float
    yaw_rate: float

    def scaled(self, kappa: float) -> Region:
        """All four radii times ``kappa``.

        Parameters
        ----------
        kappa : float
            Common factor (dimensionless).
        """
        return Region(*(float(kappa * x) for x in self.as_array()))

    def as_array(self) -> FloatArray:
        """``[position, velocity, heading, yaw_rate]``."""
        return np.array([self.position, self.velocity, self.heading, self.yaw_rate])

    def to_dict(self) -> dict[str, float]:
        """JSON-safe dictionary."""
        return asdict(self)


@dataclass(frozen=True)
class RegionCertificate:
    """Largest certified simultaneous start region.

    Attributes
    ----------
    single_axis : Region
        Largest radius of each error *alone* (the others zero), NOT simultaneous.
    kappa : float
        Common fraction of the single-axis radii certified simultaneously.
    region : Region
        ``kappa * single_axis``: the simultaneous start region.
    bounds : ErrorBounds
        Sup-in-time error bounds over every start in ``region``.
    margins : Margins
        Envelope margins under ``bounds`` (all ``>= 0``).
    p2, q : ndarray or None
        Verified non-increasing Lyapunov matrices of the position and heading loops used
        for ``region`` (None when that loop starts at zero error and so stays there).
    sigma : float
        ``||D|| bound`` used (1/s): the larger of the given sigma and the certified sigma
        of the inflated envelope.
    c_range : tuple of float
        Range of the heading damping ``c`` (1/s) over the inflated envelope.
    """

    single_axis: Region
    kappa: float
    region: Region
    bounds: ErrorBounds
    margins: Margins
    p2: FloatArray | None
    q: FloatArray | None
    sigma: float
    c_range: tuple[float, float]

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "single_axis": self.single_axis.to_dict(),
            "kappa": self.kappa,
            "region": self.region.to_dict(),
            "bounds": self.bounds.to_dict(),
            "margins": self.margins.to_dict(),
            "p2": None if self.p2 is None else self.p2.tolist(),
            "q": None if self.q is None else self.q.tolist(),
            "sigma": self.sigma,
            "c_range": list(self.c_range),
        }


@dataclass(frozen=True)
class _Trial:
    ok: bool
    bounds: ErrorBounds
    margins: Margins | None
    p2: FloatArray | None
    q: FloatArray | None


class _RegionProblem:
    """Decides whether a start region is certified (verified P2, Q and exact margins)."""

    def __init__(
        self,
        lam: float,
        alpha: float,
        k1: float,
        sigma: float,
        k1psi: float,
        c_range: tuple[float, float],
        tube: ReferenceTube,
        envelope: Envelope,
    ) -> None:
        self.loop = (lam, alpha, k1, sigma)
        self.k1psi, self.c_range, self.tube, self.envelope = k1psi, c_range, tube, envelope
        self._p2: dict[tuple[float, float], LyapunovResult] = {}
        zero = envelope_margins(tube, ErrorBounds(0.0, 0.0, 0.0, 0.0), envelope)
        if not zero.ok:
            raise DesignError(f"the reference tube itself leaves the envelope (margins {zero.to_dict()})")
        self.yaw_budget = min(zero.r_hi, zero.r_lo)

    def position(self, rp: float, rv: float) -> tuple[float, float, FloatArray | None]:
        """Position and velocity extents (m, m/s) and the P2 giving them."""
        if rp == 0.0 and rv == 0.0:
            return 0.0, 0.0, None
        n = max(rp, rv)
        key = (rp / n, rv / n)  # the SDP is homogeneous: one solve per direction
        if key not in self._p2:
            self._p2[key] = lmi_position_region(*self.loop, *key)
        p2 = self._p2[key].matrix
        return (*ellipsoid_extent(p2, rp, rv), p2)

    def heading_budget(self, ev: float) -> float:
        """Largest heading-error bound (rad) that keeps the u, v margins ``>= 0`` at ``ev``."""

        def uv_ok(eh: float) -> bool:
            m = envelope_margins(self.tube, ErrorBounds(0.0, ev, eh, 0.0), self.envelope)
            return min(m.u_hi, m.u_lo, m.v_hi, m.v_lo) >= 0.0

        if not uv_ok(0.0):
            return -1.0
        return bisect(uv_ok, 0.0, MAX_HEADING_ERROR, atol=ANGLE_ATOL)[0]

    def trial(self, region: Region) -> _Trial:
        """Certify ``region``: solve for P2 and Q, then check the exact margins.

        A solve that fails (the solver's status, or the strict ``eigvalsh`` re-check of what it
        returns) certifies nothing: the region is not certified, and the bisection that asked
        goes on with smaller ones, each checked the same way. A solver symptom is never the answer.
        """
        try:
            ep, ev, p2 = self.position(region.position, region.velocity)
        except SolverError:
            return _Trial(False, ErrorBounds(math.inf, math.inf, math.inf, math.inf), None, None, None)
        rh, rr = region.heading, region.yaw_rate
        q: FloatArray | None = None
        eh = er = 0.0
        fail = _Trial(False, ErrorBounds(ep, ev, math.inf, math.inf), None, p2, None)
        if rh > 0.0 or rr > 0.0:
            b_psi, b_r = self.heading_budget(ev), self.yaw_budget
            if b_psi <= 0.0 or b_r <= 0.0:
                return fail
            n = max(rh, rr)
            try:
                budgets = ((b_psi / n) ** 2, (b_r / n) ** 2)
                q = lmi_heading_region(self.k1psi, self.c_range, rh / n, rr / n, budgets).matrix
            except SolverError:
                return fail
            eh, er = ellipsoid_extent(q, rh, rr)
            if eh >= MAX_HEADING_ERROR:
                return fail
        bounds = ErrorBounds(ep, ev, eh, er)
        margins = envelope_margins(self.tube, bounds, self.envelope)
        return _Trial(margins.ok, bounds, margins, p2, q)


def _axis_ok(prob: _RegionProblem, axis: FloatArray, k: float) -> bool:
    return prob.trial(Region(*(k * axis))).ok


def certify_region(
    params: VehicleParams,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    *,
    lam: float,
    sigma: float,
) -> RegionCertificate:
    """Largest simultaneous start region keeping every vehicle in the envelope.

    Each single-axis radius is the largest radius of that error alone (others zero) whose
    invariant-ellipsoid bounds keep all margins ``>= 0``, with P2 (position loop) and Q
    (heading loop) optimised for that start set (:func:`auv_hinf.closed_loop.lyapunov.lmi_position_region`,
    :func:`auv_hinf.closed_loop.lyapunov.lmi_heading_region`). Then the common fraction ``kappa`` of the four
    is maximised by bisection, re-optimising P2 and Q. The u/v budget shared by the
    velocity and heading errors is split exactly: the velocity extent is fixed by P2, the
    heading SDP gets the largest heading budget compatible with it.

    Parameters
    ----------
    params : VehicleParams
    envelope : Envelope
    tube : ReferenceTube
    gains : Gains
        ``alpha`` (1/s), ``k1`` (1/s^2), heading gains ``(k1psi, k2psi)`` (1/s^2, 1/s).
    lam : float
        Envelope lambda (1/s).
    sigma : float
        Bound of ``||G_i - lam I||`` (1/s); raised to the certified value on the inflated
        envelope if smaller (see the module docstring).

    Raises
    ------
    DesignError
        If ``alpha - lam <= sigma`` (no common quadratic Lyapunov function) or the tube
        already leaves the envelope at zero error.
    """
    alpha, k1, k_psi = gains.alpha, gains.k1, gains.k_psi
    inflated = inflate_envelope(envelope)
    sig = max(float(sigma), vehicle_sigma(params, inflated, lam).upper)
    if alpha - lam <= sig:
        raise DesignError(f"alpha - lambda = {alpha - lam:.6g} must exceed sigma = {sig:.6g} 1/s")
    c_range = heading_c_range(params, inflated, k_psi)
    prob = _RegionProblem(lam, alpha, k1, sig, k_psi[0], c_range, tube, envelope)
    axes = np.eye(4)
    single = []
    for axis in axes:
        hi = 1.0
        for _ in range(_MAX_DOUBLINGS):
            if not prob.trial(Region(*(hi * axis))).ok:
                break
            hi *= 2.0
        else:
            raise DesignError(f"single-axis radius along {axis} is unbounded: the margins never bind")
        single.append(
            largest_holding(partial(_axis_ok, prob, axis), hi, check_lo=False, rtol=REGION_RTOL, atol=REGION_ATOL)
        )
    single_axis = Region(*single)
    kappa = largest_holding(
        lambda k: prob.trial(single_axis.scaled(k)).ok, 1.0, check_lo=False, rtol=REGION_RTOL, atol=REGION_ATOL
    )
    region = single_axis.scaled(kappa)
    final = prob.trial(region)
    if not final.ok or final.margins is None:  # the bisection keeps only certified scales
        raise DesignError("the region found by bisection failed its final check")
    return RegionCertificate(
        single_axis=single_axis,
        kappa=kappa,
        region=region,
        bounds=final.bounds,
        margins=final.margins,
        p2=final.p2,
        q=final.q,
        sigma=sig,
        c_range=c_range,
    )


__all__ = ["ANGLE_ATOL", "REGION_ATOL", "REGION_RTOL", "Region", "RegionCertificate", "certify_region"]
