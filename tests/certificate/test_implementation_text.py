"""The implementation section of ``certify``'s text: one verdict, with what governs it; limits that say what
they are the largest of."""

from __future__ import annotations

from typing import Any

import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.parts.implementation import ImplementationPart
from auv_hinf.certificate.text import certificate_text
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import config_from_dict
from tests.helpers import failed_certificate

VERDICT = "  implementation covered"

#: A 10 Hz law with a delay, as the JSON record gives it: stable, but its error bounds leave the envelope.
SAMPLED: dict[str, Any] = {
    "continuous": False,
    "description": "10 Hz (0.1 s ZOH), delay 0.05 s, noise <= 0.05 m, 0 m/s, 0.01 rad, 0 rad/s",
    "sample_time": 0.1,
    "delay": 0.05,
    "max_sample_time": 0.4767,
    "max_delay": 0.4267,
    "exact_max_sample_time": 1.162,
    "tightness": 0.41,
    "error_bounds": None,
    "ultimate_bounds": None,
    "decay_rate": 0.1,
    "covers": False,
    "covered_sample_time": 0.02,
    "searched_sample_time": True,
    "governed_by": "envelope",
    "reasons": ["the error bounds leave the envelope (last bounds |e| <= 25.2 m)", "sample times up to 0.02 s"],
}


def lines(**changes: Any) -> list[str]:
    return ImplementationPart().lines({**SAMPLED, **changes}, {})


def verdicts(text: list[str]) -> list[str]:
    return [line for line in text if line.startswith(VERDICT)]


def test_one_verdict_names_what_governs_it_and_that_stability_holds():
    text = lines()
    (verdict,) = verdicts(text)
    assert verdict.startswith(f"{VERDICT}    NO, governed by the envelope: the error bounds leave the envelope")
    assert verdict.endswith("(sample time 0.1 s, within the stability limit)")
    assert "sample times up to" not in verdict  # the other reasons have lines of their own, or the list below
    assert text[-1] == verdict


def test_the_largest_sample_times_say_what_they_are_the_largest_of():
    stability, covered = (next(line for line in lines() if line.startswith(f"  {k}")) for k in ("stability", "covered"))
    assert "sample time <= 0.4767 s, the largest at which the error loops alone (no noise, no envelope)" in stability
    assert "certified stable with delay 0.05 s" in stability
    assert covered.endswith(
        "<= 0.02 s (50 Hz): the largest covered with this delay (0.05 s) and noise, on this mission"
    )
    (none,) = [line for line in lines(covered_sample_time=None) if line.startswith("  covered")]
    assert none.endswith("none: no sample time is covered with this delay (0.05 s) and noise, on this mission")


def test_a_sample_time_past_the_stability_limit_is_governed_by_it():
    (verdict,) = verdicts(lines(sample_time=0.6, governed_by="stability", reasons=["sample_time + delay = 0.65 s"]))
    assert verdict == f"{VERDICT}    NO, governed by the stability limit: sample_time + delay = 0.65 s"


def test_a_covered_implementation_says_yes_once_and_no_search():
    text = lines(covers=True, governed_by=None, reasons=[], covered_sample_time=None, searched_sample_time=False)
    assert verdicts(text) == [f"{VERDICT}    yes"] and not any(line.startswith("  covered") for line in text)


def test_the_continuous_default_decides_nothing_and_prints_no_verdict():
    for covers in (True, False):  # whatever the continuous certificates say
        text = lines(continuous=True, sample_time=0.0, delay=0.0, covers=covers, governed_by=None, reasons=[])
        assert verdicts(text) == [] and not any("NO" in line for line in text)


def test_a_record_written_before_governors_still_prints_one_verdict():
    old = {k: v for k, v in SAMPLED.items() if k not in ("governed_by", "searched_sample_time")}
    text = ImplementationPart().lines(old, {})
    assert verdicts(text) == [f"{VERDICT}    NO: the error bounds leave the envelope (last bounds |e| <= 25.2 m)"]


@pytest.mark.slow
def test_certify_text_continuous_and_sampled():
    for cert in (certify(preset_config("paper-triangle")), failed_certificate()):
        text = cert.summary().splitlines()
        assert verdicts(text) == [] and "implementation covered" not in cert.summary()
        assert not any("NO" in line for line in text if line.startswith("  implementation"))
    data = preset_config("paper-triangle").to_toml_dict()
    impl = {"sample_time": 0.1, "delay": 0.05, "noise": {"position": 0.05, "heading": 0.01}}
    cert = certify(config_from_dict({**data, "implementation": impl}))
    text = cert.summary()
    assert certificate_text(cert.to_dict()) == text  # written from the JSON record alone
    (verdict,) = verdicts(text.splitlines())
    assert "NO, governed by the envelope: the error bounds leave the envelope" in verdict
    assert "within the stability limit" in verdict
    assert "with this delay (0.05 s) and noise, on this mission" in text
    own = "implementation not covered by its own certificate (the composed certificate judges the deployed loop)"
    assert any(r.startswith(f"{own}: the error bounds leave") for r in cert.reasons)


@pytest.mark.slow
def test_a_delay_that_uses_the_whole_certified_lag_prints_no_vacuous_limit():
    """Sample time and delay each beyond the certified total lag: no ``<= 0 s`` limit, and the delay to set."""
    doc = preset_config("paper-triangle").to_toml_dict()
    cfg = config_from_dict({**doc, "implementation": {"sample_time": 60.0, "delay": 60.0}})
    text = certify(cfg).summary()
    assert "<= 0 s" not in text, text
    line = next(x for x in text.splitlines() if x.startswith("  stability limit (LK)"))
    assert "the delay and the sample time each reach" in line
    assert "set [implementation] delay < " in text


def _refusing(parts: dict[str, bool]) -> dict[str, Any]:
    """A certificate record whose parts all refuse, each with values advised (``True``) or none."""
    entries = {
        name: {
            "applies": True,
            "ok": False,
            "note": "",
            "reasons": [{"settings": [{"table": "t", "key": name, "value": 1.0}] if values else []}],
        }
        for name, values in parts.items()
    }
    reasons = [f"{n}: refused" for n in parts]
    return {"preset": "p", "n": 2, "vehicle": {}, "parts": entries, "certified": False, "reasons": reasons}


@pytest.mark.parametrize(
    ("parts", "says", "not_says"),
    [
        ({"composed": True, "robust": False, "implementation": False}, "only composed advises values", "every part"),
        (
            {"composed": True, "actuators": True, "robust": False},
            "write the advice of every part that gives values",
            "only",
        ),
    ],
)
def test_several_refusals_say_which_parts_give_values(parts, says, not_says):
    """Several parts refuse: the text asks for the values of the parts that give some, and names the others."""
    text = certificate_text(_refusing(parts), registered={})
    line = text.splitlines()[-1]
    assert says in line and not_says not in line, line
    if "every part" in says:
        assert "(robust gives none)" in line


@pytest.mark.parametrize(
    ("delay", "noise", "named"),
    [
        (0.0, {"heading": 0.01}, ["[implementation.noise] heading (0.01 rad)"]),
        (0.1, {"position": 0.5, "yaw_rate": 0.002}, ["delay (0.1 s)", "position (0.5 m)", "yaw_rate (0.002 rad/s)"]),
    ],
)
def test_no_covered_sample_time_names_each_declared_noise_bound_with_its_value(delay, noise, named):
    from auv_hinf.certificate.parts.implementation import no_sample_time_covered
    from auv_hinf.implementation.model import Implementation, MeasurementNoise

    text = no_sample_time_covered(Implementation(0.1, delay, noise=MeasurementNoise(**noise)))
    for words in named:
        assert words in text
    for key in {"position", "velocity", "heading", "yaw_rate"} - set(noise):
        assert f"] {key} (" not in text  # nothing undeclared is asked to be reduced
    if not delay:
        assert "delay (" not in text


def test_a_sampled_law_the_composed_certificate_refuses_gets_no_sample_time_from_the_stand_in():
    """With a sampled formation law the composed certificate judges the deployed loop; the implementation
    part's own covered sample time is not the deployed loop's (the composed part refuses at it too), so it
    is reported, not advised: the values to write are the composed part's."""
    tables = {
        "vehicle": {"m11": 230.0, "m22": 212.0, "m33": 92.0, "d11_lin": 59.5, "d11_quad": 121.0}
        | {"d22_lin": 83.0, "d22_quad": 236.0, "d33_lin": 61.0, "d33_quad": 74.0},
        "formation": {"n": 2, "polygon_radius": 10.0},
        "envelope": {"u": [0.0, 3.5], "v": [-1.5, 1.5], "r": [-0.5, 0.5]},
        "reference": {"kind": "sine", "speed": 1.0, "amplitude": 30.0, "omega": 0.1},
        "implementation": {"sample_time": 0.1},
    }
    cert = certify(config_from_dict(tables, "sampled sine"))
    by_part = {r.part: r for r in cert.findings}
    assert not cert.certified and {"composed", "implementation"} <= set(by_part)
    assert by_part["composed"].settings
    assert by_part["implementation"].settings == ()
    assert "sample times up to" in by_part["implementation"].message  # still said, as what its own certificate covers
