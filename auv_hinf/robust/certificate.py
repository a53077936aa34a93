"""Robust certificate: every plant of a declared box, every current up to a declared speed.

For each vehicle the perturbed position and heading error loops of
:mod:`auv_hinf.robust.box` get verified invariant ellipsoids (:mod:`auv_hinf.design.lmi.ellipsoid`).
They are coupled: the position disturbance grows with the heading error (through
``sin theta``) and the heading disturbance with the velocity error (through ``u v``). The
certificate assumes bounds ``(E_psi, E_v)``, computes the ellipsoids those assumptions allow,
and accepts when the ellipsoids are strictly inside the assumptions: by continuity a
trajectory that starts inside both ellipsoids can never be the first to violate an assumption
(the first-exit argument of :mod:`auv_hinf.certification.region`, with sigma on the envelope inflated by
1e-9). The assumptions come from the least fixed point of that map, inflated slightly.

What is certified, per vehicle and for every plant in the box and every constant current with
``|c| <= current``: a start inside both ellipsoids keeps its errors within ``bounds`` for all
``t >= 0``; ``V - 1`` decays at least as ``exp(-2 decay_rate t)``; the body velocities stay in
the envelope (``margins``) and the thrust within ``thrust``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.certification.levels import pair_level
from auv_hinf.certification.margins import MAX_HEADING_ERROR, ErrorBounds, Margins, envelope_margins, inflate_envelope
from auv_hinf.certification.thrust import ThrustBounds, ellipsoid_feedback, thrust_bounds
from auv_hinf.design.gains import Gains
from auv_hinf.design.lmi.ellipsoid import Ellipsoid, best_ellipsoid, heading_ellipsoid, position_ellipsoid
from auv_hinf.exceptions import AuvHinfError
from auv_hinf.models.actuators import Actuators, actuator_shortfall
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.reference import ReferenceTube
from auv_hinf.robust.box import (
    HeadingPerturbation,
    ParameterBox,
    TubeSummary,
    box_lambda,
    current_offset,
    heading_perturbation,
    position_disturbance,
)

#: Weight of the squared velocity half-width against ``l k1`` times the squared position
#: half-width in the position ellipsoid's objective: the velocity error decides the envelope
#: margins, so it is favoured (100 costs about 20 % in position and saves about 25 % in velocity).
VELOCITY_WEIGHT = 100.0
#: Relative change of the assumed heading bound at which the fixed-point iteration stops.
FIXED_POINT_RTOL = 1e-4
#: Iterations of the fixed point before giving up (it converges geometrically when it converges).
FIXED_POINT_ITERATIONS = 40
#: Relative inflations of the converged assumptions tried for the strict self-consistency check.
ASSUMPTION_INFLATIONS = (1e-2, 5e-2, 2e-1)

METHOD = (
    "per-vehicle perturbed error loops: multi-affine vertex sigma over the box, S-procedure invariant "
    "ellipsoid (position: ||D||<=sigma, ||L-l I||<=delta) and vertex LMI (heading: K, C boxes), "
    "fixed point of the coupling assumptions, interval envelope margins (first exit)"
)


@dataclass(frozen=True)
class RobustCertificate:
    """Verdict and numbers of the robust certificate for one box, current bound and gains.

    Attributes
    ----------
    gains : Gains
    box : ParameterBox
    current : float
        Bound of the current speed (m/s).
    stable : bool
        Both ellipsoids exist and the coupling assumptions are self-consistent.
    covers : bool
        ``stable``, the envelope holds with the error bounds, and the thrust is within the limit.
    bounds : ErrorBounds or None
        Per-vehicle error bounds over the certified set (m, m/s, rad, rad/s).
    assumptions : ErrorBounds or None
        The heading and velocity bounds assumed (strictly larger than the bounds).
    decay_rate : float or None
        ``min(a_position, a_heading)/2`` (1/s).
    lam, sigma : float
        Centre of ``G`` over the box and ``sup ||G - lam I||`` (1/s).
    gain_centre, gain_spread : float
        Centre and radius of the input gains ``m_jj_hat/m_jj``.
    position_disturbance : float or None
        Bound of ``|d|`` (m/s^2) under the assumptions.
    heading : HeadingPerturbation or None
    position_ellipsoid, heading_ellipsoid : Ellipsoid or None
        Per unit disturbance (scale by the disturbance bound).
    margins : Margins or None
    thrust : ThrustBounds or None
    reasons : tuple of str
        Why it does not cover (empty when it does).
    """

    gains: Gains
    box: ParameterBox
    current: float
    stable: bool
    covers: bool
    bounds: ErrorBounds | None
    assumptions: ErrorBounds | None
    decay_rate: float | None
    lam: float
    sigma: float
    gain_centre: float
    gain_spread: float
    position_disturbance: float | None = None
    heading: HeadingPerturbation | None = None
    position_ellipsoid: Ellipsoid | None = None
    heading_ellipsoid: Ellipsoid | None = None
    margins: Margins | None = None
    thrust: ThrustBounds | None = None
    reasons: tuple[str, ...] = field(default=())
    method: str = METHOD
    integral_bound: float | None = None

    def equilibrium_shift(self, current: ArrayLike) -> FloatArray:
        """The current-shifted equilibrium the position ellipsoid is about, shape of ``current``.

        Without integral action ``e_c = -lam c/(l k1)`` (m) in the position error; with it the
        integrator absorbs the constant part, ``z* = -lam c/(l ki)`` (m s), and the position
        error's equilibrium is zero. ``current`` is the inertial current (m/s), shape ``(..., 2)``.
        """
        gain = self.gains.ki if self.gains.integral else self.gains.k1
        out: FloatArray = -self.lam * np.asarray(current, dtype=float) / (self.gain_centre * gain)
        return out

    def start_inside(
        self, e: FloatArray, de: FloatArray, epsi: FloatArray, depsi: FloatArray, current: ArrayLike
    ) -> bool:
        """Every vehicle's start errors lie in both certified sets (False when there are none).

        ``e (N, 2)`` m and ``de (N, 2)`` m/s are the position and ground-velocity errors,
        ``epsi``, ``depsi`` ``(N,)`` the heading (rad) and yaw-rate (rad/s) errors, ``current``
        the inertial current (m/s). The sets are ``V(e - e_c, e') <= d^2`` (position ellipsoid
        on each axis pair) and ``W(e_psi, e_psi') <= h^2``.
        """
        pos, head, hp, d = self.position_ellipsoid, self.heading_ellipsoid, self.heading, self.position_disturbance
        if pos is None or head is None or hp is None or d is None:
            return False
        shift = self.equilibrium_shift(current)
        if self.gains.integral:  # (z~, e, e') with the integrator starting at z = 0
            x = np.stack(np.broadcast_arrays(-shift, np.asarray(e, dtype=float), np.asarray(de, dtype=float)), -1)
            vp = np.einsum("...ak,kl,...al->...", x, pos.matrix, x)
        else:
            vp = pair_level(pos.matrix, e - shift, de, planar=True)
        vh = pair_level(head.matrix, epsi, depsi)
        return bool(np.all(vp <= d**2) and np.all(vh <= hp.disturbance**2))

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe summary."""
        b = self.bounds
        return {
            "stable": self.stable,
            "covers": self.covers,
            "decay_rate": self.decay_rate,
            "ultimate_bounds": None
            if b is None
            else {"position": b.position, "velocity": b.velocity, "heading": b.heading, "yaw_rate": b.yaw_rate},
            "gains": self.gains.to_dict(),
            "lambda": self.lam,
            "sigma": self.sigma,
            "input_gain": [self.gain_centre - self.gain_spread, self.gain_centre + self.gain_spread],
            "position_disturbance": self.position_disturbance,
            "heading_stiffness": None if self.heading is None else list(self.heading.stiffness),
            "heading_damping": None if self.heading is None else list(self.heading.damping),
            "heading_disturbance": None if self.heading is None else self.heading.disturbance,
            "envelope_margins": None if self.margins is None else self.margins.to_dict(),
            "thrust": None if self.thrust is None else self.thrust.to_dict(),
            "current_speed": self.current,
            "reasons": list(self.reasons),
            "method": self.method,
        } | ({} if self.integral_bound is None else {"integral_bound": self.integral_bound})


def _stable_rate(a0: np.ndarray) -> float:
    """Twice the stability margin ``-max Re eig(a0)`` (1/s), the largest rate worth trying."""
    return float(-2.0 * np.linalg.eigvals(a0).real.max())


def _heading_rate(hp: HeadingPerturbation) -> float:
    k, c = hp.stiffness[0], hp.damping[0]
    roots = np.roots([1.0, c, k])
    return float(-2.0 * roots.real.max())


def _position_loop(
    box: ParameterBox, env: Envelope, summ: TubeSummary, gains: Gains, current: float, lam: float, sigma: float
) -> tuple[FloatArray, FloatArray, float, float | None]:
    """Centre matrix, delta-channel row, ``|z*|`` bound (m s) and ``P_zz`` cap of the position loop.

    With integral action the state is ``(z~, e, e')``, ``z~ = z - z*``, and the integrator starts
    at ``z = 0``: the start ``z~ = -z*`` must lie in ``{V <= d^2}`` for every admissible current.
    The disturbance bound ``d`` only grows with the assumed heading error, so its value at zero
    heading error is a lower bound, and ``P_zz <= (d_0/|z*|_max)^2`` keeps every such start inside.
    """
    lc, _ = box.input_gain()
    if not gains.integral:
        return (
            np.array([[0.0, 1.0], [-lc * gains.k1, lam - lc * gains.alpha]]),
            np.array([gains.k1, gains.alpha]),
            0.0,
            None,
        )
    a0 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-lc * gains.ki, -lc * gains.k1, lam - lc * gains.alpha]])
    c2 = np.array([gains.ki, gains.k1, gains.alpha])
    z_star = abs(lam) * current / (lc * gains.ki)
    if z_star == 0.0:
        return a0, c2, 0.0, None
    d0 = position_disturbance(box, env, summ, current, 0.0, lam, sigma)
    return a0, c2, z_star, (d0 / z_star) ** 2


def _heading_at(
    box: ParameterBox,
    env: Envelope,
    tube: TubeSummary,
    gains: Gains,
    current: float,
    velocity: float,
    heading: float,
) -> tuple[HeadingPerturbation, Ellipsoid | None]:
    hp = heading_perturbation(box, env, tube, gains.k_psi, current, velocity, heading)
    if hp.stiffness[0] <= 0.0 or hp.damping[0] <= 0.0:
        return hp, None
    weight = 1.0 / max(hp.stiffness[0], 1e-12)
    ell = best_ellipsoid(lambda a: heading_ellipsoid(hp.stiffness, hp.damping, a, weight), _heading_rate(hp), weight)
    return hp, ell


def robust_certificate(
    box: ParameterBox,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    current: float = 0.0,
    actuators: Actuators | None = None,
) -> RobustCertificate:
    """Certify the closed loop of ``gains`` for every plant of ``box`` and current ``<= current``.

    Parameters
    ----------
    box : ParameterBox
        Declared plant box around the controller's model.
    envelope : Envelope
        Operating envelope (body velocities, m/s and rad/s).
    tube : ReferenceTube
        Sound bounds of the desired motion (e.g. :func:`~auv_hinf.models.tubes.mission_tube`).
    gains : Gains
    current : float
        Bound of the constant current's speed (m/s, >= 0).
    actuators : Actuators, optional
        What the vehicles can push: the certificate covers only if its thrust bound fits.
    """
    env = inflate_envelope(envelope)
    lam, sigma = box_lambda(box, env)
    lc, spread = box.input_gain()
    base: dict[str, Any] = {"gains": gains, "box": box, "current": current, "lam": lam, "sigma": sigma}
    base |= {"gain_centre": lc, "gain_spread": spread}

    def fail(reason: str, **kw: Any) -> RobustCertificate:
        return RobustCertificate(
            stable=False, covers=False, bounds=None, assumptions=None, decay_rate=None, reasons=(reason,), **base, **kw
        )

    summ = TubeSummary.of(tube)
    a0, c2, z_star, cap = _position_loop(box, env, summ, gains, current, lam, sigma)
    if not np.all(np.linalg.eigvals(a0).real < 0):
        return fail("the centre of the perturbed position loop is not stable (alpha, k1 or ki)")
    wp = VELOCITY_WEIGHT / (lc * gains.k1)
    pos = best_ellipsoid(lambda a: position_ellipsoid(a0, sigma, spread, c2, a, wp, cap), _stable_rate(a0), wp)
    if pos is None:
        start = " that holds the integrator's start" if cap is not None else ""
        return fail(
            f"no invariant ellipsoid of the position loop{start} (sigma = {sigma:.4g} 1/s, "
            f"input-gain spread {spread:.3g})"
        )
    e_h = 0.0
    for _ in range(FIXED_POINT_ITERATIONS):
        e_v = position_disturbance(box, env, summ, current, e_h, lam, sigma) * pos.extents[1]
        hp, head = _heading_at(box, env, summ, gains, current, e_v, e_h)
        if head is None:
            return fail(
                f"heading loop not robustly stable: stiffness in [{hp.stiffness[0]:.4g}, {hp.stiffness[1]:.4g}] 1/s^2, "
                f"damping in [{hp.damping[0]:.4g}, {hp.damping[1]:.4g}] 1/s",
                position_ellipsoid=pos,
                heading=hp,
            )
        new = hp.disturbance * head.extents[0]
        if not new < MAX_HEADING_ERROR:
            return fail(f"the heading-error bound diverges ({new:.3g} rad)", position_ellipsoid=pos, heading=hp)
        done = abs(new - e_h) <= FIXED_POINT_RTOL * max(new, 1e-300)
        e_h = new
        if done:
            break
    for eta in ASSUMPTION_INFLATIONS:
        a_h = e_h * (1.0 + eta)
        dbar = position_disturbance(box, env, summ, current, a_h, lam, sigma)
        a_v = dbar * pos.extents[1] * (1.0 + eta)
        hp, head = _heading_at(box, env, summ, gains, current, a_v, a_h)
        if head is None:
            continue
        b_h, b_r = hp.disturbance * head.extents[0], hp.disturbance * head.extents[1]
        offset = 0.0 if gains.integral else current_offset(box, lam, current, gains.k1)
        b_p, b_v = dbar * pos.extents[0] + offset, dbar * pos.extents[1]
        if b_h <= a_h and b_v <= a_v and a_h < MAX_HEADING_ERROR:
            break
    else:
        return fail("the coupling assumptions are not self-consistent (the fixed point does not verify)")
    bounds = ErrorBounds(b_p, b_v, b_h, b_r)
    rest: dict[str, Any] = {
        "bounds": bounds,
        "assumptions": ErrorBounds(b_p, a_v, a_h, b_r),
        "decay_rate": 0.5 * min(pos.rate, head.rate),
        "position_disturbance": dbar,
        "heading": hp,
        "position_ellipsoid": pos,
        "heading_ellipsoid": head,
    }
    reasons: list[str] = []
    try:
        margins: Margins | None = envelope_margins(tube, ErrorBounds(b_p, b_v + current, b_h, b_r), envelope)
    except AuvHinfError as exc:
        margins = None
        reasons.append(f"envelope margins: {exc}")
    if margins is not None and not margins.ok:
        reasons.append(f"the envelope does not hold with these error bounds (smallest margin {margins.min:.4g})")
    b_z = dbar * pos.integral_extent + z_star if gains.integral else None  # |z| <= |z~| + |z*| (m s)
    # the feedback on the ellipsoid about the shifted equilibrium, plus the equilibrium's own:
    # l times it cancels -lam c, so |k1 e_c| = |ki z*| = |lam| c / l with or without integral action
    feedback = ellipsoid_feedback(pos.matrix, c2, dbar**2) + abs(lam) * current / lc
    thrust = thrust_bounds(box.nominal, env, tube, bounds, gains, current, b_z or 0.0, feedback)
    if actuators is not None and not actuators.admits(thrust.as_tuple()):
        reasons.append(actuator_shortfall(actuators, thrust.as_tuple()))
    return RobustCertificate(
        stable=True,
        covers=not reasons,
        margins=margins,
        thrust=thrust,
        reasons=tuple(reasons),
        integral_bound=b_z,
        **base,
        **rest,
    )


__all__ = ["METHOD", "RobustCertificate", "robust_certificate"]
