"""The problem an implementation certificate solves: one design's error loops, lagged.

:class:`ImplementationProblem` gathers what the certificate of the implemented controller
depends on (model, envelope, tube, gains, sigma, heading damping range, reference jerks,
actuators); :func:`position_lag_loop` and :func:`heading_lag_loop` are its two error loops in the form
of :class:`~auv_hinf.design.lmi.sampled.LagLoop`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from auv_hinf.certification.lag_terms import lag_channel_sigma
from auv_hinf.design.gains import Gains
from auv_hinf.design.lmi.sampled import LagLoop
from auv_hinf.models.actuators import Actuators
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.reference import ReferenceTube
from auv_hinf.models.vehicle import VehicleParams


def position_lag_loop(gains: Gains, lam: float, sigma: float, lag_sigma: float = 0.0) -> LagLoop:
    """The position error loop: ``a = lam``, ``K = (k1, alpha)``, ``|q| <= sigma |e'|``,
    ``|q2| <= lag_sigma |delta_2|`` (all 1/s)."""
    return LagLoop((lam,), gains.k1, gains.alpha, sigma, lag_sigma)


def heading_lag_loop(gains: Gains, c_range: tuple[float, float]) -> LagLoop:
    """The heading error loop: ``a = -(c - k2psi)`` at both ends of ``c``, ``K = k_psi``."""
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
        |delta_2|`` (:func:`~auv_hinf.certification.lag_terms.lag_channel_sigma`).
        """
        lag_sigma = lag_channel_sigma(self.params, self.tube) if channel else 0.0
        return position_lag_loop(self.gains, self.lam, self.sigma, lag_sigma), heading_lag_loop(
            self.gains, self.c_range
        )

    @property
    def nominal_dampings(self) -> tuple[float, float]:
        """``a`` of the nominal loops: ``lam`` (``D = 0``) and the smallest yaw damping."""
        return self.lam, -(self.c_range[0] - self.gains.k_psi[1])


__all__ = ["ImplementationProblem", "heading_lag_loop", "position_lag_loop"]
