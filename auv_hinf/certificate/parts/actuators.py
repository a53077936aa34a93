"""The actuator part of a certificate: the force the law commands against what the vehicle can push.

The certified peak is the elementwise largest of the thrust bounds the certificate proves
(:func:`~auv_hinf.actuation.thrust.thrust_bounds`: feed-forward, model
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
(:func:`~auv_hinf.closed_loop.actuator_fit.within_actuators`).

``required_limits`` (the certified peak itself) are the smallest per-channel limits that would
certify the declared case.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from auv_hinf.actuation.limits import CHANNELS, Actuators, actuator_shortfall
from auv_hinf.certificate.design_point import DesignPoint
from auv_hinf.robust.margin import largest_certifiable

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
    best = None
    if answers and point.declared and point.gains is not None:
        cfg = point.config
        best = largest_certifiable(
            point.box,
            cfg.envelope,
            point.tube,
            point.gains,
            point.current,
            act,
            redesign=cfg.synthesis if cfg.robust else None,
            integral=cfg.integral,
        )
    elif answers and point.declared:
        best = {"box_scale": None, "current_speed": None}
    return ActuatorCheck(act, peak, channel, ratio, False, why, best)


__all__ = ["ActuatorCheck", "Peak", "check_actuators", "peak_of"]
