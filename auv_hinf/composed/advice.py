"""What would certify: the largest declared setting at which the composed certificate covers.

When :func:`~auv_hinf.composed.certificate.certify_deployed` does not cover a problem, each
*declared* setting that makes the problem harder (the noise bounds, the box, the current, the
delay, the sample time) is shrunk alone, the others kept, by bisection on a scale ``s`` in
``[0, 1]`` (:func:`largest_covered`). The value returned is one at which the certificate was
computed and covers, so re-running with it certifies; coverage is not proven monotone in ``s``,
so the bisection finds *a* covered value near the boundary, not necessarily the largest. When it
finds only zero covered, the scale is halved down from the smallest one that failed, so that a
small covered value is answered rather than the setting removed.

The noise found so is every channel's bound at one scale; its channels that need not shrink are
then put back at their declared bounds one at a time, and the ones that must shrink raised together
as far as a bisection finds (:func:`refined_noise`): the answer names the channel that binds.

A setting that is not declared (no noise, no box, no current, no delay) is never proposed, and
neither is one whose shrinking to zero does not cover either. When no one setting certifies
alone, the declared current and box (the water and the knowledge of the plant) are shrunk together
by one scale, the implementation kept as declared (its sample time, delay and noise are the
hardware's); when that does not certify either, the declared noise, delay, current and box are
shrunk *together* by one scale.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Literal

from auv_hinf.composed.certificate import (
    MAX_DELAY_SAMPLES,
    DeployedCertificate,
    DeployedProblem,
    certify_deployed,
)
from auv_hinf.numerics.bisection import bisect

#: The settings :func:`largest_covered` can shrink (``world``: the current and the box by one
#: scale; ``together``: the noise, the delay, the current and the box by one scale; each for when
#: no one of them alone certifies).
Knob = Literal["noise", "box", "current", "delay", "sample_time", "world", "together"]
#: Their order in the advice: what a deployment changes most easily first.
KNOBS: tuple[Knob, ...] = ("noise", "delay", "sample_time", "current", "box", "world", "together")
#: The settings ``world`` scales: the mission's water and the plant's box, not the hardware.
WORLD: tuple[Knob, ...] = ("current", "box")
#: The settings ``together`` scales.
TOGETHER: tuple[Knob, ...] = ("noise", "delay", "current", "box")
#: The settings each joint knob scales.
JOINT: dict[Knob, tuple[Knob, ...]] = {"world": WORLD, "together": TOGETHER}
#: Bisection steps per setting after the end check: the answer is within 1/16 of the declared
#: value below the boundary the bisection found (five certificates per setting in all).
ADVICE_STEPS = 4
#: Halvings below the smallest scale the bisection found failing, when it found none but zero
#: covered: an answer of 2^-6 of that (about 1/1000 of the declared value) is still a value to
#: re-run with, where zero would remove the setting (each halving is one certificate).
ADVICE_HALVINGS = 6
#: Significant digits of every scale the advice evaluates: the advised bounds read ``0.261 m`` and
#: ``0.0136 rad``, not ``0.26108594541 m`` and ``0.013671875 rad``. A bisection's midpoint is rounded
#: down before its certificate is computed, so the value answered is the one certified.
ADVICE_DIGITS = 3
#: Significant digits of a shrunk physical value (:func:`tidy`): 12 keep every digit a
#: three-digit scale of a declared value of up to nine digits gives, and drop the binary
#: product's noise in the 16th and 17th.
TIDY_DIGITS = 12
#: The sample time is shrunk down to this fraction of the declared one at most (a law 20 times
#: faster than declared is not advice a deployment can follow).
SAMPLE_TIME_FLOOR = 0.05
#: The noise's channels (:class:`~auv_hinf.implementation.model.MeasurementNoise`), in the order
#: :func:`refined_noise` tries to keep them at their declared bounds: the position first (an acoustic
#: fix, the dearest to improve), then the heading, the velocity, and the yaw rate (a gyro's, the
#: cheapest); an answer shrinks what a navigation suite improves most easily.
NOISE_CHANNELS: tuple[str, ...] = ("position", "heading", "velocity", "yaw_rate")


@dataclass(frozen=True)
class Advice:
    """One setting's value at which the composed certificate covers.

    Attributes
    ----------
    knob : str
        One of :data:`KNOBS`.
    scale : float
        The fraction of the declared value (``0 < scale < 1``).
    problem : DeployedProblem
        The problem with that setting shrunk.
    certificate : DeployedCertificate
        Its certificate (it covers).
    scaled : tuple of str
        The settings it changed (``(knob,)``, or the declared ones of the joint knob's :data:`JOINT`).
    original : DeployedProblem or None
        The problem as declared.
    channels : tuple of str
        For the noise: the channels (of :data:`NOISE_CHANNELS`) shrunk to ``scale`` of their
        declared bounds, the others kept (empty: every channel, as found before any was put back).
    ceiling : float
        The smallest scale a *re-run* (which designs its own gains) was found not to cover (1: the
        declared value): the re-runs that raise the answer bisect below it. A scale the design's gains
        do not cover is no ceiling: a re-run's gains may cover far more.
    """

    knob: Knob
    scale: float
    problem: DeployedProblem
    certificate: DeployedCertificate
    scaled: tuple[Knob, ...] = ()
    original: DeployedProblem | None = None
    channels: tuple[str, ...] = ()
    ceiling: float = 1.0


def declared_knobs(problem: DeployedProblem) -> tuple[Knob, ...]:
    """The settings of ``problem`` that are declared and can be shrunk, in :data:`KNOBS` order.

    Parameters
    ----------
    problem : DeployedProblem
        The problem.
    """
    impl = problem.implementation
    present = {
        "noise": not impl.noise.exact,
        "box": problem.plant.box.declared,
        "current": problem.plant.current > 0.0,
        "delay": impl.delay > 0.0,
        "sample_time": True,
    }
    present["world"] = all(present[k] for k in WORLD)
    # "together" beside "world" only when it shrinks some of the hardware too
    present["together"] = sum(present[k] for k in TOGETHER) >= 2 and any(present[k] for k in TOGETHER if k not in WORLD)
    return tuple(k for k in KNOBS if present[k])


def rounded_down(x: float, digits: int = ADVICE_DIGITS) -> float:
    """``x`` rounded down to ``digits`` significant digits (``x <= 0`` is returned as it is).

    Parameters
    ----------
    x : float
        A scale or a fraction.
    digits : int
        Significant digits kept.
    """
    if not x > 0.0:
        return x
    step = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return math.floor(x / step * (1.0 + 1e-12)) * step


def physical(scale: float, scaled: tuple[Knob, ...]) -> bool:
    """Settings ``scaled`` at ``scale`` of their declared values are something hardware can be: not noise at zero.

    Exact measurements are no navigation's: an answer that needs them says only that no noise the
    vehicle can have certifies, and another answer (a delay, a sample time, the mission) is sought.

    Parameters
    ----------
    scale : float
        The fraction of the declared values.
    scaled : tuple of str
        The settings scaled (:attr:`Advice.scaled`).
    """
    return scale > 0.0 or "noise" not in scaled


def tidy(x: float) -> float:
    """``x`` with the binary product's last digits dropped: ``0.1 * 0.7`` is ``0.07``, not ``0.06999999999999999``.

    The advice's values are products of a declared value and a scale of three digits; rounded to
    :data:`TIDY_DIGITS` significant digits they read as a person writes them, and the certificate
    is computed at the rounded value itself (:func:`shrunk`), so what is answered is what was
    certified.

    Parameters
    ----------
    x : float
        A physical value (s, m, m/s, rad, rad/s).
    """
    return float(f"{x:.{TIDY_DIGITS}g}")


def shrunk(problem: DeployedProblem, knob: Knob, scale: float, channels: tuple[str, ...] = ()) -> DeployedProblem:
    """``problem`` with the setting ``knob`` at ``scale`` times its declared value.

    Parameters
    ----------
    problem : DeployedProblem
        The problem.
    knob : str
        One of :data:`KNOBS`.
    scale : float
        In ``[0, 1]`` (the sample time is kept above :data:`SAMPLE_TIME_FLOOR` of the declared, and
        at most :data:`~auv_hinf.composed.certificate.MAX_DELAY_SAMPLES` samples within the delay).
    channels : tuple of str
        For the noise: the channels to shrink, the others kept (default: every channel).
    """
    impl, plant = problem.implementation, problem.plant
    if knob in JOINT:
        for k in JOINT[knob]:
            problem = shrunk(problem, k, scale)
        return problem
    if knob == "noise":
        n = impl.noise
        names = channels or NOISE_CHANNELS
        noise = replace(n, **{c: tidy(getattr(n, c) * scale) for c in names})
        return replace(problem, implementation=replace(impl, noise=noise))
    if knob == "delay":
        return replace(problem, implementation=replace(impl, delay=tidy(impl.delay * scale)))
    if knob == "sample_time":  # not below the floor, nor (when the declared one is within it) the delay's
        h = impl.sample_time * max(scale, SAMPLE_TIME_FLOOR)
        h = max(h, min(impl.sample_time, impl.delay / MAX_DELAY_SAMPLES))
        return replace(problem, implementation=replace(impl, sample_time=tidy(h)))
    if knob == "current":
        current, rate = tidy(plant.current * scale), tidy(plant.current_rate * scale)
        return replace(problem, plant=replace(plant, current=current, current_rate=rate))
    return replace(problem, plant=replace(plant, box=plant.box.scaled(scale)))


def largest_covered(
    problem: DeployedProblem, knob: Knob, certify: Callable[[DeployedProblem], DeployedCertificate] = certify_deployed
) -> Advice | None:
    """A covered value of one setting near the largest, by bisection (``None``: not even its smallest covers).

    Parameters
    ----------
    problem : DeployedProblem
        A problem the composed certificate does not cover.
    knob : str
        The setting to shrink (one of :func:`declared_knobs`).
    certify : callable
        The certificate (default :func:`~auv_hinf.composed.certificate.certify_deployed`).
    """
    floor = SAMPLE_TIME_FLOOR if knob == "sample_time" else 0.0
    found: dict[float, DeployedCertificate] = {}

    def covers(s: float) -> bool:  # at the scale rounded down (found: by the scale asked)
        cert = certify(shrunk(problem, knob, rounded_down(s)))
        found[s] = cert
        return cert.covers

    if not covers(floor):
        return None
    lo, hi = bisect(covers, floor, 1.0, steps=ADVICE_STEPS)
    if lo == 0.0:  # below the bisection's resolution: halve down from the smallest failing scale first
        for _ in range(ADVICE_HALVINGS):
            hi *= 0.5
            if covers(hi):
                lo, _ = bisect(covers, hi, 2.0 * hi, steps=ADVICE_STEPS // 2)
                break
    cert = found.get(lo)
    lo = rounded_down(lo)
    if cert is None or not cert.covers:  # bisect returns a point it evaluated as covered
        return None
    declared = declared_knobs(problem)
    scaled = tuple(k for k in JOINT[knob] if k in declared) if knob in JOINT else (knob,)
    found_advice = Advice(knob, lo, shrunk(problem, knob, lo), cert, scaled, problem)
    return refined_noise(found_advice, certify) if knob == "noise" and lo > 0.0 else found_advice


def channels_put_back(
    shrinking: Sequence[str], holds: Callable[[tuple[str, ...]], bool], last: bool = False
) -> tuple[str, ...]:
    """The noise channels still shrunk after each of ``shrinking``, in order, is put back where it can be.

    A channel is put back at its declared bound when ``holds`` of the channels then left shrunk is
    true (the answer still covers). The last channel left is tried only with ``last``: an answer that
    shrinks the noise alone never (the declared noise is the one refused), one that shrinks other
    settings with it may put back every channel.

    Parameters
    ----------
    shrinking : sequence of str
        The channels an answer shrinks (of :data:`NOISE_CHANNELS`), in the order to try them.
    holds : callable
        Whether the answer covers with only the given channels shrunk.
    last : bool
        Try the last channel left too (``holds`` of the empty tuple).
    """
    left = list(shrinking)
    for channel in shrinking:
        rest = tuple(c for c in left if c != channel)
        if (rest or last) and holds(rest):
            left.remove(channel)
    return tuple(left)


def refined_noise(
    advice: Advice, certify: Callable[[DeployedProblem], DeployedCertificate] = certify_deployed
) -> Advice:
    """``advice`` (every noise channel at one scale) with the channels that need not shrink kept as declared.

    Each declared channel in :data:`NOISE_CHANNELS` order (the dearest first) is put back at its
    declared bound, the others as they stand, and kept there when the certificate still covers (one
    certificate each); the channels left are then raised together from the advised scale by a
    geometric bisection (:data:`ADVICE_STEPS` certificates; the advised scale may be a small
    fraction). Every value returned was certified: the answer only grows.

    Parameters
    ----------
    advice : Advice
        A covering answer of the ``noise`` knob with every channel at ``advice.scale > 0``.
    certify : callable
        The certificate the answer was found with.
    """
    original = advice.original
    if original is None:
        return advice
    declared = tuple(c for c in NOISE_CHANNELS if getattr(original.implementation.noise, c) > 0.0)
    best = advice

    def holds(rest: tuple[str, ...]) -> bool:
        nonlocal best
        trial = shrunk(original, "noise", advice.scale, rest)
        cert = certify(trial)
        if cert.covers:
            best = replace(advice, problem=trial, certificate=cert, channels=rest)
        return cert.covers

    channels = channels_put_back(declared, holds)
    if len(channels) == len(declared):
        return replace(advice, channels=declared)  # every channel binds: named all the same
    found: dict[float, DeployedCertificate] = {advice.scale: best.certificate}

    def covers(scale: float) -> bool:  # at the scale rounded down (found: by the scale asked)
        found[scale] = certify(shrunk(original, "noise", rounded_down(scale), channels))
        return found[scale].covers

    lo = bisect(covers, advice.scale, 1.0, steps=ADVICE_STEPS, geometric=True)[0]
    if lo <= advice.scale or not found[lo].covers or rounded_down(lo) <= advice.scale:
        return best
    cert, lo = found[lo], rounded_down(lo)
    return replace(best, scale=lo, problem=shrunk(original, "noise", lo, channels), certificate=cert)


__all__ = [
    "ADVICE_DIGITS",
    "ADVICE_HALVINGS",
    "ADVICE_STEPS",
    "JOINT",
    "KNOBS",
    "NOISE_CHANNELS",
    "SAMPLE_TIME_FLOOR",
    "TIDY_DIGITS",
    "TOGETHER",
    "WORLD",
    "Advice",
    "Knob",
    "channels_put_back",
    "declared_knobs",
    "largest_covered",
    "physical",
    "refined_noise",
    "rounded_down",
    "shrunk",
    "tidy",
]
