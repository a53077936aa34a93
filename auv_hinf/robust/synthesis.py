"""Robust design by LMI synthesis: the gains that need the least force, certified for the box.

The bandwidth family (:mod:`auv_hinf.robust.bandwidth`) fixes the shape of the gains and
searches one number. Here the position gains ``(k1, alpha)`` come from the synthesis LMI of
:mod:`auv_hinf.design.lmi.synthesis`: for a decay rate ``a`` and a cap on the velocity error
it minimises the feedback acceleration on the invariant ellipsoid, over every plant of the box
(the vertex sigma and the input-gain spread) and the current's disturbance. The heading gains
follow by pole placement at :data:`~auv_hinf.robust.bandwidth.HEADING_RATIO` times the position
loop's natural frequency ``sqrt(l k1)``.

The objective, stated in every design: the smallest **certified peak force** relative to the
actuator limits (or in newtons when none are declared), among the candidates whose robust
certificate covers the box scaled by :data:`~auv_hinf.robust.bandwidth.TARGET_MARGIN` (else by
1). The search runs over :data:`RATES` (fractions of ``|lam| + sigma``) and :data:`VELOCITY_SHARES`
(the share of the envelope's sway half-width the velocity error may take). Every candidate is
certified from scratch by :func:`~auv_hinf.robust.certificate.robust_certificate`; the SDP
only proposes.
"""

from __future__ import annotations

import math

import numpy as np
from tqdm.auto import tqdm

from auv_hinf.certification.margins import inflate_envelope
from auv_hinf.design.gains import Gains, heading_gains, with_integral
from auv_hinf.design.lmi.synthesis import synthesise_position
from auv_hinf.models.actuators import Actuators
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.reference import ReferenceTube
from auv_hinf.robust.bandwidth import HEADING_RATIO, TARGET_MARGIN, RobustDesign
from auv_hinf.robust.box import ParameterBox, TubeSummary, box_lambda, position_disturbance
from auv_hinf.robust.certificate import RobustCertificate, robust_certificate

#: Decay rates tried, as fractions of ``|lam| + sigma`` (1/s).
RATES = (0.05, 0.15, 0.4, 1.0)
#: Shares of the envelope's sway half-width that the certified velocity error may take.
VELOCITY_SHARES = (0.3, 0.6, 0.9)

#: Smallest disturbance bound used to size the velocity cap (m/s^2): a plant known exactly in
#: still water has none, and any positive floor far below real disturbances keeps the cap finite.
DISTURBANCE_FLOOR = 1e-12

OBJECTIVE = "minimise the certified peak force (relative to the actuator limits when declared)"


def _score(cert: RobustCertificate, actuators: Actuators | None) -> float:
    """Objective value of a covering certificate: largest peak/limit ratio, or largest force (N)."""
    if cert.thrust is None:
        return math.inf
    peak = cert.thrust.as_tuple()
    if actuators is not None:
        return actuators.utilisation(peak)
    return max(peak[0], peak[1])


def synthesise_robust(
    box: ParameterBox,
    envelope: Envelope,
    tube: ReferenceTube,
    current: float = 0.0,
    actuators: Actuators | None = None,
    *,
    progress: bool = False,
    integral: bool = False,
) -> RobustDesign:
    """The synthesised robust design (see the module docstring).

    With ``integral`` every candidate gets the integral gain of
    :func:`~auv_hinf.design.gains.integral_gain` for its ``(alpha, k1)`` before it is certified.

    Returns
    -------
    RobustDesign
        Its ``bandwidth`` is the position loop's natural frequency ``sqrt(l k1)`` (rad/s) and
        ``target`` the box scale it covers (``TARGET_MARGIN``, 1, or 0 when no candidate covers:
        then the candidate with the best objective on the declared box, not certified).
    """
    env = inflate_envelope(envelope)
    lam, sigma = box_lambda(box, env)
    lc, spread = box.input_gain()
    summ = TubeSummary.of(tube)
    half_v = min(-envelope.v[0], envelope.v[1])
    scale = abs(lam) + sigma
    candidates: list[tuple[Gains, float]] = []
    # the disturbance of the position loop at zero heading error; the heading coupling is
    # checked afterwards by the robust certificate of each candidate
    dbar = max(position_disturbance(box, env, summ, current, 0.0, lam, sigma), DISTURBANCE_FLOOR)
    for share in VELOCITY_SHARES:
        cap = (share * half_v / dbar) ** 2
        for frac in RATES:
            found = synthesise_position(lam, lc, sigma, spread, frac * scale, cap)
            if found is None:
                continue
            k1, alpha = found.k1, found.alpha
            h = HEADING_RATIO * math.sqrt(lc * k1)
            gains = Gains(alpha, k1, heading_gains(box.nominal, (-h, -1.5 * h)))
            candidates.append((with_integral(gains, lam, lc) if integral else gains, math.sqrt(lc * k1)))
    tried: list[tuple[float, float, bool]] = []
    best: tuple[float, int, float] | None = None  # (score, candidate, box scale)
    cap_scale = box.max_scale if box.declared else math.inf
    declared: dict[int, RobustCertificate] = {}  # each candidate's certificate on the declared box, once

    def on_declared(k: int) -> RobustCertificate:
        if k not in declared:
            declared[k] = robust_certificate(box, envelope, tube, candidates[k][0], current, actuators)
        return declared[k]

    def consider(k: int, target: float, cert: RobustCertificate) -> bool:
        nonlocal best
        tried.append((candidates[k][1], target, cert.covers))
        if cert.covers:
            score = _score(cert, actuators) / (1.0 + 1e-9 * target)  # prefer the larger target on ties
            if best is None or (target, -score) > (best[2], -best[0]):
                best = (score, k, target)
        return cert.covers

    big = TARGET_MARGIN if TARGET_MARGIN <= cap_scale else None
    with tqdm(total=len(candidates), disable=not progress, desc="LMI synthesis", unit="candidate") as bar:
        for k, (gains, _) in enumerate(candidates):
            bar.update(1)
            # the declared box first while no candidate covers the larger one: a candidate that
            # does not cover the declared box is not tried on the larger (this only orders the
            # search; every answer is certified)
            if (best is None or best[2] < TARGET_MARGIN) and not consider(k, 1.0, on_declared(k)):
                continue
            if big is not None:
                b = box.scaled(big) if box.declared else box
                consider(k, big, robust_certificate(b, envelope, tube, gains, current * big, actuators))
    if best is None:
        # nothing covers: show the candidate with the best objective on the declared box
        rated = [(g, w, on_declared(k)) for k, (g, w) in enumerate(candidates)]
        if not rated:
            gains = Gains(-lam / lc + 1.0, 1.0, heading_gains(box.nominal, (-1.0, -1.5)))
            gains = with_integral(gains, lam, lc) if integral else gains
            cert = robust_certificate(box, envelope, tube, gains, current, actuators)
            return RobustDesign(gains, 1.0, 0.0, cert, tuple(tried), "the synthesis LMI is infeasible at every rate")
        k = int(np.argmin([_score(c, None) if c.thrust is not None else math.inf for _, _, c in rated]))
        g, w, cert = rated[k]
        why = "no synthesised candidate covers the declared box; showing the one needing the least force"
        return RobustDesign(g, w, 0.0, cert, tuple(tried), why)
    score, k, target = best
    gains, w = candidates[k]
    cert = on_declared(k)
    unit = "of the actuator limits" if actuators is not None else "N"
    why = (
        f"LMI synthesis ({len(candidates)} candidates): {OBJECTIVE}; best {score:.4g} {unit} "
        f"among those covering the box scaled by {target:g}"
    )
    return RobustDesign(gains, w, target, cert, tuple(tried), why)


__all__ = ["DISTURBANCE_FLOOR", "OBJECTIVE", "RATES", "VELOCITY_SHARES", "synthesise_robust"]
