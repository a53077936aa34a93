"""A small-gain refusal of the composed certificate names the couplings that close the loop.

Properties asserted, on the deployed BlueROV2 fleet with a declared box and current (refused at
the start's errors):

* the refusal gives the couplings, by their share of the loop's gain;
* every coupling the small-gain system can carry is named (a perturbation channel's entries,
  except the varying delay's staleness terms, which this fleet does not have);
* removing the entries of the coupling named first lowers the system's spectral radius, and by
  more than removing those of the one named last (the shares are Perron sensitivities).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.composed import composed_summary
from auv_hinf.composed import certificate as composed
from auv_hinf.config.settings import config_from_dict
from auv_hinf.robust.box import ParameterBox
from tests.helpers import DEPLOYED

#: The box and current of the refusal (at the start's errors, with the fleet's gains): masses
#: +-20 %, surge and sway drag +-40 %, 0.1 m/s.
BOX = (
    ("m11", (0.8, 1.2)),
    ("m22", (0.8, 1.2)),
    ("d11_lin", (0.6, 1.4)),
    ("d11_quad", (0.6, 1.4)),
    ("d22_quad", (0.6, 1.4)),
)
#: Perturbation channels whose entries are the varying delay's staleness (not named).
STALENESS = ("n_v", "h:n_e", "h:n_v")


@pytest.fixture(scope="module")
def refused():
    point = design_point(config_from_dict(DEPLOYED, "deployed"))
    problem = composed_summary(point, search=False).problem
    assert problem is not None
    plant = replace(problem.plant, box=ParameterBox.from_ranges(problem.plant.model, BOX), current=0.1)
    problem = replace(problem, plant=plant)
    cert = composed.certify_deployed(problem)
    assert not cert.covers
    op = composed.OperatingBox.of(
        problem.mission, plant.current, composed._widen(problem.initial, 1.0 + composed.BOX_ROOM)
    )
    rnd = composed.make_round(problem, op)
    assert not isinstance(rnd, str)
    _, m, ix, _ = composed._system_at(problem, rnd, problem.initial)
    return problem, cert, m, ix


def _radius(m: np.ndarray) -> float:
    return float(np.abs(np.linalg.eigvals(m)).max())


def test_the_refusal_names_what_closes_the_loop(refused):
    _, cert, m, _ = refused
    assert _radius(m) >= 1.0
    assert "what closes the loop, by share of the couplings:" in cert.reasons[0]
    shares = [f for _, f in cert.binding]
    assert shares == sorted(shares, reverse=True) and 0.0 < sum(shares) <= 1.0 + 1e-12
    for text, share in cert.binding:
        assert f"{text} ({100.0 * share:.0f} %)" in cert.reasons[0]
    digest = composed.summary(cert)["binding"]
    assert [b["coupling"] for b in digest] == [t for t, _ in cert.binding]


def test_every_coupling_of_the_system_is_named(refused):
    _, _, m, ix = refused
    for i, j in zip(*np.nonzero(m), strict=True):
        row, col = ix.names[i], ix.names[j]
        channel = row.split(":", 1)[1] if not row.startswith("h:") else row
        if channel not in ("q", "q_e", "n_e", "p_z", "h:q"):
            continue  # a loop's own gain, or the measurements' staleness
        assert composed._coupling(row, col) is not None, (row, col)


def test_removing_the_first_named_coupling_lowers_the_radius_most(refused):
    _, cert, m, ix = refused
    texts = [t for t, _ in cert.binding]

    def without(text: str) -> float:
        cut = m.copy()
        for i, j in zip(*np.nonzero(m), strict=True):
            if composed._coupling(ix.names[i], ix.names[j]) == text:
                cut[i, j] = 0.0
        return _radius(cut)

    first, last = without(texts[0]), without(texts[-1])
    assert first < _radius(m) and first < last


def test_a_refusal_by_growing_bounds_names_what_carries_the_radius_at_the_start(refused):
    """A tenth of the refused box and current is not refused at the start's errors (radius below 1) but by
    bounds that grow round after round; the refusal still names the couplings that carry the radius there,
    with the radius, so that it says what to change."""
    problem = refused[0]
    plant = replace(problem.plant, box=problem.plant.box.scaled(0.1), current=0.01)
    smaller = replace(problem, plant=plant)
    cert = composed.certify_deployed(smaller)
    assert not cert.covers and "fails even at the start" not in cert.reasons[0]
    op = composed.OperatingBox.of(
        smaller.mission, plant.current, composed._widen(smaller.initial, 1.0 + composed.BOX_ROOM)
    )
    rnd = composed.make_round(smaller, op)
    assert not isinstance(rnd, str)
    _, m, _, _ = composed._system_at(smaller, rnd, smaller.initial)
    radius = _radius(m)
    assert radius < 1.0 and f"the small-gain radius is {radius:.3g} at the start's errors" in cert.reasons[0]
    assert cert.binding and cert.binding == composed.binding(smaller, rnd, smaller.initial)
    assert "what carries it, by share of the couplings:" in cert.reasons[0]
    for text, share in cert.binding:
        assert f"{text} ({100.0 * share:.0f} %)" in cert.reasons[0]
