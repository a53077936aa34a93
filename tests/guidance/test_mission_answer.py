"""Answers to a refused guidance cascade that change the mission, or shrink the current and box together.

Properties asserted:

* the mission's changes come as ladders from mild to gentle, in the units a user writes (a
  lawn-mower's turn radius and spacing together, a sine's frequency so that its curvature falls
  by the same factors, no slower sine, whose turns would tighten), and both kinds at once;
* a value is printed as it must be written: exactly when four digits would change it;
* a fleet whose current and box each refuse it alone, on a mission its nominal plant certifies,
  is answered on that mission, with the two shrunk together, and re-running with the answer
  certifies it (the mission's own answer is followed in ``test_guidance.py``);
* a mission on which a slot stops is answered with wider turns on which none does, and re-running
  with them certifies;
* a declared start that binds (the vehicles tens of metres off their slots) is answered with the
  start on the slots, the declared box and current kept, and re-running from there certifies.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.mission_advice import SPEED_FACTORS, TURN_FACTORS, mission_changes
from auv_hinf.certificate.reason import Setting
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import ReferenceConfig, config_from_dict, with_settings
from tests.helpers import CELLS_LINE

#: Four torpedo vehicles (figures within 15 % of a REMUS 100, a weaker propeller and rudder) on a
#: line in a current up to 0.3 m/s, masses and drag +-15 %: neither the current nor the box alone
#: certifies, the nominal plant in still water does.
TOGETHER = {
    "vehicle": {
        "m11": 34.55,
        "m22": 58.06,
        "m33": 9.58,
        "d11_lin": 0.0,
        "d11_quad": 1.78,
        "d22_lin": 40.0,
        "d22_quad": 1113.5,
        "d33_lin": 3.3,
        "d33_quad": 103.4,
    },
    "formation": {"n": 4, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, -15.0], [-15.0, 0.0]]},
    "reference": {"kind": "line", "speed": 2.0, "heading": 0.5},
    "actuators": {"kind": "underactuated", "tau_x": 40.0, "rudder_max": 0.15, "rudder_sway": 9.64, "rudder_yaw": -6.15},
    "guidance": {"kind": "ilos"},
    "uncertainty": {k: [0.85, 1.15] for k in ("m11", "m22", "m33", "d11_quad", "d22_quad", "d33_quad")},
    "disturbance": {"current_speed": 0.3},
}


def _refused(tables: dict, name: str) -> tuple[object, dict, dict]:
    """The configuration of ``tables``, its refused ``certify --json`` and the guidance part's reason."""
    cfg = config_from_dict(tables, name)
    data = certify(cfg).to_dict()
    assert data["guidance"]["certified"] is False
    return cfg, data, data["parts"]["guidance"]["reasons"][0]


def _keys(why: dict) -> set[tuple[str, str]]:
    """The ``(table, key)`` of every setting a reason writes."""
    return {(x["table"], x["key"]) for x in why["settings"]}


def _certifies_when_rerun(cfg: object, why: dict) -> None:
    """Re-running ``cfg`` with the reason's settings certifies the cascade and the fleet."""
    again = _rerun(cfg, why)
    assert again["guidance"]["certified"] is True and again["certified"] is True


def _rerun(cfg: object, why: dict) -> dict:
    """``certify --json`` of ``cfg`` rewritten with the reason's settings."""
    return certify(with_settings(cfg, [(x["table"], x["key"], x["value"]) for x in why["settings"]])).to_dict()


def test_the_mission_changes_are_ladders_in_the_users_units():
    cfg = preset_config("remus-survey-ilos")
    ref = cfg.reference.kwargs()
    changes = mission_changes(cfg)
    kinds = [what for what, _ in changes]
    assert kinds == ["turns"] * len(TURN_FACTORS) + ["speed"] * len(SPEED_FACTORS) + ["both"] * len(SPEED_FACTORS)
    for f, (_, settings) in zip(TURN_FACTORS, changes, strict=False):
        values = {s.key: s.value for s in settings}
        assert values == {"turn_radius": ref["turn_radius"] * f, "spacing": ref["spacing"] * f}
    widest = changes[len(TURN_FACTORS) - 1][1]
    for f, (_, settings) in zip(SPEED_FACTORS, changes[-len(SPEED_FACTORS) :], strict=True):
        assert settings == (*widest, Setting("reference", "speed", ref["speed"] * f))
    # a sine's curvature is A omega^2 / speed: its turns widen by f with omega / sqrt(f), and it is never slowed
    sine = ReferenceConfig("sine", (("speed", 1.5), ("amplitude", 30.0), ("omega", 0.05)))
    changes = mission_changes(replace(cfg, reference=sine))
    assert [what for what, _ in changes] == ["turns"] * len(TURN_FACTORS)
    for f, (_, (s,)) in zip(TURN_FACTORS, changes, strict=True):
        # written as a user writes it: 4 significant digits, rounded down to the gentler side (within 1e-3)
        assert s.key == "omega" and s.value == float(f"{s.value:.4g}")
        curvature = 30.0 * s.value**2 / 1.5
        assert 30.0 * 0.05**2 / 1.5 / f * (1 - 2e-3) <= curvature <= 30.0 * 0.05**2 / 1.5 / f
    line = ReferenceConfig("line", (("speed", 1.5), ("heading", 0.0)))
    assert [w for w, _ in mission_changes(replace(cfg, reference=line))] == ["speed"] * len(SPEED_FACTORS)


def test_a_value_is_printed_exactly_when_four_digits_would_change_it():
    assert Setting("disturbance", "current_speed", 0.0281).toml() == "[disturbance] current_speed = 0.0281"
    assert Setting("reference", "turn_radius", 480.0).toml() == "[reference] turn_radius = 480"
    text = Setting("reference", "spacing", 496.2696 * 8).toml()
    assert float(text.split("= ")[1]) == 496.2696 * 8
    assert Setting("design", "synthesis", "deployed").toml() == '[design] synthesis = "deployed"'
    assert Setting("design", "robust", True).toml() == "[design] robust = true"
    assert Setting("uncertainty", "m11", [0.9696, 1.0304]).toml() == "[uncertainty] m11 = [0.9696, 1.0304]"


@pytest.mark.slow
def test_a_current_and_box_that_bind_together_are_shrunk_together_on_the_declared_mission():
    cfg, data, why = _refused(TOGETHER, "together")
    found = data["guidance"]["largest_certifiable"]
    assert found["current_speed"] in (None, 0.0) and found["box_scale"] in (None, 0.0)
    assert 0.0 < found["together"] < 1.0
    written = {(s["table"], s["key"]): s["value"] for s in why["settings"]}
    assert {t for t, _ in written} == {"disturbance", "uncertainty"}  # the mission is kept
    assert written[("disturbance", "current_speed")] <= found["together"] * 0.3
    for (table, key), value in written.items():
        if table == "uncertainty":
            assert 0.85 < value[0] <= 1.0 <= value[1] < 1.15, (key, value)
    assert "on the declared mission" in why["message"]
    again = _rerun(cfg, why)
    assert again["guidance"]["certified"] is True


#: Three REMUS 100 in the path frame, the outer two 18 m across the track, on 15 m turns: the inner
#: slot of each turn stops, and no gains, current or box can certify that.
SLOT_STOPS = {
    "vehicle": {"preset": "remus100"},
    "formation": {"n": 3, "frame": "path", "offsets": [[0.0, 0.0], [0.0, 18.0], [0.0, -18.0]]},
    "reference": {"kind": "lawnmower", "speed": 1.0, "leg_length": 300.0, "spacing": 60.0, "turn_radius": 15.0},
    "actuators": {"preset": "remus100"},
    "guidance": {"kind": "ilos"},
}


@pytest.mark.slow
def test_a_mission_on_which_a_slot_stops_is_answered_with_one_on_which_none_does():
    cfg, _, why = _refused(SLOT_STOPS, "stops")
    assert "a slot stops" in why["message"]
    assert why["kind"] == "not_covered"  # a mission to change, not an unsupported configuration
    written = {(s["table"], s["key"]): s["value"] for s in why["settings"]}
    assert {t for t, _ in written} == {"reference"}
    assert written[("reference", "turn_radius")] > 18.0  # the outer slots no longer reach the turn's centre
    again = _rerun(cfg, why)
    assert again["guidance"]["certified"] is True


#: Four REMUS-like vehicles on a straight line in a 0.05 m/s current, started tens of metres off
#: their slots: from their slots they are certified, from this start not.
FAR_START = {
    "vehicle": {
        "m11": 30.2,
        "m22": 68.4,
        "m33": 8.0,
        "d11_lin": 0.0,
        "d11_quad": 1.55,
        "d22_lin": 44.0,
        "d22_quad": 1290.0,
        "d33_lin": 2.9,
        "d33_quad": 97.0,
    },
    "formation": {"n": 4, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, -15.0], [0.0, 30.0]]},
    "reference": {"kind": "line", "speed": 1.5},
    "actuators": {"kind": "underactuated", "tau_x": 80.0, "rudder_max": 0.24, "rudder_sway": 10.2, "rudder_yaw": -5.8},
    "guidance": {"kind": "ilos"},
    "uncertainty": {"m11": [0.97, 1.03], "m22": [0.97, 1.03], "d11_quad": [0.8, 1.2], "d22_lin": [0.8, 1.2]},
    "disturbance": {"current_speed": 0.05},
    "simulation": {
        "horizon": 200.0,
        "initial": [
            [-30.0, -40.0, 0.9, 0.8, 0.0, 0.0],
            [25.0, 45.0, -0.9, 2.0, 0.0, 0.0],
            [-20.0, -60.0, 0.6, 1.0, 0.0, 0.0],
            [30.0, 60.0, -0.7, 1.5, 0.0, 0.0],
        ],
    },
}


@pytest.mark.slow
def test_a_declared_start_that_binds_is_answered_with_the_slots_and_the_world_kept():
    cfg, data, why = _refused(FAR_START, "far")
    assert "the declared start binds" in why["message"]
    assert why["settings"] == [{"table": "simulation", "key": "initial", "value": None, "unit": ""}]
    assert "remove [simulation] initial" in why["message"]
    again = _rerun(cfg, why)
    assert again["guidance"]["certified"] is True
    bound = data["guidance"]["largest_certifiable"]["start_on_slots"]["position_bound"]
    assert again["guidance"]["error_bounds"]["cross_track"] <= bound


@pytest.mark.slow
def test_a_declared_start_of_a_fleet_only_cells_certify_is_answered_with_the_slots():
    # the start from the slots was probed on the whole box at once, which refuses this fleet: the answer was
    # a current of 0.0203 m/s, and 0.3 m off the slots "nothing certifies it, even from the slots"
    cfg, data, why = _refused(CELLS_LINE, "cells line")
    assert "the declared start binds" in why["message"] and _keys(why) == {("simulation", "initial")}
    again = _rerun(cfg, why)
    assert again["certified"] is True and again["guidance"]["cells"] > 1
    bound = data["guidance"]["largest_certifiable"]["start_on_slots"]["position_bound"]
    assert again["guidance"]["error_bounds"]["cross_track"] <= bound


@pytest.mark.slow
def test_plain_los_on_a_fleet_only_cells_certify_is_answered_with_ilos_in_the_json_too():
    # the switch to ILOS was confirmed on the whole box at once: the text said "use kind = ilos" while
    # guidance.largest_certifiable.supported was null
    tables = {k: v for k, v in CELLS_LINE.items() if k != "simulation"}
    cfg, data, why = _refused({**tables, "guidance": {**tables["guidance"], "kind": "los"}}, "los")
    supported = data["guidance"]["largest_certifiable"]["supported"]
    assert supported is not None and supported["settings"] == why["settings"]
    assert _keys(why) == {("guidance", "kind")} and why["settings"][0]["value"] == "ilos"
    again = _rerun(cfg, why)
    assert (
        again["certified"] is True and again["guidance"]["error_bounds"]["cross_track"] <= supported["position_bound"]
    )
    # declared off the slots too: both answers in one (the switched fleet's answer was dropped as a run setting)
    start = {"initial": [[0.0, y + 0.3, 0.3, 1.5, 0.0, 0.0] for y in (-22.5, -7.5, 7.5, 22.5)]}
    cfg, data, why = _refused({**tables, "guidance": {**tables["guidance"], "kind": "los"}, "simulation": start}, "l")
    assert _keys(why) == {("guidance", "kind"), ("simulation", "initial")}
    assert data["guidance"]["largest_certifiable"]["supported"]["settings"] == why["settings"]
    assert _rerun(cfg, why)["certified"] is True


#: Three REMUS 100 on a 3 m polygon in the path frame, on a lawn-mower with 60 m turns: refused;
#: the mission answer's distance to the slots must also keep the vehicles 2 m apart (the slots are
#: 5.2 m apart, so every vehicle must stay within 1.6 m of its slot).
CLOSE_FORMATION = {
    "vehicle": {"preset": "remus100"},
    "formation": {"n": 3, "frame": "path", "min_separation": 2.0, "polygon_radius": 3.0},
    "envelope": {"u": [0.5, 2.5], "v": [-0.3, 0.3], "r": [-0.3, 0.3]},
    "reference": {"kind": "lawnmower", "speed": 1.5, "leg_length": 400.0, "spacing": 240.0, "turn_radius": 60.0},
    "simulation": {"horizon": 300.0, "start": "shaped", "current": [0.0089, -0.0159]},
    "disturbance": {"current_speed": 0.1},
    "actuators": {"kind": "underactuated", "tau_x": 10.0, "rudder_max": 0.78, "rudder_sway": 9.64, "rudder_yaw": -6.15},
    "guidance": {"kind": "ilos", "lookahead": 16.0, "integral_gain": 0.3, "heading_bandwidth": 2.4},
}


@pytest.mark.slow
def test_an_answer_keeps_the_required_separation_and_certifies_when_rerun():
    """An answer that certifies the cascade may still leave the vehicles too close: the first mission
    answer (120 m turns, every vehicle within 1.98 m of its slot) left them 1.23 m apart, and the
    largest current that certified the cascade (0.0318 m/s, within 1.94 m) 1.32 m apart. The answer
    given is one whose bound keeps them 2 m apart."""
    cert = certify(config_from_dict(CLOSE_FORMATION, "close"))
    assert not cert.certified
    (why,) = cert.verdict("guidance").reasons
    assert why.settings and "(re-run with it)" in why.message
    again = certify(with_settings(cert.config, [(x.table, x.key, x.value) for x in why.settings]))
    assert again.certified, again.reasons
    sep = again.to_dict()["formation"]
    assert sep["min_separation_certified"] >= 2.0


@pytest.mark.slow
def test_the_default_start_written_out_is_refused_in_a_current_and_the_refusal_says_why():
    """A review wrote out the very states every vehicle starts from (on its slot, crabbed into the current)
    and was refused: a declared start is judged in every current of the disc. The refusal says so, and its
    answer (the default start) certifies."""
    from auv_hinf.certificate.run_plan import guidance_run
    from auv_hinf.config.settings import UncertaintyConfig

    base = replace(preset_config("remus-transit-ilos"), uncertainty=UncertaintyConfig(()))
    start = guidance_run(base, horizon=0.2).states[0]
    cfg = replace(base, simulation=replace(base.simulation, initial=tuple(map(tuple, start.tolist()))))
    data = certify(cfg).to_dict()
    (why,) = data["parts"]["guidance"]["reasons"]
    assert not data["certified"] and "judged in every current up to [disturbance] current_speed" in why["message"]
    assert certify(base).certified


#: Three REMUS 100 line abreast on a lawn-mower with 150 m turns, masses +-3 %, damping +-20 %, in a
#: current up to 0.1 m/s: only a current under a tenth of the declared certifies these turns.
WEAK_CURRENT = {
    "vehicle": {"preset": "remus100"},
    "formation": {"n": 3, "frame": "inertial", "offsets": [[0.0, 15.0], [0.0, 0.0], [0.0, -15.0]]},
    "envelope": {"u": [0.5, 2.5], "v": [-0.3, 0.3], "r": [-0.3, 0.3]},
    "reference": {"kind": "lawnmower", "speed": 1.5, "leg_length": 400.0, "spacing": 600.0, "turn_radius": 150.0},
    "actuators": {"preset": "remus100"},
    "guidance": {"kind": "ilos", "lookahead": 16.0, "heading_bandwidth": 2.4},
    "uncertainty": {
        **{k: [0.97, 1.03] for k in ("m11", "m22", "m33")},
        **{k: [0.8, 1.2] for k in ("d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")},
    },
    "disturbance": {"current_speed": 0.1},
}


@pytest.mark.slow
def test_a_turning_fleet_that_only_a_weak_current_certifies_is_told_the_turns_that_keep_the_declared_current():
    from auv_hinf.certificate.parts.guidance import WEAK_WORLD

    cfg, _, why = _refused(WEAK_CURRENT, "weak-current")
    assert _keys(why) == {("reference", "turn_radius"), ("reference", "spacing")}, why
    # the current alone would have to shrink below WEAK_WORLD of the declared: it is named as the alternative
    assert "on the declared mission only a smaller current certifies" in why["message"]
    named = float(why["message"].split("current_speed = ", 1)[1].split(" ")[0])
    assert 0.0 < named < WEAK_WORLD * 0.1
    # re-run with the answer (the declared current and box untouched): certified
    _certifies_when_rerun(cfg, why)


#: Four torpedo vehicles (a REMUS 100 within 3 %) on a line at 1.5 m/s in a current up to 0.15 m/s,
#: masses +-3 %, damping +-20 %, navigated at 10 Hz with a 0.1 s delay and a 0.5 m position noise:
#: neither the navigation alone, nor the current and box together, nor a slower mission certifies.
EVERYTHING = {
    "vehicle": {
        "m11": 34.551,
        "m22": 59.382,
        "m33": 9.3296,
        "d11_lin": 0.0,
        "d11_quad": 1.782,
        "d22_lin": 38.61,
        "d22_quad": 1152.8,
        "d33_lin": 3.3,
        "d33_quad": 106.22,
    },
    "formation": {"n": 4, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, -15.0], [0.0, 30.0]]},
    "envelope": {"u": [0.5, 2.5], "v": [-0.3, 0.3], "r": [-0.3, 0.3]},
    "reference": {"kind": "line", "speed": 1.5, "heading": 0.0},
    "actuators": {"preset": "remus100"},
    "guidance": {"kind": "ilos", "lookahead": 16.0, "heading_bandwidth": 2.4},
    "uncertainty": WEAK_CURRENT["uncertainty"],
    "disturbance": {"current_speed": 0.15},
    "implementation": {
        "sample_time": 0.1,
        "delay": 0.1,
        "noise": {"position": 0.5, "velocity": 0.02, "heading": 0.01, "yaw_rate": 0.005},
    },
}


@pytest.mark.slow
def test_a_fleet_that_needs_its_navigation_and_its_world_shrunk_together_is_told_both():
    """Regression: each answer shrank one kind of effect, and a fleet that needed two got no values at all."""
    cfg, data, why = _refused(EVERYTHING, "everything")
    scale = data["guidance"]["largest_certifiable"]["everything"]
    assert scale is not None and 0.0 < scale < 1.0
    keys = _keys(why)
    assert {("implementation", "delay"), ("implementation.noise", "position"), ("disturbance", "current_speed")} <= keys
    assert any(t == "uncertainty" for t, _ in keys) and "every declared effect together" in why["message"]
    _certifies_when_rerun(cfg, why)


#: A slow REMUS mission (0.3 m/s) in a current up to 0.5 m/s, its envelope's surge range from 0.5 m/s:
#: the current hides that the mission itself runs below the envelope until a smaller current is tried.
SLOW_IN_CURRENT = {
    **WEAK_CURRENT,
    "reference": {"kind": "line", "speed": 0.3, "heading": 0.0},
    "disturbance": {"current_speed": 0.5},
}


@pytest.mark.slow
def test_a_smaller_current_whose_motion_leaves_the_envelope_is_answered_with_the_envelope_it_needs():
    """Regression: "a smaller current certifies" was refused on the envelope when re-run."""
    cfg, data, why = _refused(SLOW_IN_CURRENT, "slow")
    assert _keys(why) == {("disturbance", "current_speed"), ("envelope", "u")}, why
    assert data["guidance"]["largest_certifiable"]["envelope"] is not None
    _certifies_when_rerun(cfg, why)


@pytest.mark.slow
def test_a_varying_delay_whose_fixed_version_is_refused_too_is_answered_with_both_changes():
    """Regression: "set varying_delay = false" was printed without values, and its re-run got none either."""
    varying = {**EVERYTHING, "implementation": {**EVERYTHING["implementation"], "varying_delay": True}}
    cfg, data, why = _refused(varying, "varying")
    assert ("implementation", "varying_delay") in _keys(why) and ("disturbance", "current_speed") in _keys(why)
    assert data["guidance"]["largest_certifiable"]["supported"]["position_bound"] > 0.0
    _certifies_when_rerun(cfg, why)


def test_a_delay_varying_within_zero_is_the_fixed_zero_delay():
    """A varying delay of at most 0 s is no delay: certified as the fixed one, not refused as unsupported."""
    base = preset_config("remus-transit-ilos")
    timing = [("implementation", "sample_time", 0.1), ("implementation", "delay", 0.0)]
    fixed, varying = (with_settings(base, [*timing, ("implementation", "varying_delay", v)]) for v in (False, True))
    a, b = certify(fixed).to_dict(), certify(varying).to_dict()
    assert a["guidance"]["certified"] is True and b["guidance"]["certified"] is True
    assert a["guidance"]["error_bounds"] == b["guidance"]["error_bounds"]


@pytest.mark.slow
def test_a_box_that_certifies_only_in_still_water_is_not_told_no_smaller_current_certifies():
    # a REMUS-like vehicle with a wide box in a 0.4 m/s current: with the whole box only still water
    # certifies, which the JSON gives as a largest current of 0; the words must say the same
    tables = {
        "vehicle": {"m11": 33.0, "m22": 70.0, "m33": 9.0, "d11_lin": 2.0, "d11_quad": 1.8}
        | {"d22_lin": 45.0, "d22_quad": 1300.0, "d33_lin": 3.5, "d33_quad": 90.0},
        "formation": {"n": 3, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, -15.0]]},
        "reference": {"kind": "line", "speed": 1.5},
        "actuators": {"preset": "remus100"},
        "guidance": {"kind": "ilos", "heading_bandwidth": 2.4, "lookahead": 16.0},
        "uncertainty": {k: [0.85, 1.15] for k in ("m11", "m22", "m33")}
        | {k: [0.7, 1.3] for k in ("d11_quad", "d22_lin", "d33_quad")},
        "disturbance": {"current_speed": 0.4},
    }
    data = certify(config_from_dict(tables, "wide box")).to_dict()
    largest = data["guidance"]["largest_certifiable"]
    (why,) = data["parts"]["guidance"]["reasons"]
    assert largest["current_speed"] == 0.0 and largest["together"] > 0.0
    assert "only still water certifies" in why["message"] and "no smaller current" not in why["message"]


@pytest.mark.slow
def test_a_declared_start_that_binds_with_the_world_is_answered_with_the_slots_and_the_world_together():
    """``remus-line`` steered by ILOS, as its refusal advises, from its declared start off the slots: no
    smaller current or box certifies from there, nor the slots alone. The answer was "no smaller current,
    smaller box or faster heading loop certifies it, from the declared start", every value null; it is now
    the start on the slots with what certifies from there, confirmed together, and it certifies when rerun."""
    tables = preset_config("remus-line").to_toml_dict()
    assert tables["simulation"].get("initial") is not None
    cfg, data, why = _refused({**tables, "guidance": {"kind": "ilos"}}, "remus-line ilos")
    assert "nothing certifies from the declared start" in why["message"]
    keys = _keys(why)
    assert ("simulation", "initial") in keys and ("disturbance", "current_speed") in keys
    supported = data["guidance"]["largest_certifiable"]["supported"]
    assert supported is not None and supported["settings"] == why["settings"]
    again = _rerun(cfg, why)
    assert again["certified"] is True
    assert again["guidance"]["error_bounds"]["cross_track"] <= supported["position_bound"]
