"""The actuator part of a certificate: the force the law commands against what the vehicle can push.

The certified peak is the elementwise largest of the thrust bounds the certificate proves
(:func:`~auv_hinf.certification.thrust.thrust_bounds`: feed-forward, model
cancellation, current compensation and feedback, over the certified set and the whole
mission): the nominal closed loop over its start region, the configured shaped start when it
is checked, and the robust certificate of the declared box and current. The design is
certified for the actuators only when the box of these peaks fits the declared limits.

When it does not, :func:`largest_certifiable` answers what does fit, each by bisection on
certificates (the lower end of every bisection is a certified value, so re-running at it
certifies; with ``[design] robust = true`` the answer is confirmed by re-running the robust
design there, as a re-run of ``certify`` would):

* ``box_scale_alone``: the largest scale of the declared ``[uncertainty]`` box (declared current);
* ``current_speed_alone``: the largest current speed (declared box);
* ``box_scale`` and ``current_speed``: a pair that certifies *together*, the one to re-run with
  (one of the answers alone with the other declared value, both when they are confirmed
  together, else box and current scaled together), with the scaled ``uncertainty`` table.

The nominal start region needs no answer of its own: it is already shrunk to fit the limits
(:func:`~auv_hinf.certification.actuation.within_actuators`).

``required_limits`` (the certified peak itself) are the smallest per-channel limits that would
certify the declared case.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from auv_hinf.models.actuators import CHANNELS, Actuators, actuator_shortfall
from auv_hinf.robust.bandwidth import design_robust
from auv_hinf.robust.box import PARAMETERS
from auv_hinf.robust.certificate import robust_certificate
from auv_hinf.robust.synthesis import synthesise_robust
from auv_hinf.workflow.design_point import DesignPoint

#: Bisection steps of :func:`largest_certifiable` with fixed gains: the answer is within 2^-12
#: (0.02 %) of the declared value below the true largest certifiable value, never above it.
BISECTION_STEPS = 12
#: With ``[design] robust = true`` a re-run of ``certify`` re-designs the gains for the smaller
#: box or current, so each answer found with the design's gains is confirmed by re-running the
#: robust design there; an answer that does not confirm is halved, at most this many times.
REDESIGN_TRIES = 3

Peak = tuple[float, float, float]


@dataclass(frozen=True)
class ActuatorCheck:
    """What ``certify`` reports under ``actuators``.

    Attributes
    ----------
    limits : Actuators or None
        The declared limits (``None``: none declared, the certificate assumes unlimited thrust).
    certified_peak : tuple of float or None
        ``(|tau_x|, |tau_y|, |tau_psi|)`` the law can command on the certified set (N, N, N m);
        ``None`` when no certificate bounds it.
    binding : str or None
        The channel with the largest peak-to-limit ratio (``force_x``, ``force_y``, ``moment``).
    binding_ratio : float or None
        That ratio (above 1: the channel cannot deliver the peak).
    certified : bool
        Limits declared, a peak certified, and the peak within the limits.
    reason : str
        One sentence on the verdict.
    largest_certifiable : dict or None
        When the limits bind: a ``box_scale`` and ``current_speed`` that certify together within
        them, with the scaled ``uncertainty`` table, and each answer alone (see
        :func:`largest_certifiable`).
    """

    limits: Actuators | None
    certified_peak: Peak | None
    binding: str | None
    binding_ratio: float | None
    certified: bool
    reason: str
    largest_certifiable: dict[str, Any] | None = None

    def lines(self) -> list[str]:
        """Lines of ``Certificate.summary``."""
        if self.certified_peak is None:
            return [f"  actuators                 {self.reason}"]
        fx, fy, m = self.certified_peak
        out = [f"  commanded force (certified) |tau_x| <= {fx:.5g} N, |tau_y| <= {fy:.5g} N, |tau_psi| <= {m:.5g} N m"]
        if self.limits is None:
            out.append(f"  actuators                 {self.reason}")
            return out
        lx, ly, lm = self.limits.limits()
        verdict = "fit" if self.certified else "do NOT fit"
        out.append(f"  actuator limits           {lx:.5g} N, {ly:.5g} N, {lm:.5g} N m: the peaks {verdict}")
        if not self.certified:
            out.append(f"    {self.reason}")
        if self.largest_certifiable is not None:
            best = self.largest_certifiable
            if best.get("current_speed") is None:
                out.append(
                    "    largest certifiable within the limits: none (not even the nominal plant in still water)"
                )
            else:
                box = "n/a" if best.get("box_scale") is None else f"{best['box_scale']:.4g}"
                out.append(
                    f"    largest certifiable within the limits: box scale {box} with current "
                    f"{best['current_speed']:.4g} m/s (re-run with these)"
                )
        return out

    def to_dict(self) -> dict[str, Any]:
        """The ``actuators`` object of ``auv-hinf certify --json``."""
        peak = None if self.certified_peak is None else dict(zip(CHANNELS, self.certified_peak))
        out: dict[str, Any] = {
            "limits": None if self.limits is None else self.limits.to_dict(),
            "certified_peak": peak,
            "required_limits": peak,
            "binding": self.binding,
            "binding_ratio": self.binding_ratio,
            "certified": self.certified,
            "reason": self.reason,
        }
        if self.largest_certifiable is not None:
            out["largest_certifiable"] = dict(self.largest_certifiable)
        return out


def peak_of(bounds: list[Peak]) -> Peak | None:
    """Elementwise largest of thrust bounds (``None`` for none)."""
    if not bounds:
        return None
    return (max(b[0] for b in bounds), max(b[1] for b in bounds), max(b[2] for b in bounds))


def check_actuators(point: DesignPoint, peaks: list[Peak], *, answers: bool = True) -> ActuatorCheck:
    """The actuator verdict of a design whose certificates bound the thrust by ``peaks``.

    ``answers`` computes :func:`largest_certifiable` when the limits bind.
    """
    act = point.config.actuators
    peak = peak_of(peaks)
    if act is None:
        why = "no actuator limits declared ([actuators]): the certificate assumes unlimited thrust"
        return ActuatorCheck(None, peak, None, None, False, why)
    if peak is None:
        return ActuatorCheck(act, None, None, None, False, "no certificate bounds the commanded force")
    channel, ratio = act.binding(peak)
    if act.admits(peak):
        why = f"the certified peak force fits the limits (binding: {channel}, {ratio:.3g} of its limit)"
        return ActuatorCheck(act, peak, channel, ratio, True, why)
    why = actuator_shortfall(act, peak)
    if act.note:
        why += f" ({act.note})"
    best = largest_certifiable(point, act) if answers and point.declared else None
    return ActuatorCheck(act, peak, channel, ratio, False, why, best)


def largest_certifiable(point: DesignPoint, act: Actuators) -> dict[str, Any]:
    """A box scale and a current speed that certify together within ``act``, largest first.

    ``box_scale`` and ``current_speed`` are a pair to re-run with (``uncertainty`` gives the
    scaled ``[uncertainty]`` table); ``box_scale_alone`` (declared current) and
    ``current_speed_alone`` (declared box) are the largest of each with the other unchanged.
    Each is ``None`` when it does not apply (nothing of that kind declared) or when not even
    zero certifies.
    """
    cfg = point.config
    gains = point.gains
    out: dict[str, Any] = {"box_scale": None, "current_speed": None}
    if gains is None:
        return out
    box, current = point.box, point.current

    def fits(scale: float, speed: float) -> bool:
        return robust_certificate(box.scaled(scale), cfg.envelope, point.tube, gains, speed, act).covers

    def redesign_fits(scale: float, speed: float) -> bool:
        b = box.scaled(scale)
        if cfg.synthesis == "lmi":
            design = synthesise_robust(b, cfg.envelope, point.tube, speed, act, integral=cfg.integral)
        else:
            design = design_robust(b, cfg.envelope, point.tube, speed, act, fallback=False, integral=cfg.integral)
        return design.target > 0.0 and robust_certificate(b, cfg.envelope, point.tube, design.gains, speed, act).covers

    def answer(scale_of: Any, top: float) -> float | None:
        """Bisection with the design's gains; with a robust design, confirmed by re-running it."""
        x = _largest(lambda v: fits(*scale_of(v)), top, BISECTION_STEPS)
        if x is None or not cfg.robust:
            return x
        for _ in range(REDESIGN_TRIES):
            if redesign_fits(*scale_of(x)):
                return x
            x *= 0.5
        return None

    top = min(1.0, box.max_scale)
    alone_box = answer(lambda s: (s, current), top) if box.declared else None
    alone_current = answer(lambda c: (1.0, c), current) if current > 0.0 else None

    def pair_fits(scale: float, speed: float) -> bool:
        return fits(scale, speed) and (not cfg.robust or redesign_fits(scale, speed))

    # the pair to re-run with: each answer alone holds the other at its declared value, so one
    # of them alone is a certified pair; when both shrink, the pair is confirmed together, and
    # when neither alone helps, box and current are scaled together
    if alone_box is not None and alone_current is None:
        pair: tuple[float | None, float] | None = (alone_box, current)
    elif alone_current is not None and alone_box is None:
        pair = (1.0 if box.declared else None, alone_current)
    elif alone_box is not None and alone_current is not None and pair_fits(alone_box, alone_current):
        pair = (alone_box, alone_current)
    elif box.declared and current > 0.0:
        joint = answer(lambda s: (s, s * current), top)
        pair = None if joint is None else (joint, joint * current)
    else:
        pair = None
    out["box_scale_alone"], out["current_speed_alone"] = alone_box, alone_current
    if pair is not None:
        out["box_scale"], out["current_speed"] = pair
        if pair[0] is not None:
            scaled = box.scaled(pair[0])
            out["uncertainty"] = {
                name: [lo, hi] for name, lo, hi in zip(PARAMETERS, scaled.lo, scaled.hi) if lo < 1.0 or hi > 1.0
            }
    return out


def _largest(fits: Any, top: float, steps: int) -> float | None:
    """Largest ``x`` in ``[0, top]`` with ``fits(x)``, by bisection (``fits`` monotone); ``None`` if not 0."""
    if fits(top):
        return top
    if not fits(0.0):
        return None
    lo, hi = 0.0, top
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


__all__ = [
    "BISECTION_STEPS",
    "REDESIGN_TRIES",
    "ActuatorCheck",
    "check_actuators",
    "largest_certifiable",
    "peak_of",
]
