"""The lagged error loops of one design, and bounds of what a held, delayed, noisy law adds to them.

:class:`ImplementationProblem` gathers what the certificate of the implemented controller
depends on (model, envelope, tube, gains, sigma, heading damping range, reference jerks,
actuators); :func:`position_lag_loop` and :func:`heading_lag_loop` are its two error loops in the
form of :class:`~auv_hinf.implementation.lmi.LagLoop`.

Under the implementation convention (:mod:`auv_hinf.implementation.model`) the force at time
``t`` is the law evaluated at ``t' = t - eta`` (``0 <= eta <= T = h + delay``) on the measured
state ``y = x(t') + n``. Writing ``x = (e, e')`` the position loop becomes (derivation in
``docs/derivations/implementation.md``)

    e'' = (G(x) - alpha) e' - k1 e + K (x(t) - x(t')) + w,

    w = -alpha n_v - k1 n_p + [p_d''(t') - p_d''(t)] + [G(x) - G(y)] p_d'(t)
        + G(y) [p_d'(t) - p_d'(t')] + (R(psi - psi_y) - I) R(psi_y) M1^-1 tau_xy,

and the heading loop ``e_psi'' = -k1psi e_psi - (k2psi + d33(r)/m33) e_psi' + K_psi (...) + w_psi``
with

    w_psi = -k1psi n_psi - k2psi n_r + [psi_d''(t') - psi_d''(t)]
            + [d33(r_y) psi_d'(t') - d33(r) psi_d'(t)]/m33 + (m11 - m22)(u v - u_y v_y)/m33.

Every bracket is bounded here by envelope and tube quantities: the state moves at most
``T`` times its rate bound between ``t'`` and ``t`` (body accelerations from the force bound,
the drag and the Coriolis terms over the envelope), ``G = R B R^T`` is Lipschitz in the body
velocities (``B`` is affine in ``|u|, |v|, r``) and in the heading (``2 sigma``), and the
rotation error satisfies ``||R(a) - I|| <= |a|``. The change of the desired yaw acceleration is
``T`` times the course jerk bound (:func:`~auv_hinf.mission.paths.course_jerk_bound`) when the path bounds its fourth
derivative, else twice its size (which does not shrink with ``T``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_hinf.actuation.limits import Actuators
from auv_hinf.actuation.thrust import ThrustBounds
from auv_hinf.implementation.lmi import LagLoop
from auv_hinf.implementation.model import Implementation
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import ErrorBounds
from auv_hinf.models.envelope import Envelope, abs_range
from auv_hinf.models.vehicle import VehicleParams, body_block


@dataclass(frozen=True)
class LagDisturbance:
    """Bounds of the disturbances ``w`` (position, m/s^2) and ``w_psi`` (heading, rad/s^2).

    Attributes
    ----------
    position, heading : float
        ``sup |w|`` and ``sup |w_psi|``.
    body_rates : tuple of float
        Bounds of ``|u'|, |v'|`` (m/s^2) and ``|r'|`` (rad/s^2) used.
    """

    position: float
    heading: float
    body_rates: tuple[float, float, float]


def operating_box(envelope: Envelope, tube: ReferenceTube, bounds: ErrorBounds) -> tuple[float, float, float]:
    """Bounds of ``|u|, |v|`` (m/s) and ``|r|`` (rad/s) while the errors stay within ``bounds``.

    The body velocity is the desired one (speed ``S``, pointing along the desired heading up to
    the tube's heading offset) plus the velocity error, and the yaw rate the desired one plus its
    error (as in :func:`~auv_hinf.actuation.thrust.thrust_bounds`), each capped by the envelope.

    Parameters
    ----------
    envelope : Envelope
        Operating envelope.
    tube : ReferenceTube
        Bounds of the desired motion.
    bounds : ErrorBounds
        Bounds of the errors (m, m/s, rad, rad/s; the position bound is unused).
    """
    u_hi, v_hi, r_hi = abs_range(*envelope.u)[1], abs_range(*envelope.v)[1], abs_range(*envelope.r)[1]
    speed = float(tube.speed[:, 1].max())
    slip = min(0.5 * math.pi, float(np.abs(tube.offset).max()) + bounds.heading)
    return (
        min(u_hi, speed + bounds.velocity),
        min(v_hi, speed * math.sin(slip) + bounds.velocity),
        min(r_hi, float(np.abs(tube.yaw_rate).max()) + bounds.yaw_rate),
    )


def block_slopes(params: VehicleParams) -> tuple[float, float, float]:
    """Spectral norms of ``dB/d|u|``, ``dB/d|v|``, ``dB/dr`` (``B`` is affine in them), 1/m and 1.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters; ``B`` is their :func:`~auv_hinf.models.vehicle.body_block`.
    """
    base = body_block(params, 0.0, 0.0, 0.0)
    return tuple(  # type: ignore[return-value]
        float(np.linalg.norm(body_block(params, *unit) - base, 2))
        for unit in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    )


def lag_channel_sigma(params: VehicleParams, tube: ReferenceTube) -> float:
    """Bound (1/s) of the drift feed-forward's change per unit change of the velocity error over the lag.

    ``|(G(x) - G(y)) p_d'| <= max |p_d'| hypot(b_u, b_v) |delta nu|`` (:func:`block_slopes`): the
    position LMI's lag channel ``|q2| <= lag_sigma |delta_2|``.

    Parameters
    ----------
    params : VehicleParams
        Plant parameters.
    tube : ReferenceTube
        Bounds of the desired motion (its largest speed ``max |p_d'|`` is used).
    """
    b_u, b_v, _ = block_slopes(params)
    return float(tube.speed[:, 1].max()) * math.hypot(b_u, b_v)


def body_rates(
    params: VehicleParams,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    implementation: Implementation,
    *,
    lam: float,
    sigma: float,
    bounds: ErrorBounds,
    force: ThrustBounds,
    disturbance: tuple[float, float] = (0.0, 0.0),
    lag_sigma: float = 0.0,
) -> tuple[float, float, float]:
    """Bounds of ``|u'|, |v'|`` (m/s^2) and ``|r'|`` (rad/s^2) under the lagged law.

    The smallest of three sound bounds, componentwise:

    * from the error loops themselves: ``nu' = R^T (p_d'' + e'') - S(r) nu`` and
      ``|e''| <= (|lam| + sigma + alpha) E_v + k1 E_p + |K delta| + |q2| + |w|`` with
      ``|K delta| <= k1 E_v T + 2 alpha E_v``, ``|q2| <= 2 lag_sigma E_v`` and ``|w|`` bounded by
      ``disturbance`` (the fixed point carries it; likewise ``r' = psi_d'' + e_psi''``);
    * the held-force argument below;
    * the force bound with the drag and Coriolis terms at their largest (crude).

    Between samples the force is held, so ``nu' = g(nu)`` (body dynamics with constant force)
    and ``d/dt |nu'|^2 = 2 nu'^T J nu' <= 2 mu |nu'|^2``, ``J = dg/dnu``, ``mu`` a bound of its
    logarithmic norm over the envelope (the drag terms of the diagonal are negative; the
    Coriolis terms are bounded by their largest moduli): ``|nu'(t)| <= exp(mu+ h) |nu'(t_k+)|``.
    Just after a sample, ``nu'(t_k+) = nu*'(s_k) + M^-1 [tau(y) - tau(x(s_k))] + [g(x(t_k)) - g(x(s_k))]``:
    the continuous closed loop's body acceleration at the measurement time (``R^T p'' - S(r) nu``,
    ``p'' = p_d'' + e''``, ``|e''| <= (|lam| + sigma + alpha) E_v + k1 E_p``), the law's response to
    the measurement noise, and the drift moved by the state's change over the delay ``d``
    (Lipschitz matrix ``L``). So ``rho <= exp(mu+ h) (|a0| + d ||L|| rho)``; every component is
    bounded by the Euclidean ``rho`` (and by the cruder force-based rate).

    Parameters
    ----------
    params : VehicleParams
        The controller's model, taken as the plant.
    envelope : Envelope
        The envelope the true body velocities stay in.
    tube : ReferenceTube
        Bounds of the desired motion.
    gains : Gains
        The law's gains.
    implementation : Implementation
        Sample time, delay and measurement-noise bounds.
    lam, sigma : float
        Envelope lambda and the bound of ``||G - lam I||`` over the envelope (1/s).
    bounds : ErrorBounds
        Bounds of the true errors (m, m/s, rad, rad/s).
    force : ThrustBounds
        Bounds of the applied (held) forces (N, N, N m).
    disturbance : tuple of float
        Bounds of ``|w|`` (m/s^2) and ``|w_psi|`` (rad/s^2) assumed in the error-loop bound.
    lag_sigma : float
        Bound of the position loop's lag channel ``|q2| / |delta_2|`` (1/s).
    """
    h, d, n = implementation.sample_time, implementation.delay, implementation.noise
    m11, m22, m33 = params.m11, params.m22, params.m33
    u_hi, v_hi, r_hi = abs_range(*envelope.u)[1], abs_range(*envelope.v)[1], abs_range(*envelope.r)[1]
    d11, d22, d33 = (float(x) for x in params.damping(u_hi, v_hi, r_hi))
    crude = (
        (force.force_x + m22 * v_hi * r_hi + d11 * u_hi) / m11,
        (force.force_y + m11 * u_hi * r_hi + d22 * v_hi) / m22,
        (force.moment + abs(m22 - m11) * u_hi * v_hi + d33 * r_hi) / m33,
    )
    # the state the vehicle can be in: desired motion widened by the error bounds, inside the envelope
    speed = float(tube.speed[:, 1].max())
    yaw = float(np.abs(tube.yaw_rate).max())
    u_in, v_in, r_in = operating_box(envelope, tube, bounds)
    b_u, b_v, b_r = block_slopes(params)
    k1p, k2p = gains.k_psi
    p_acc = float(tube.accel.max()) + (abs(lam) + sigma + gains.alpha) * bounds.velocity + gains.k1 * bounds.position
    c_hi = abs(k2p) + float(params.damping(0.0, 0.0, r_in)[2]) / m33
    ground_noise = n.velocity + math.hypot(u_in, v_in) * n.heading
    f_acc = math.hypot(force.force_x / m11, force.force_y / m22)
    xy_noise = (
        gains.alpha * ground_noise
        + gains.k1 * n.position
        + (f_acc + 2.0 * sigma * speed) * n.heading
        + speed * ((b_u + b_v) * n.velocity + b_r * n.yaw_rate)
    )
    d33_slope = float(params.damping(0.0, 0.0, 1.0)[2] - params.damping(0.0, 0.0, 0.0)[2])
    yaw_noise = (
        abs(k1p) * n.heading
        + abs(k2p) * n.yaw_rate
        + d33_slope * n.yaw_rate * yaw / m33
        + abs(m11 - m22) * ((u_in + v_in) * n.velocity + n.velocity**2) / m33
    )
    a0 = np.array(
        [
            p_acc + r_in * v_in + xy_noise,
            p_acc + r_in * u_in + xy_noise,
            float(tube.yaw_accel.max()) + abs(k1p) * bounds.heading + c_hi * bounds.yaw_rate + yaw_noise,
        ]
    )
    d_lin = [float(x) for x in params.damping(0.0, 0.0, 0.0)]
    d11_in, d22_in, d33_in = (float(x) for x in params.damping(u_in, v_in, r_in))
    slopes = (
        float(params.damping(1.0, 0.0, 0.0)[0]) - d_lin[0],
        float(params.damping(0.0, 1.0, 0.0)[1]) - d_lin[1],
        d33_slope,
    )
    # |dg/dnu| entrywise over the envelope; d(d(u) u)/du = d_lin + 2 d_quad |u|
    lip = np.array(
        [
            [(d11_in + slopes[0] * u_in) / m11, m22 * r_in / m11, m22 * v_in / m11],
            [m11 * r_in / m22, (d22_in + slopes[1] * v_in) / m22, m11 * u_in / m22],
            [abs(m22 - m11) * v_in / m33, abs(m22 - m11) * u_in / m33, (d33_in + slopes[2] * r_in) / m33],
        ]
    )
    # comparison matrix of sym(J): the least negative diagonal (-d_lin/m) and the largest off-diagonal moduli
    comp = 0.5 * (lip + lip.T)
    np.fill_diagonal(comp, [-d_lin[0] / m11, -d_lin[1] / m22, -d_lin[2] / m33])
    grow = math.exp(max(float(np.linalg.eigvalsh(comp).max()), 0.0) * h)
    loop = grow * d * float(np.linalg.norm(lip, 2))
    rho = grow * float(np.linalg.norm(a0)) / (1.0 - loop) if loop < 1.0 else math.inf
    lag = implementation.max_lag
    e_acc = (
        (abs(lam) + sigma + gains.alpha) * bounds.velocity
        + gains.k1 * bounds.position
        + (gains.k1 * lag + 2.0 * gains.alpha + 2.0 * lag_sigma) * bounds.velocity
        + disturbance[0]
    )
    psi_acc = (
        abs(k1p) * bounds.heading
        + c_hi * bounds.yaw_rate
        + (abs(k1p) * lag + 2.0 * abs(k2p)) * bounds.yaw_rate
        + disturbance[1]
    )
    loops = (
        float(tube.accel.max()) + e_acc + r_in * v_in,
        float(tube.accel.max()) + e_acc + r_in * u_in,
        float(tube.yaw_accel.max()) + psi_acc,
    )
    return tuple(float(min(rho, c, k)) for c, k in zip(crude, loops, strict=True))  # type: ignore[return-value]


def lag_disturbance(
    params: VehicleParams,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    implementation: Implementation,
    *,
    lam: float,
    sigma: float,
    jerk: float,
    force: ThrustBounds,
    bounds: ErrorBounds,
    yaw_jerk: float = math.inf,
    lag_channel: bool = False,
    previous: tuple[float, float] = (0.0, 0.0),
) -> LagDisturbance:
    """Sound bounds of ``|w|`` and ``|w_psi|`` (see the module docstring).

    Parameters
    ----------
    params : VehicleParams
        The controller's model, taken as the plant.
    envelope : Envelope
        The envelope the true body velocities stay in.
    tube : ReferenceTube
        Bounds of the desired motion.
    gains : Gains
    implementation : Implementation
    lam, sigma : float
        Envelope lambda and the bound of ``||G - lam I||`` over the envelope (1/s).
    jerk : float
        Bound of ``|p_d'''|`` (m/s^3).
    force : ThrustBounds
        Bounds of the applied (held) forces (N, N, N m).
    bounds : ErrorBounds
        Bounds of the true errors (m, m/s, rad, rad/s).
    yaw_jerk : float
        Bound of ``|psi_d'''|`` (rad/s^3); ``inf`` when unknown (then the change of ``psi_d''``
        over the lag is bounded by twice its size).
    lag_channel : bool
        The position certificate carries the feedforward's dependence on the velocity error's
        change (``q2``); then only the rest of the body velocity's change enters here.
    previous : tuple of float
        Bounds of ``|w|``, ``|w_psi|`` assumed while these are computed (the fixed point's
        previous iterate): they enter the body-acceleration bound (:func:`body_rates`).
    """
    lag, n = implementation.max_lag, implementation.noise
    m11, m22, m33 = params.m11, params.m22, params.m33
    _u_hi, _v_hi, _r_hi = abs_range(*envelope.u)[1], abs_range(*envelope.v)[1], abs_range(*envelope.r)[1]
    b_u, b_v, b_r = block_slopes(params)
    lag_sigma = lag_channel_sigma(params, tube) if lag_channel else 0.0
    u_rate, v_rate, r_rate = body_rates(
        params,
        envelope,
        tube,
        gains,
        implementation,
        lam=lam,
        sigma=sigma,
        bounds=bounds,
        force=force,
        disturbance=previous,
        lag_sigma=lag_sigma,
    )
    u_in, v_in, r_in = operating_box(envelope, tube, bounds)
    # change of each state between the measurement and now, noise included
    d_psi = r_in * lag + n.heading
    d_u, d_v, d_r = u_rate * lag + n.velocity, v_rate * lag + n.velocity, r_rate * lag + n.yaw_rate
    speed = float(tube.speed[:, 1].max())
    accel = float(tube.accel.max())
    yaw = float(np.abs(tube.yaw_rate).max())
    yaw_accel = float(tube.yaw_accel.max())
    # change of the body velocity over the lag beyond the velocity error's own change (which the
    # Lyapunov-Krasovskii certificate carries as q2, |q2| <= S hypot(b_u, b_v) |delta_2|):
    # reference speed change, rotation of the ground velocity, measurement noise
    if lag_channel:
        drift_change = math.hypot(b_u, b_v) * (accel * lag + r_in * lag * (speed + bounds.velocity) + n.velocity)
    else:
        drift_change = b_u * d_u + b_v * d_v
    ground_noise = n.velocity + math.hypot(u_in, v_in) * n.heading  # |R(psi_y) nu_y - R(psi) nu|
    g_measured = abs(lam) + sigma + (b_u + b_v) * n.velocity + b_r * n.yaw_rate
    position = (
        gains.alpha * ground_noise
        + gains.k1 * n.position
        + jerk * lag
        + speed * (2.0 * sigma * d_psi + drift_change + b_r * d_r)
        + g_measured * accel * lag
        + d_psi * math.hypot(force.force_x / m11, force.force_y / m22)
    )
    d33_y = float(params.damping(0.0, 0.0, r_in + n.yaw_rate)[2])
    d33_quad = float(params.damping(0.0, 0.0, 1.0)[2]) - float(params.damping(0.0, 0.0, 0.0)[2])
    heading = (
        abs(gains.k_psi[0]) * n.heading
        + abs(gains.k_psi[1]) * n.yaw_rate
        + min(2.0 * yaw_accel, yaw_jerk * lag if lag > 0 else 0.0)
        + (abs(d33_quad) * d_r * yaw + d33_y * yaw_accel * lag) / m33
        + abs(m11 - m22) * ((v_in + n.velocity) * d_u + u_in * d_v) / m33
    )
    return LagDisturbance(position=position, heading=heading, body_rates=(u_rate, v_rate, r_rate))


def position_lag_loop(gains: Gains, lam: float, sigma: float, lag_sigma: float = 0.0) -> LagLoop:
    """The position error loop: ``a = lam``, ``K = (k1, alpha)``, ``|q| <= sigma |e'|``.

    With a lag channel also ``|q2| <= lag_sigma |delta_2|``.

    Parameters
    ----------
    gains : Gains
        ``k1`` (1/s^2) and ``alpha`` (1/s) are the loop's gains.
    lam : float
        Envelope lambda (1/s).
    sigma : float
        Bound of ``||G - lam I||`` (1/s).
    lag_sigma : float
        Bound of the lag channel ``|q2| / |delta_2|`` (1/s); 0 for none.
    """
    return LagLoop((lam,), gains.k1, gains.alpha, sigma, lag_sigma)


def heading_lag_loop(gains: Gains, c_range: tuple[float, float]) -> LagLoop:
    """The heading error loop: ``a = -(c - k2psi)`` at both ends of ``c``, ``K = k_psi``.

    Parameters
    ----------
    gains : Gains
        Its heading gains ``k_psi`` (1/s^2, 1/s) are the loop's gains.
    c_range : tuple of float
        Range of the heading damping ``c = k2psi + d33(r)/m33`` (1/s).
    """
    k1p, k2p = gains.k_psi
    return LagLoop((-(c_range[0] - k2p), -(c_range[1] - k2p)), k1p, k2p)


@dataclass(frozen=True)
class ImplementationProblem:
    """Everything the implementation certificate of one configuration depends on.

    Attributes
    ----------
    params, envelope, tube, gains
        The controller's model (taken as the plant), envelope, reference tube and gains.
    lam, sigma : float
        Envelope lambda and ``||G - lam I||`` bound (1/s).
    c_range : tuple of float
        Range of the heading loop's damping ``k2psi + d33(r)/m33`` (1/s).
    jerk : float
        Bound of ``|p_d'''|`` (m/s^3).
    actuators : Actuators or None
    yaw_jerk : float
        Bound of ``|psi_d'''|`` (rad/s^3); ``inf`` when unknown.
    """

    params: VehicleParams
    envelope: Envelope
    tube: ReferenceTube
    gains: Gains
    lam: float
    sigma: float
    c_range: tuple[float, float]
    jerk: float
    actuators: Actuators | None = None
    yaw_jerk: float = math.inf

    @property
    def loops(self) -> tuple[LagLoop, LagLoop]:
        """Position and heading :class:`LagLoop` of the stability limits (no lag channel)."""
        return self.lag_loops(False)

    def lag_loops(self, channel: bool) -> tuple[LagLoop, LagLoop]:
        """Position and heading :class:`LagLoop`, with the position lag channel when ``channel``.

        The lag channel is the drift feedforward ``G(y) p_d'`` evaluated at the old state: its
        part driven by the velocity error's change is at most ``max |p_d'| hypot(b_u, b_v)
        |delta_2|`` (:func:`~auv_hinf.implementation.lag.lag_channel_sigma`).

        Parameters
        ----------
        channel : bool
            Give the position loop its lag channel (``lag_sigma > 0``).
        """
        lag_sigma = lag_channel_sigma(self.params, self.tube) if channel else 0.0
        return position_lag_loop(self.gains, self.lam, self.sigma, lag_sigma), heading_lag_loop(
            self.gains, self.c_range
        )

    @property
    def nominal_dampings(self) -> tuple[float, float]:
        """``a`` of the nominal loops: ``lam`` (``D = 0``) and the smallest yaw damping."""
        return self.lam, -(self.c_range[0] - self.gains.k_psi[1])


__all__ = [
    "ImplementationProblem",
    "LagDisturbance",
    "block_slopes",
    "body_rates",
    "heading_lag_loop",
    "lag_channel_sigma",
    "lag_disturbance",
    "operating_box",
    "position_lag_loop",
]
