"""Robust design: alpha, k1 and the heading gains chosen for the declared box and current.

One bandwidth ``w`` (rad/s) sets every gain of a family with fixed shape:

* position: nominal loop ``s^2 + 2 zeta w s + w^2`` on the box centre, i.e.
  ``k1 = w^2/l`` and ``alpha = (2 zeta w + lam)/l`` with :data:`POSITION_DAMPING` ``zeta``:
  heavy damping keeps velocity excursions (which decide the envelope) small;
* heading: poles ``(-h w, -1.5 h w)`` placed on the nominal heading model
  (:func:`~auv_hinf.law.gains.heading_gains`), ``h =`` :data:`HEADING_RATIO`.

Larger ``w`` shrinks every error bound and raises the heading stiffness that the Munk-moment
mismatch erodes, at the price of thrust. The design takes the *gentlest* ``w`` on the grid
:data:`BANDWIDTHS` whose robust certificate covers the box scaled by
:data:`TARGET_MARGIN` (so the certified margin ``lower`` is at least that), refined by
bisection between grid points; if no ``w`` reaches the target it takes the gentlest that covers
the declared box (margin >= 1); if none does, it reports the failure and the best attempt.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from tqdm.auto import tqdm

from auv_hinf.actuation.limits import Actuators
from auv_hinf.law.gains import Gains, heading_gains, with_integral
from auv_hinf.mission.fleet import ReferenceTube
from auv_hinf.mission.margins import inflate_envelope
from auv_hinf.models.envelope import Envelope
from auv_hinf.numerics.bisection import bisect
from auv_hinf.robust.box import ParameterBox, box_lambda
from auv_hinf.robust.invariant_set import RobustCertificate, robust_certificate

#: Damping ratio of the nominal position loop of the family.
POSITION_DAMPING = 4.0
#: Heading bandwidth as a fraction of the position bandwidth.
HEADING_RATIO = 0.8
#: Bandwidth grid (rad/s): factor-2 steps from 0.25 to 64 rad/s.
BANDWIDTHS = tuple(0.25 * 2.0**k for k in range(9))
#: Box scale the design asks the certificate to cover (25 % headroom over the declared box).
TARGET_MARGIN = 1.25
#: Bisection steps between the last failing and the first passing grid bandwidth.
REFINE_STEPS = 3


@dataclass(frozen=True)
class RobustDesign:
    """What the robust design chose and why.

    Attributes
    ----------
    gains : Gains
    bandwidth : float
        The chosen ``w`` (rad/s).
    target : float
        Box scale the choice covers (``TARGET_MARGIN``, 1, or 0 when nothing covers).
    certificate : RobustCertificate
        Certificate of the chosen gains on the declared box.
    tried : tuple of tuple
        ``(w, scale, covers)`` of every evaluation, in order.
    reason : str
        One sentence: what was chosen and why.
    """

    gains: Gains
    bandwidth: float
    target: float
    certificate: RobustCertificate
    tried: tuple[tuple[float, float, bool], ...]
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "gains": self.gains.to_dict(),
            "bandwidth": self.bandwidth,
            "target_scale": self.target,
            "position_damping": POSITION_DAMPING,
            "heading_ratio": HEADING_RATIO,
            "tried": [{"bandwidth": w, "scale": s, "covers": c} for w, s, c in self.tried],
            "reason": self.reason,
        }


def family_gains(box: ParameterBox, envelope: Envelope, w: float, integral: bool = False) -> Gains:
    """Gains of the family at bandwidth ``w`` (rad/s); with ``integral``, plus ``ki`` (:func:`integral_gain`).

    Parameters
    ----------
    box : ParameterBox
        The plant box (its centre lambda and input gain enter the gains).
    envelope : Envelope
        Operating envelope (inflated for the centre lambda).
    w : float
        Bandwidth (rad/s).
    integral : bool
        Add integral action.
    """
    lam, _ = box_lambda(box, inflate_envelope(envelope))
    lc, _ = box.input_gain()
    h = HEADING_RATIO * w
    gains = Gains(
        alpha=(2.0 * POSITION_DAMPING * w + lam) / lc,
        k1=w * w / lc,
        k_psi=heading_gains(box.nominal, (-h, -1.5 * h)),
    )
    return with_integral(gains, lam, lc) if integral else gains


def design_robust(
    box: ParameterBox,
    envelope: Envelope,
    tube: ReferenceTube,
    current: float = 0.0,
    actuators: Actuators | None = None,
    *,
    progress: bool = False,
    fallback: bool = True,
    integral: bool = False,
) -> RobustDesign:
    """Choose the robust gains (see the module docstring).

    Parameters
    ----------
    box : ParameterBox
        The declared plant box.
    envelope : Envelope
        Operating envelope.
    tube : ReferenceTube
        Bounds of the desired motion.
    current : float
        Declared current speed (m/s), scaled with the box.
    actuators : Actuators, optional
        The force limits the certificate must respect.
    progress : bool
        Show one progress bar over the whole search.
    fallback : bool
        When nothing fits the actuators, return the gentlest design that covers the box
        without them (its certificate then reports the excess).
    integral : bool
        Every candidate with integral action.
    """
    tried: list[tuple[float, float, bool]] = []
    cap = box.max_scale if box.declared else math.inf

    def covers(w: float, s: float) -> bool:
        b = box.scaled(min(s, cap)) if box.declared else box
        gains = family_gains(box, envelope, w, integral)
        c = robust_certificate(b, envelope, tube, gains, current * s, actuators, until_covered=True)
        tried.append((w, s, c.covers))
        return c.covers

    targets = [t for t in (TARGET_MARGIN, 1.0) if t <= cap]
    # one bar for the whole search: every bandwidth of every target, refinements included
    total = len(targets) * (len(BANDWIDTHS) + REFINE_STEPS)
    with tqdm(total=total, disable=not progress, desc="robust design", unit="certificate") as bar:
        for target in targets:
            prev: float | None = None
            for w in BANDWIDTHS:
                bar.update(1)
                if covers(w, target):
                    hi = w
                    if prev is not None:

                        def short(b: float, target: float = target) -> bool:
                            bar.update(1)
                            return not covers(b, target)

                        hi = bisect(short, prev, w, steps=REFINE_STEPS, geometric=True)[1]
                    bar.update(total - bar.n)  # the search is over: the bar ends full
                    gains = family_gains(box, envelope, hi, integral)
                    cert = robust_certificate(box, envelope, tube, gains, current, actuators)
                    why = (
                        f"gentlest bandwidth {hi:.4g} rad/s of the family (zeta = {POSITION_DAMPING:g}, heading "
                        f"{HEADING_RATIO:g} w) whose certificate covers the box scaled by {target:g}"
                    )
                    return RobustDesign(gains, hi, target, cert, tuple(tried), why)
                prev = w
    if actuators is not None and fallback:
        # nothing fits the actuators: take the gentlest design that covers the box without them,
        # whose certificate then says by how much it exceeds them (the most aggressive
        # bandwidth would need the most force of all)
        free = design_robust(box, envelope, tube, current, None, progress=progress, integral=integral)
        if free.target > 0.0:
            cert = robust_certificate(box, envelope, tube, free.gains, current, actuators)
            why = (
                f"no bandwidth of the family covers the declared box within the actuator limits; showing the "
                f"gentlest that covers it without them ({free.bandwidth:.4g} rad/s)"
            )
            return RobustDesign(free.gains, free.bandwidth, 0.0, cert, tuple(tried) + free.tried, why)
    w = BANDWIDTHS[-1]
    gains = family_gains(box, envelope, w, integral)
    cert = robust_certificate(box, envelope, tube, gains, current, actuators)
    return RobustDesign(
        gains,
        w,
        0.0,
        cert,
        tuple(tried),
        f"no bandwidth up to {w:g} rad/s covers the declared box; showing the largest",
    )


__all__ = [
    "BANDWIDTHS",
    "HEADING_RATIO",
    "POSITION_DAMPING",
    "REFINE_STEPS",
    "TARGET_MARGIN",
    "RobustDesign",
    "design_robust",
    "family_gains",
]
