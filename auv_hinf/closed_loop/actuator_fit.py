"""The closed-loop certificate within the actuator limits: the start region shrunk until the
force fits.

:func:`~auv_hinf.closed_loop.region.certify_region` makes the start region as large as the
operating envelope allows. With declared actuator limits the region must also keep the
commanded force inside them. The thrust bound of
:func:`~auv_hinf.actuation.thrust.thrust_bounds` is ``t0 + t1(E)``: ``t0`` is what
the mission itself needs at zero error (feed-forward and model cancellation along the tube),
``t1`` grows with the error bounds ``E``. The error bounds are the extents of one level set
of the certified Lyapunov functions (P2 for the position loop, Q for the heading loop); for
the start region scaled by ``kappa`` in ``[0, 1]`` the level set, and so every extent,
scales by ``kappa`` (the extents are homogeneous of degree one in the region's radii), and
the thrust bound is nondecreasing in them, so the fractions that fit form an interval ``[0,
kappa*]`` (:func:`actuator_fraction` finds its end by bisection). A smaller sub-level set of
an invariant ellipsoid inside the envelope is itself invariant, and its envelope margins
only grow. When ``t0`` already exceeds a limit, no start region fits: the mission needs more
force than the actuators give even when tracked exactly.
"""

from __future__ import annotations

import dataclasses

from auv_hinf.actuation.limits import Actuators
from auv_hinf.actuation.thrust import ThrustBounds, thrust_bounds
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import ErrorBounds, envelope_margins, inflate_envelope
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.bisection import largest_holding

#: Resolution of the shrink factor's bisection: the region returned is within 1e-6 of the
#: largest fraction that fits (always on the fitting side), far below any physical resolution.
KAPPA_RTOL = 1e-6


def mission_thrust(params: VehicleParams, envelope: Envelope, tube: ReferenceTube, gains: Gains) -> ThrustBounds:
    """Thrust bound at zero tracking error: what the mission itself needs (N, N, N m).

    Parameters
    ----------
    params : VehicleParams
        The controller's model of the vehicle.
    envelope : Envelope
        Operating envelope (not inflated: the bound uses its inflated copy, as the certificate does).
    tube : ReferenceTube
        Bounds of the vehicle's desired motion.
    gains : Gains
        The law's gains.
    """
    return thrust_bounds(params, inflate_envelope(envelope), tube, ErrorBounds(0.0, 0.0, 0.0, 0.0), gains)


def actuator_fraction(
    cert: ClosedLoopCertificate,
    params: VehicleParams,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    actuators: Actuators,
) -> float | None:
    """Largest ``kappa`` in ``[0, 1]`` whose scaled start region keeps the thrust within ``actuators``.

    The thrust bound of the region scaled by ``kappa`` is nondecreasing in ``kappa`` (every term
    of :func:`~auv_hinf.actuation.thrust.thrust_bounds` grows with the error bounds),
    so the fitting fractions form an interval ``[0, kappa*]``, found by bisection to
    :data:`KAPPA_RTOL`; the value returned always fits. Returns ``None`` when the mission alone
    (zero error) needs more than a limit.

    Parameters
    ----------
    cert : ClosedLoopCertificate
        The certificate whose region (error bounds) is scaled.
    params : VehicleParams
        The controller's model of the vehicle.
    envelope : Envelope
        Operating envelope (not inflated: the bound uses its inflated copy, as the certificate does).
    tube : ReferenceTube
        Bounds of the vehicle's desired motion.
    gains : Gains
        The law's gains.
    actuators : Actuators
        The force limits (N, N, N m, body frame).
    """
    env = inflate_envelope(envelope)
    b = cert.region.bounds

    def fits(k: float) -> bool:
        scaled = ErrorBounds(k * b.position, k * b.velocity, k * b.heading, k * b.yaw_rate)
        return actuators.admits(thrust_bounds(params, env, tube, scaled, gains).as_tuple())

    if not fits(0.0):
        return None
    return largest_holding(fits, 1.0, check_lo=False, rtol=KAPPA_RTOL)


def within_actuators(
    cert: ClosedLoopCertificate,
    params: VehicleParams,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    actuators: Actuators,
) -> ClosedLoopCertificate | None:
    """``cert`` with its start region shrunk to fit ``actuators`` (itself when it fits already).

    The Lyapunov matrices and decay rates are unchanged; the region, its error bounds and
    margins and the thrust bound are those of the scaled level set (see the module docstring).
    Returns ``None`` when no start region fits.

    Parameters
    ----------
    cert : ClosedLoopCertificate
        The closed-loop certificate to shrink.
    params : VehicleParams
        The controller's model of the vehicle.
    envelope : Envelope
        Operating envelope.
    tube : ReferenceTube
        Bounds of the vehicle's desired motion.
    gains : Gains
        The law's gains.
    actuators : Actuators
        The force limits (N, N, N m, body frame).
    """
    kappa = actuator_fraction(cert, params, envelope, tube, gains, actuators)
    if kappa is None:
        return None
    if kappa >= 1.0:
        return cert
    reg = cert.region
    b = reg.bounds
    bounds = ErrorBounds(kappa * b.position, kappa * b.velocity, kappa * b.heading, kappa * b.yaw_rate)
    region = dataclasses.replace(
        reg,
        kappa=reg.kappa * kappa,
        region=reg.region.scaled(kappa),
        bounds=bounds,
        margins=envelope_margins(tube, bounds, envelope),
    )
    thrust = thrust_bounds(params, inflate_envelope(envelope), tube, bounds, gains)
    return dataclasses.replace(cert, region=region, thrust=thrust)


__all__ = ["KAPPA_RTOL", "actuator_fraction", "mission_thrust", "within_actuators"]
