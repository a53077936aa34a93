"""When no declared effect, shrunk, certifies the deployed loop: the design or the mission does, and re-runs.

A BlueROV2 survey on a lawn-mower with 10 m turns at 10 Hz is not covered by the composed
certificate even with no noise, delay, box or current; its turns are what binds. The answer is a
change a user can write (wider turns, a slower mission, or gains designed for the deployed loop),
each computed as a re-run computes it, and the re-run certifies.
"""

from __future__ import annotations

import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.mission_advice import SPEED_FACTORS, TURN_FACTORS, mission_advice
from auv_hinf.config.settings import config_from_dict, with_settings
from tests.helpers import DEPLOYED

#: Four BlueROV2 Heavy in a 3 m square, in the path frame, on a lawn-mower at 0.35 m/s, deployed.
SURVEY = {
    **DEPLOYED,
    "formation": {
        "n": 4,
        "frame": "path",
        "offsets": [[1.5, 1.5], [1.5, -1.5], [-1.5, 1.5], [-1.5, -1.5]],
        "min_separation": 1.0,
    },
    "reference": {"kind": "lawnmower", "speed": 0.35, "leg_length": 40.0, "spacing": 40.0, "turn_radius": 10.0},
    "simulation": {"horizon": 300.0},
    "implementation": {
        "sample_time": 0.1,
        "delay": 0.1,
        "noise": {"position": 0.05, "velocity": 0.004, "heading": 0.004, "yaw_rate": 0.002},
    },
}


def test_the_changes_are_tried_in_order_and_the_first_that_covers_is_the_answer():
    cfg = config_from_dict({**SURVEY, "design": {"robust": False}}, "survey")
    tried = []

    def bound(c, settings):
        tried.append({(s.table, s.key): s.value for s in settings})
        return 0.5 if ("reference", "speed") in tried[-1] else None

    out = mission_advice(design_point(cfg), bound)
    # the design change first (alone), then wider turns with it, then the slower mission with it
    assert tried[0] == {("design", "robust"): True, ("design", "synthesis"): "deployed"}
    turns = [t for t in tried if ("reference", "turn_radius") in t]
    assert [t[("reference", "turn_radius")] for t in turns] == [10.0 * f for f in TURN_FACTORS]
    assert all(t[("reference", "spacing")] == 4.0 * t[("reference", "turn_radius")] for t in turns)
    assert len(out) == 1 and out[0].what == "speed" and out[0].position_bound == 0.5
    assert {(s.table, s.key): s.value for s in out[0].settings}[("reference", "speed")] == 0.35 * SPEED_FACTORS[0]
    assert "[reference] speed = 0.175" in out[0].line()


@pytest.mark.slow
def test_nothing_covers_gives_no_answer():
    cfg = config_from_dict(SURVEY, "survey")
    assert mission_advice(design_point(cfg), lambda c, s: None) == ()


@pytest.mark.slow
def test_the_lawnmower_survey_is_refused_with_a_mission_change_that_certifies_when_rerun():
    cfg = config_from_dict(SURVEY, "survey")
    cert = certify(cfg)
    assert not cert.certified
    reason = next(r for r in cert.findings if r.part == "composed")
    assert reason.settings, reason.message
    assert {s.table for s in reason.settings} <= {"reference", "design"}
    # the JSON's advice lists the same answer as data, with the re-run's bound
    (entry,) = cert.to_dict()["composed"]["advice"]
    assert entry["settings"] == [s.to_dict() for s in reason.settings] and entry["scale"] is None
    assert entry["setting"] in ("design", "turns", "speed") and entry["position_bound"] > 0.0
    again = certify(with_settings(cfg, [(s.table, s.key, s.value) for s in reason.settings]))
    assert again.certified, again.reasons
    assert again.to_dict()["composed"]["covers"]


def test_a_refusal_lists_only_the_changes_that_were_tried():
    from auv_hinf.certificate.mission_advice import tried

    line = config_from_dict({**SURVEY, "reference": {"kind": "line", "speed": 0.4}, "formation": DEPLOYED["formation"]})
    assert "turns" not in tried(line) and "speed" in tried(line) and "gains designed" not in tried(line)
    survey = config_from_dict({**SURVEY, "design": {"robust": True, "synthesis": "lmi"}})
    assert tried(survey).startswith("gains designed for the deployed loop, turns up to 8 times wider")


@pytest.mark.slow
def test_a_circle_too_tight_for_the_yaw_rate_range_is_answered_in_its_own_keys_and_re_runs():
    """The paper's fleet on a 5 m circle with yaw rates limited to 0.01 rad/s, sampled at 10 Hz.

    The closed-loop refusal's setting is the circle's ``radius`` (a lawn-mower's key would not be
    read), the composed part answers with a change of the mission, and the re-run of that answer
    certifies."""
    data = {
        "envelope": {"r": [-0.01, 0.01]},
        "reference": {"kind": "circle", "radius": 5.0},
        "implementation": {"sample_time": 0.1},
    }
    cfg = config_from_dict(data, "tight circle")
    cert = certify(cfg)
    assert not cert.certified
    closed = next(r for r in cert.findings if r.part == "closed_loop")
    assert [(s.table, s.key) for s in closed.settings] == [("reference", "radius")]
    speed = cfg.reference.kwargs()["speed"]
    assert closed.settings[0].value >= speed / 0.01 * (1.0 - 1e-6)  # the yaw-rate limit's radius at least
    composed = next(r for r in cert.findings if r.part == "composed")
    assert composed.settings, composed.message
    again = certify(with_settings(cfg, [(s.table, s.key, s.value) for s in composed.settings]))
    assert again.certified, again.reasons
