"""The composed certificate as a campaign of sampled runs draws from it and checks against it.

A sampled ``[implementation]`` runs the held, delayed law on noisy measurements, which no
continuous certificate is about. When the composed certificate
(:mod:`auv_hinf.composed.certificate`) covers the deployed loop, a campaign of it:

* **Starts** every vehicle inside a start set that a composed certificate covers: position error
  uniform in the disc of radius ``P``, water-relative velocity error uniform in the disc of radius
  ``V`` (the ground-velocity error is that plus the run's current, as the certificate assumes),
  heading and yaw-rate errors uniform in ``[-H, H]`` and ``[-R, R]``. ``(P, V, H, R)`` is the
  largest common fraction :attr:`ComposedStart.scale` of a reference set (the continuous
  nominal certificate's start region, a familiar scale for a user) at which the composed
  certificate covers with bounds that keep ``[formation] min_separation`` (as ``certify``
  requires), found by a halving ladder (:data:`LADDER` rungs) and a geometric bisection
  (:data:`START_STEPS` certificates); the fraction is 0, the vehicles starting on their slots,
  when only that is covered.
* **Plants and currents** as the robust campaign (:mod:`auv_hinf.campaign.starts`): box
  vertices every other run first, with the current at its full speed, the others uniform.
* **Check** each run against the certificate computed at that start set: the error bounds
  hold for every vehicle of every run, whatever the plant of the box, the current within its
  bound and the measurement errors within theirs, and so does its force bound.

When the composed certificate does not cover even the on-slot start, no certificate covers a
sampled run, and every run is reported as not covered (``inside_bounds`` NA) with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.campaign.starts import BoxVertices, uniform_ball
from auv_hinf.certificate.design_point import DesignPoint
from auv_hinf.certificate.parts.composed import composed_summary, within_actuators
from auv_hinf.certificate.parts.separation import separation_refusal
from auv_hinf.composed.certificate import DeployedCertificate
from auv_hinf.composed.loops import Errors
from auv_hinf.exceptions import ParameterError
from auv_hinf.numerics.bisection import bisect

#: Rungs of the halving ladder of the start set's scale (1, 1/2, ..., 1/256 of the reference set);
#: below the last the vehicles start on their slots.
LADDER = 9
#: Certificates of the geometric bisection between the first covered rung and the one above it:
#: the scale is within a factor 2^(1/4) of the boundary found.
START_STEPS = 2


@dataclass(frozen=True)
class ComposedStart(BoxVertices):
    """A covering composed certificate as a campaign samples from it and checks against it.

    Attributes
    ----------
    certificate : DeployedCertificate
        The composed certificate at :attr:`start` (it covers, its force within the actuators).
    start : Errors
        The start set's radii: position (m), water-relative velocity (m/s), heading (rad) and
        yaw-rate (rad/s) errors.
    scale : float
        The fraction of the reference set :attr:`start` is (0: on the slots).
    declared : tuple of int
        Indices of the box parameters with a non-degenerate range (the vertex bits).
    """

    certificate: DeployedCertificate
    start: Errors
    scale: float
    declared: tuple[int, ...]

    #: What the campaign's summary calls the certificate.
    kind = "composed"

    @property
    def bounds(self) -> FloatArray:
        """Certified per-vehicle bounds of position (m), velocity (m/s), heading (rad), yaw rate (rad/s)."""
        e = self.certificate.errors
        if e is None:  # pragma: no cover - a covering certificate has bounds
            raise ParameterError("a composed campaign needs a covering certificate")
        return np.array([e.position, e.velocity, e.heading, e.yaw_rate])

    @property
    def thrust(self) -> FloatArray:
        """Certified bound of the commanded ``|tau_x|`` (N), ``|tau_y|`` (N), ``|tau_psi|`` (N m)."""
        f = self.certificate.force
        if f is None:  # pragma: no cover - a covering certificate has a force bound
            raise ParameterError("a composed campaign needs a covering certificate")
        return np.array(f.as_tuple())

    @property
    def decay_rate(self) -> None:
        """No Lyapunov decay rate is certified for the sampled runs (the summary says ``null``)."""
        return None

    def sample_errors(
        self, rng: np.random.Generator, n: int, current: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Start errors of ``n`` vehicles in the start set, in ``current`` (m/s, inertial).

        Returns ``e (n, 2)`` m, the ground-velocity error ``e' (n, 2)`` m/s (the water-relative
        one plus the current), ``e_psi (n,)`` rad and ``e_psi' (n,)`` rad/s.

        Parameters
        ----------
        rng : numpy.random.Generator
            Source of the draws.
        n : int
            Number of vehicles.
        current : ndarray, shape (2,)
            The run's current (m/s, inertial frame).
        """
        s = self.start
        e = uniform_ball(rng, n, 2) * s.position
        de = uniform_ball(rng, n, 2) * s.velocity + current
        epsi = s.heading * rng.uniform(-1.0, 1.0, n)
        depsi = s.yaw_rate * rng.uniform(-1.0, 1.0, n)
        return e, de, epsi, depsi

    def region(self) -> dict[str, float]:
        """The start set's radii (m, m/s, rad, rad/s), as the summary's ``start_region``."""
        return {k: v for k, v in self.start.to_dict().items() if k in ("position", "velocity", "heading", "yaw_rate")}


def composed_start(
    point: DesignPoint, declared: tuple[int, ...], reference: Errors | None
) -> tuple[ComposedStart | None, str | None]:
    """The largest scaled ``reference`` start set the composed certificate covers, or why there is none.

    A start set counts as covered when its certificate covers and its position bound keeps
    ``[formation] min_separation``: a larger set whose bound breaks the separation is passed over
    for a smaller one, down to the on-slot start that ``certify`` judges (returned when it covers
    even if its bound breaks the separation too: the campaign's setup then refuses every run, as
    ``certify`` refuses the fleet).

    Parameters
    ----------
    point : DesignPoint
        The design point (configuration with a sampled implementation, gains, mission).
    declared : tuple of int
        The box's vertex bits (:func:`~auv_hinf.campaign.starts.declared_rows`).
    reference : Errors or None
        The start set at scale 1 (``None``: only the on-slot start is tried).
    """
    summary = composed_summary(point, search=False)
    problem = summary.problem
    if not summary.applies or problem is None:
        return None, "; ".join(summary.reasons) or "the composed certificate does not apply"
    certify = within_actuators(point)
    found: dict[float, DeployedCertificate] = {}

    def start(scale: float) -> Errors:
        r = reference or Errors(0.0, 0.0, 0.0, 0.0)
        return Errors(scale * r.position, scale * r.velocity, scale * r.heading, scale * r.yaw_rate)

    def covers(scale: float) -> bool:
        cert = found[scale] = certify(replace(problem, start=start(scale)))
        errors = cert.errors if cert.covers else None
        return errors is not None and separation_refusal(point, errors.position) is None

    scale = None
    if reference is not None:  # a halving ladder to the first covered scale, then a geometric bisection above it
        for k in range(LADDER):
            rung = 0.5**k
            if covers(rung):
                scale = rung if k == 0 else bisect(covers, rung, 2.0 * rung, steps=START_STEPS, geometric=True)[0]
                break
    if scale is None:
        scale = 0.0 if covers(0.0) else None
    if scale is None and 0.0 in found and found[0.0].covers:
        # covered from the slots, but its bound breaks the separation: the campaign refuses every run for it
        return ComposedStart(found[0.0], start(0.0), 0.0, declared), None
    if scale is None:
        why = "; ".join(found[0.0].reasons) if 0.0 in found else "not computed"
        return None, f"the composed certificate does not cover the deployed loop even from the slots: {why}"
    return ComposedStart(found[scale], start(scale), float(scale), declared), None


__all__ = ["LADDER", "START_STEPS", "ComposedStart", "composed_start"]
