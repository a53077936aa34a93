"""Per-vehicle reference check: the right vehicle, turn and channel bind, and the smallest radius is tight."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_hinf.mission.fit import reference_fit
from auv_hinf.mission.paths import LawnmowerReference
from auv_hinf.models.envelope import Envelope

SPEED = 1.5  # m/s
ENVELOPE = Envelope(u=(0.0, 2.5), v=(-0.3, 0.3), r=(-0.3, 0.3))
#: Line abreast across the track (m, path frame): the vehicle 25 m to the right is the outer one in
#: left turns. Its surge s (1 + 25/R) <= 2.5 m/s needs R >= 25 s / (2.5 - s) = 37.5 m (closed form);
#: its inner-side surge s (1 - 25/R) >= 0 needs only R >= 25 m, the left vehicle's R >= 15 m.
LINE_ABREAST = np.array([[0.0, 0.0], [0.0, 10.0], [0.0, -25.0]])
CLOSED_FORM_RADIUS = 25.0 * SPEED / (ENVELOPE.u[1] - SPEED)
#: The bisection stops at REGION_RTOL of the curvature; the tube is exact up to TUBE_RTOL here (no
#: sideslip: d_x = 0), so the answer is within 1e-4 of the closed form, and so is the tightness step.
RADIUS_RTOL = 1e-4


def mower(radius: float) -> LawnmowerReference:
    return LawnmowerReference(speed=SPEED, leg_length=200.0, spacing=max(160.0, 4.0 * radius), turn_radius=radius)


def test_too_tight_turn_names_the_outer_vehicle_the_first_turn_and_a_tight_smallest_radius():
    fit = reference_fit(mower(30.0), LINE_ABREAST, "path", ENVELOPE)
    assert fit.inside == (True, True, False)
    b = fit.binding
    assert b is not None and (b.vehicle, b.channel, b.edge) == (2, "surge", "upper")
    assert b.margin == pytest.approx(ENVELOPE.u[1] - SPEED * (1 + 25.0 / 30.0), rel=1e-6)
    m = mower(30.0)
    assert 200.0 / SPEED < b.time < 200.0 / SPEED + m.t90  # inside the first (left) 90-degree turn
    assert fit.smallest_radius == pytest.approx(CLOSED_FORM_RADIUS, rel=RADIUS_RTOL)
    r = fit.smallest_radius
    assert reference_fit(mower(r * (1 + RADIUS_RTOL)), LINE_ABREAST, "path", ENVELOPE).ok
    assert not reference_fit(mower(r * (1 - RADIUS_RTOL)), LINE_ABREAST, "path", ENVELOPE).ok
    assert fit.largest_offset == pytest.approx(25.0 * 30.0 / CLOSED_FORM_RADIUS, rel=RADIUS_RTOL)
    assert "vehicle 3" in fit.reason() and "smallest turn radius that fits: 37.5" in fit.reason()


def test_sideslip_of_a_vehicle_ahead_binds_the_sway_channel():
    ahead = np.array([[12.0, 0.0], [-12.0, 0.0]])  # chi' d_x = s d_x / R <= 0.3 needs R >= 60 m
    fit = reference_fit(mower(50.0), ahead, "path", ENVELOPE)
    assert fit.binding is not None and fit.binding.channel == "sway"
    assert fit.smallest_radius == pytest.approx(12.0 * SPEED / ENVELOPE.v[1], rel=RADIUS_RTOL)


def test_inertial_frame_every_vehicle_moves_as_the_centre():
    fit = reference_fit(mower(30.0), LINE_ABREAST, "inertial", ENVELOPE)
    assert fit.ok and fit.inside == (True, True, True)
    assert fit.binding is None and fit.smallest_radius is None and math.isinf(fit.turn_radius) is False
    slow = Envelope(u=(0.0, 1.0), v=(-0.3, 0.3), r=(-0.3, 0.3))
    bad = reference_fit(mower(30.0), LINE_ABREAST, "inertial", slow)
    assert bad.inside == (False, False, False) and bad.largest_offset is None and bad.smallest_radius is None


def test_a_path_frame_turn_where_a_vehicle_would_stop_is_refused_by_name_not_by_an_error():
    """The paper triangle's sine (amplitude 30 m) turns tighter than its offsets in the path frame."""
    from auv_hinf.certificate.assembly import certify
    from auv_hinf.config.presets import preset_config
    from auv_hinf.config.settings import config_from_dict

    doc = preset_config("paper-triangle").to_toml_dict()
    doc.pop("simulation", None)
    doc["formation"]["frame"] = "path"
    cert = certify(config_from_dict(doc))
    assert not cert.certified
    why = " ".join(cert.reasons)
    assert "vehicle" in why and "smallest turn radius that fits" in why


def test_an_advised_radius_is_rounded_to_the_side_that_fits():
    """Regression: a smallest radius of 20.00015 m printed as "20 m", the declared radius that does not fit."""
    import math

    from auv_hinf.mission.fit import Binding, ReferenceFit

    fit = ReferenceFit(
        frame="path",
        inside=(True, False),
        margins=np.zeros((2, 1)),
        binding=Binding(vehicle=1, time=None, channel="surge", edge="lower", margin=-5e-13),
        turn_radius=20.0,
        smallest_radius=20.00015,
        largest_offset=20.3999,
    )
    words = fit.reason()
    radius = float(words.split("smallest turn radius that fits: ")[1].split(" m")[0])
    offset = float(words.split("largest offset that fits (shape scaled): ")[1].split(" m")[0])
    assert radius >= 20.00015 and radius == 20.01 and offset <= 20.3999 and offset == 20.39
    assert not math.isclose(radius, fit.turn_radius, rel_tol=1e-9)


@pytest.mark.parametrize("edge", ["upper", "lower"])
def test_a_mission_on_an_edge_is_told_it_reaches_it_and_one_past_it_by_how_much(edge):
    from auv_hinf.mission.fit import EDGE_TOUCH
    from auv_hinf.mission.paths import LineReference

    line = LineReference(speed=SPEED)
    on = Envelope(u=(0.5, SPEED) if edge == "upper" else (SPEED, 2.5), v=(-0.3, 0.3), r=(-0.3, 0.3))
    fit = reference_fit(line, LINE_ABREAST, "inertial", on)
    assert not fit.ok and fit.binding is not None and fit.binding.edge == edge
    assert 0.0 < -fit.binding.margin <= EDGE_TOUCH  # outside by the tube's rounding only
    assert f"reaches the envelope's {edge} surge edge" in fit.reason() and "widen [envelope] u" in fit.reason()
    past = 1e-3 if edge == "upper" else -1e-3  # m/s: a real overshoot is given as a number
    beyond = Envelope(u=(0.5, SPEED - past) if edge == "upper" else (SPEED - past, 2.5), v=on.v, r=on.r)
    text = reference_fit(line, LINE_ABREAST, "inertial", beyond).reason()
    assert f"leaves the envelope's {edge} surge edge by 0.001" in text and "reaches" not in text
