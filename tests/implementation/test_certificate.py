"""The implementation certificate: limits against the exact reference, verdicts, bounds."""

from __future__ import annotations

import itertools
import math

import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.parts.implementation import implementation_problem, implementation_summary, start_errors
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import config_from_dict
from auv_hinf.implementation.lag import lag_disturbance
from auv_hinf.implementation.limits import spectral_radius
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.implementation.sampled_data import certify_implementation, lag_limits
from auv_hinf.mission.margins import ErrorBounds
from tests.helpers import BLUEROV_SLOW

SMALL_NOISE = MeasurementNoise(0.001, 0.001, 0.001, 0.001)
ERRORS = ("position", "velocity", "heading", "yaw_rate")


def _problem(cfg):
    point = design_point(cfg)
    return implementation_problem(point, closed_loop_for(point)), start_errors(point)


@pytest.fixture(scope="module")
def slow():
    return _problem(config_from_dict(BLUEROV_SLOW))


@pytest.fixture(scope="module")
def slow_limits(slow):
    """The lag limits of ``slow`` without delay, shared by the certificates below (they cost LMI bisections)."""
    prob, _ = slow
    return lag_limits(prob.loops, prob.nominal_dampings, 0.0)


@pytest.fixture(scope="module")
def base(slow, slow_limits):
    """``slow`` at 100 Hz, no delay, 1 mm (and 1 mm/s, 1 mrad, 1 mrad/s) of noise: covered."""
    prob, start = slow
    return certify_implementation(prob, Implementation(0.01, 0.0, noise=SMALL_NOISE), start, slow_limits)


def _no_tighter(looser: ErrorBounds, tighter: ErrorBounds) -> list[str]:
    """The error kinds whose bound in ``looser`` is below the one in ``tighter``."""
    return [k for k in ERRORS if getattr(looser, k) < getattr(tighter, k)]


@pytest.mark.slow
def test_a_fast_small_noise_implementation_is_covered_with_consistent_bounds(slow):
    prob, start = slow
    cert = certify_implementation(prob, Implementation(0.01, 0.0, noise=SMALL_NOISE), start)
    assert cert.covers, cert.reasons
    b, u = cert.bounds, cert.ultimate
    assert b is not None and u is not None
    for name in ("position", "velocity", "heading", "yaw_rate"):
        assert 0.0 < getattr(u, name) <= getattr(b, name)
    assert cert.thrust is not None and prob.actuators is not None and prob.actuators.admits(cert.thrust.as_tuple())
    assert 0 < cert.decay_rate


@pytest.mark.slow
def test_more_noise_or_slower_sampling_never_tightens_the_bounds(slow, slow_limits, base):
    """50 % more noise at 100 Hz, or 100 Hz against 200 Hz and 1 kHz: all covered, no bound smaller, some larger.

    At one sample time the LMI certificates do not depend on the noise and every noise term of
    the disturbance and of the force grows with it, so the fixed point can only grow. Over
    sample times there is no such argument (each lag gets its own LMI solution), so the
    monotonicity is checked where the lag-channel certificate covers (1 ms to 10 ms here).
    """
    prob, start = slow

    def at(h: float, noise: MeasurementNoise = SMALL_NOISE):
        return certify_implementation(prob, Implementation(h, 0.0, noise=noise), start, slow_limits)

    noisier = at(0.01, MeasurementNoise(0.0015, 0.0015, 0.0015, 0.0015))
    chain = [noisier, base, at(0.005), at(0.001)]  # each one's bounds at least the next one's
    for cert in chain:
        assert cert.covers, cert.reasons
    for looser, tighter in itertools.pairwise(chain):
        assert looser.bounds is not None and tighter.bounds is not None
        assert looser.ultimate is not None and tighter.ultimate is not None
        assert not _no_tighter(looser.bounds, tighter.bounds)
        assert not _no_tighter(looser.ultimate, tighter.ultimate)
        # and the change is real: noise and lag both enter the position bound
        assert looser.ultimate.position > tighter.ultimate.position * (1.0 + 1e-3)


@pytest.mark.slow
def test_slower_sampling_never_shrinks_the_lag_disturbance(slow, base):
    """For fixed error and force bounds, the disturbance the held, older command adds grows with the lag.

    Every term of :func:`~auv_hinf.implementation.lag.lag_disturbance` is non-decreasing in
    ``sample_time + delay`` (the state's change over the lag, the reference's change, the body
    accelerations of the held force), and it vanishes but for the noise at zero lag.
    """
    prob, _ = slow
    assert base.bounds is not None and base.thrust is not None

    def disturbance(h: float, noise: MeasurementNoise = SMALL_NOISE) -> tuple[float, float]:
        d = lag_disturbance(
            prob.params,
            prob.envelope,
            prob.tube,
            prob.gains,
            Implementation(h, 0.0, noise=noise),
            lam=prob.lam,
            sigma=prob.sigma,
            jerk=prob.jerk,
            force=base.thrust,
            bounds=base.bounds,
            yaw_jerk=prob.yaw_jerk,
        )
        return d.position, d.heading

    sample_times = (0.0, 0.001, 0.01, 0.05, 0.1)
    values = [disturbance(h) for h in sample_times]
    for (p0, h0), (p1, h1) in itertools.pairwise(values):
        assert p1 > p0 and h1 >= h0
    assert disturbance(0.0, MeasurementNoise()) == (0.0, 0.0)


@pytest.mark.slow
def test_a_sample_time_above_the_exact_limit_is_not_covered(slow):
    prob, start = slow
    limits = lag_limits(prob.loops, prob.nominal_dampings, 0.0)
    assert limits.lag <= limits.exact_sample_time
    cert = certify_implementation(prob, Implementation(1.05 * limits.exact_sample_time, 0.0), start)
    assert not cert.covers and "exceeds the certified" in cert.reasons[0]
    assert cert.max_sample_time <= cert.exact_max_sample_time


@pytest.mark.parametrize(
    ("preset", "exactly_stable"),
    [
        pytest.param("paper-triangle", True, marks=pytest.mark.slow),
        pytest.param("bluerov2-line", False, marks=pytest.mark.slow),
        pytest.param("remus-line", False, marks=pytest.mark.slow),
    ],
)
@pytest.mark.slow
def test_presets_at_10_hz_with_delay_say_whether_covered(preset, exactly_stable):
    """At 10 Hz with a 0.1 s delay the verdict agrees with an exact reference, and it decides the certificate.

    The reference is the presets' nominal loops held over 0.1 s and delayed by 0.1 s, discretised
    by python-control: unstable for the two fast designs, so no certificate may cover them;
    stable for the paper's, whose refusal must then come from the error bounds (its start is
    25 m off the slots), not from the lag. The whole ``certify`` (its verdict decided by the
    implementation part) is run on the paper's preset; the fast designs' refusals are the
    implementation part's own (``certify`` would add minutes of advice searches for their
    refused thrust, which other tests follow).
    """
    cfg = preset_config(preset)
    impl = Implementation(0.1, 0.1, noise=MeasurementNoise(0.05, 0.02, 0.01, 0.005))
    deployed = config_from_dict({**cfg.to_toml_dict(), "implementation": impl.to_dict()})
    point = design_point(cfg)
    prob = implementation_problem(point, closed_loop_for(point))
    radii = [spectral_radius(a, lp.k, lp.b, 0.1, 0.1, control=True) for a, lp in zip(prob.nominal_dampings, prob.loops)]
    assert (max(radii) < 1.0) == exactly_stable
    if exactly_stable:
        cert = certify(deployed)
        d = cert.to_dict()["implementation"]
        part = cert.verdict("implementation")
        assert part is not None and part.applies and part.ok == d["covers"]
        assert any("implementation not covered" in r for r in cert.reasons) == (not d["covers"])
        assert d["sample_time"] == 0.1 and d["delay"] == 0.1
        assert not d["covers"] and not cert.certified
        assert d["max_sample_time"] >= 0.1 and d["exact_max_sample_time"] >= 0.1
        assert "the error bounds leave the envelope" in d["reasons"][0]
    else:  # soundness: the unstable loop is refused, and the limits say why
        deployed_point = design_point(deployed)
        summary = implementation_summary(deployed_point, closed_loop_for(deployed_point), True, search=False)
        c = summary.certificate
        assert c is not None and not summary.covers and not c.covers
        assert c.implementation.sample_time == 0.1 and c.implementation.delay == 0.1
        assert c.max_sample_time < 0.1 and (c.exact_max_sample_time or 0.0) < 0.1
        assert "exceeds the certified" in summary.reasons[0]


@pytest.mark.slow
def test_the_continuous_default_reports_limits_and_the_continuous_verdict():
    cert = certify(preset_config("paper-triangle"))
    d = cert.to_dict()["implementation"]
    assert d["continuous"] and d["covers"] == cert.certified
    assert 0.3 * d["exact_max_sample_time"] <= d["max_sample_time"] <= d["exact_max_sample_time"]
    assert d["tightness"] == pytest.approx(d["max_sample_time"] / d["exact_max_sample_time"])


@pytest.mark.slow
def test_the_largest_covered_sample_time_is_itself_covered():
    """The implementation certificate's own search (the composed certificate may supersede it in ``certify``)."""

    def summary(h: float):
        cfg = config_from_dict({**BLUEROV_SLOW, "implementation": {"sample_time": h, "noise": SMALL_NOISE.to_dict()}})
        point = design_point(cfg)
        return implementation_summary(point, closed_loop_for(point), continuous_ok=True), cfg

    impl, cfg = summary(0.2)
    assert not impl.covers
    h = impl.covered_sample_time
    assert h is not None and 0 < h < 0.2
    assert summary(h)[0].covers
    assert ErrorBounds(0, 0, 0, 0) == start_errors(design_point(cfg))


@pytest.fixture(scope="module")
def fast(slow, slow_limits):
    """``slow`` at 1 kHz with the small noise: covered."""
    prob, start = slow
    return certify_implementation(prob, Implementation(1e-3, 0.0, noise=SMALL_NOISE), start, slow_limits)


@pytest.mark.slow
@pytest.mark.parametrize("h", [1e-12, pytest.param(1e-6, marks=pytest.mark.slow)])
def test_tiny_sample_times_are_certified_like_fast_ones(slow, slow_limits, fast, h):
    """A sample time far below the LMI's smallest solved lag is covered, at the same rate, with bounds like 1 kHz's.

    The LMI is solved at a floor lag (a fraction of the fastest time constant), so ``1/tau``
    cannot blow up; what changes with ``h`` is only the small lag part of the disturbance.
    """
    prob, start = slow
    cert = certify_implementation(prob, Implementation(h, 0.0, noise=SMALL_NOISE), start, slow_limits)
    assert fast.covers, fast.reasons
    assert cert.covers, cert.reasons
    assert cert.decay_rate == pytest.approx(fast.decay_rate, rel=1e-6)
    assert cert.max_sample_time == fast.max_sample_time and math.isfinite(cert.max_sample_time)
    assert cert.ultimate is not None and fast.ultimate is not None
    for kind in ERRORS:
        # the same order of size as at 1 kHz: within 25 % (the noise, not the lag, dominates both)
        assert getattr(cert.ultimate, kind) == pytest.approx(getattr(fast.ultimate, kind), rel=0.25), kind


@pytest.mark.slow
@pytest.mark.parametrize("delay_fraction", [0.0, 0.5, 1.2])
def test_lag_advice_names_a_setting_and_its_value_that_passes_the_stability_check(slow, delay_fraction):
    """The stability refusal of a lag past the certified one states the limit, and staying below it clears it.

    With room left for a sample time, the reason states the largest stable sample time (a necessary
    condition: the implementation part searches the covered one below it); when the delay alone uses
    the lag up, it advises the delay that leaves room.
    """
    prob, start = slow
    lag = lag_limits(prob.loops, prob.nominal_dampings, 0.0).lag
    delay = delay_fraction * lag
    limits = lag_limits(prob.loops, prob.nominal_dampings, delay)
    sample_time = max(1.05 * limits.lag - delay, 0.05 * limits.lag)  # the total lag just past the certified one
    why = certify_implementation(prob, Implementation(sample_time, delay), start, limits).reasons[0]
    assert "bandwidth" not in why
    if delay < limits.lag:
        setting, value = "sample_time", float(why.split("stable for sample times <= ", 1)[1].split(" s")[0])
        assert "set [implementation]" not in why
    else:
        setting, value = "delay", float(why.split("set [implementation] delay < ", 1)[1].split(" s")[0])
    fixed = Implementation(0.99 * value, delay) if setting == "sample_time" else Implementation(0.0, 0.99 * value)
    fixed_limits = lag_limits(prob.loops, prob.nominal_dampings, fixed.delay)
    again = certify_implementation(prob, fixed, start, fixed_limits)
    assert not any("exceeds the certified" in r for r in again.reasons)
