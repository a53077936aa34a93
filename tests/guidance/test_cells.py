"""Cells of the box for the ILOS cascade's certificate: they cover the box, and what they certify holds.

Properties asserted:

* the halves of a box cover it exactly along each mass and leave the other coefficients alone;
  each half's nominal plant is its centre, and the model-against-plant spreads are still taken
  against the controller's model;
* a nominal loop placed at the model reproduces the whole box's certificate to the last bit;
* a box its cells do not certify either is refused with the corner of its masses (or the cell)
  that is refused;
* a box of masses +-10 % that the whole box's certificate refuses is certified by its cells, and
  plants at the box's vertices (the smallest Munk coefficient first), in currents at the bound in
  several directions, keep every state of the simulated cascade inside the certified box and
  every command inside its certified bound: from the default start (in trim, crabbed into the
  current: the surge drag's spread moves the along-track error) and from a start on the slots
  heading along the track (not crabbed: the cross-track loop moves).
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auv_hinf.cascade.certificate import (
    CELL_PARAMETERS,
    STATES,
    cascade_states,
    certify_cascade,
    current_cells_apply,
    current_halves,
    halves,
)
from auv_hinf.certificate.design_point import design_point, raw_fleet
from auv_hinf.certificate.parts.guidance import cascade_problem, guidance_summary
from auv_hinf.config.settings import config_from_dict
from auv_hinf.guidance.law import SlotMotion
from auv_hinf.guidance.simulation import simulate_guidance, slot_motion
from auv_hinf.robust.box import PARAMETERS, ParameterBox
from tests.helpers import CELLS_LINE

#: Three REMUS 100 on a transit with every mass +-10 % and the drag uncertain: the whole box is
#: refused, its cells certify.
MASSES = {
    "vehicle": {"preset": "remus100"},
    "formation": {"n": 3, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, -15.0]]},
    "reference": {"kind": "line", "speed": 1.5},
    "actuators": {"preset": "remus100"},
    "guidance": {"kind": "ilos", "heading_bandwidth": 2.4, "lookahead": 16.0},
    "uncertainty": {
        "m11": [0.9, 1.1],
        "m22": [0.9, 1.1],
        "m33": [0.9, 1.1],
        "d11_quad": [0.9, 1.1],
        "d22_quad": [0.8, 1.2],
    },
    "disturbance": {"current_speed": 0.1},
    "simulation": {"horizon": 150.0, "current": [0.0, 0.1]},
}


@pytest.fixture(scope="module")
def masses():
    cfg = config_from_dict(MASSES, "masses")
    return cfg, cascade_problem(cfg, design_point(cfg))


def test_halves_cover_the_box_and_are_centred_on_their_own_nominal_plant(masses):
    _, problem = masses
    plant = problem.plant
    cells = halves(problem)
    assert len(cells) == 2 ** len(CELL_PARAMETERS)
    for name in PARAMETERS:
        parent = plant.interval(name)
        pieces = sorted({c.plant.interval(name) for c in cells})
        if name in CELL_PARAMETERS:
            assert len(pieces) == 2
            assert pieces[0][0] == pytest.approx(parent[0], rel=1e-15)
            assert pieces[1][1] == pytest.approx(parent[1], rel=1e-15)
            assert pieces[0][1] == pytest.approx(pieces[1][0], rel=1e-15)  # no gap between the halves
        else:
            assert pieces == [pytest.approx(parent, rel=1e-15)]
    for cell in cells:
        centre = cell.nominal
        assert centre is not None
        for name in PARAMETERS:
            lo, hi = cell.plant.interval(name)
            value = getattr(centre, name)
            assert lo * (1 - 1e-15) <= value <= hi * (1 + 1e-15)
            # the law's mismatch is still against the controller's model, not the cell's centre
            hat = getattr(plant.model, name)
            assert cell.plant.spread(name) == pytest.approx(max(hat - lo, hi - hat), rel=1e-15, abs=1e-12)
        assert cell.plant.model == plant.model


@pytest.mark.slow
def test_a_nominal_loop_at_the_model_reproduces_the_whole_box(masses):
    _, problem = masses
    problem = replace(problem, plant=replace(problem.plant, box=problem.plant.box.scaled(0.3)))
    whole = certify_cascade(problem, cells=False)
    at_model = certify_cascade(replace(problem, nominal=problem.plant.model), cells=False)
    assert whole.holds and at_model.holds
    assert np.array_equal(whole.errors, at_model.errors)
    assert whole.actuation == at_model.actuation


#: The second fleet: the same box in a 0.02 m/s current, every vehicle started on its slot heading
#: along the track (not into the current), so that the cross-track loop has a transient.
ALONG_THE_TRACK = {
    **MASSES,
    "disturbance": {"current_speed": 0.02},
    "simulation": {
        "horizon": 150.0,
        "current": [0.0, 0.02],
        "initial": [[0.0, 0.0, 0.0, 1.5, 0.0, 0.0], [0.0, 15.0, 0.0, 1.5, 0.0, 0.0], [0.0, -15.0, 0.0, 1.5, 0.0, 0.0]],
    },
}


@pytest.mark.slow
@pytest.mark.parametrize(
    ("tables", "moved"), [(MASSES, "along_track"), (ALONG_THE_TRACK, "cross_track")], ids=["in-trim", "along-track"]
)
def test_a_box_refused_whole_is_certified_by_cells_and_simulated_vertices_stay_inside(tables, moved):
    cfg = config_from_dict(tables, "cells")
    problem, cert = _certified_by_cells(cfg)
    assert cert.cells > 1
    box = cert.errors[:7]
    lo, hi = np.asarray(problem.plant.box.lo), np.asarray(problem.plant.box.hi)
    runs = []
    # vertices (1: the upper end) of m11, m22, m33, d11_quad, d22_quad: the smallest Munk coefficient
    # (m11 high, m22 low) at both yaw inertias, its opposite, and two more; the surge drag at either
    # end drives the along-track error
    vertices = [(1, 0, 0, 0, 0), (1, 0, 1, 1, 1), (0, 1, 0, 0, 1), (1, 1, 0, 1, 0), (0, 0, 1, 0, 0)]
    for m11, m22, m33, d11, d22 in vertices:
        m = np.ones(9)
        for name, side in zip(("m11", "m22", "m33", "d11_quad", "d22_quad"), (m11, m22, m33, d11, d22), strict=True):
            k = PARAMETERS.index(name)
            m[k] = hi[k] if side else lo[k]
        runs.append(m)
    currents = []
    for i in range(len(runs)):
        angle = 2.0 * np.pi * i / len(runs) + 0.3
        currents.append(problem.plant.current * np.array([np.cos(angle), np.sin(angle)]))
    worst, peaks = _worst_run(cfg, problem, runs, currents)
    for name, w, b in zip(STATES, worst, box, strict=True):
        assert w <= b, f"{name}: simulated {w:.4g} above the certified {b:.4g}"
    assert peaks[0] <= cert.actuation.thrust and peaks[1] <= cert.actuation.rudder
    # not vacuous: the state the start or the drag's spread moves reaches a fifth of its bound
    assert worst[STATES.index(moved)] >= 0.2 * box[STATES.index(moved)], (moved, worst, box)


def _certified_by_cells(cfg):
    """``cfg``'s cascade problem and its certificate, which the whole box and current do not give and cells do."""
    problem = cascade_problem(cfg, design_point(cfg))
    assert not certify_cascade(problem, cells=False).holds
    summary = guidance_summary(cfg)
    assert summary.holds, summary.reason
    return problem, summary.certificate


def _worst_run(cfg, problem, multipliers, currents) -> tuple[np.ndarray, np.ndarray]:
    """The largest ``|state|`` of the certificate's seven states over the simulated cascades of every plant
    (``multipliers`` of the model's coefficients) in its current, and the largest thrust and rudder commanded."""
    worst = np.zeros(7)
    peaks = np.zeros(2)
    slots_fleet = raw_fleet(cfg)
    initial = None if cfg.simulation.initial is None else np.asarray(cfg.simulation.initial)
    for m, current in zip(multipliers, currents, strict=True):
        plant = cfg.vehicle.__class__(**{n: getattr(cfg.vehicle, n) * m[k] for k, n in enumerate(PARAMETERS)})
        run = simulate_guidance(
            cfg.guidance,
            plant,
            cfg.vehicle,
            cfg.actuators,
            slots_fleet,
            cfg.simulation.horizon,
            tuple(current),
            initial=initial,
        )
        slots = slot_motion(slots_fleet, run.t)
        for k in range(run.t.size):
            slot = SlotMotion(p=slots.p[k], v=slots.v[k], a=slots.a[k])
            states = cascade_states(problem, run.states[k], run.integral[k], slot, current)
            worst = np.maximum(worst, np.abs(states).max(axis=0))
        peaks = np.maximum(peaks, [np.abs(run.thrust_cmd).max(), np.abs(run.rudder_cmd).max()])
    return worst, peaks


@settings(max_examples=200, deadline=None)
@given(
    speed=st.floats(0.0, 0.5),
    angle=st.floats(-np.pi, np.pi),
    bound=st.floats(1e-3, 0.5),
    depth=st.integers(1, 4),
)
def test_cells_of_the_along_track_current_cover_every_current_and_bound_its_cross_component(
    masses, speed, angle, bound, depth
):
    _, problem = masses
    problem = replace(problem, plant=replace(problem.plant, current=bound))
    c = min(speed, bound) * np.array([np.cos(angle), np.sin(angle)])  # along and across a track heading 0
    cells = [problem]
    for _ in range(depth):
        cells = [half for cell in cells for half in current_halves(cell)]
    assert cells[0].along[0] == -bound and cells[-1].along[1] == bound
    assert all(a.along[1] == b.along[0] for a, b in itertools.pairwise(cells))  # no gap, no overlap
    holding = [cell for cell in cells if cell.along[0] <= c[0] <= cell.along[1]]
    assert holding  # every current lies in a cell, which bounds its cross-track component
    for cell in holding:
        assert abs(c[1]) <= cell.across * (1 + 1e-12) + 1e-15
        lo, hi = cell.along
        assert cell.nominal_speed == pytest.approx(problem.reference_speed - 0.5 * (lo + hi), rel=1e-15)


#: Three REMUS 100 on a straight transit in a 0.2 m/s current (the ``remus-transit-ilos`` box and
#: gains): the whole range of currents is refused, cells of the current's along-track component certify.
CURRENT = {
    "vehicle": {"preset": "remus100"},
    "formation": {"n": 3, "frame": "inertial", "offsets": [[0.0, 15.0], [0.0, 0.0], [0.0, -15.0]]},
    "reference": {"kind": "line", "speed": 1.5, "heading": 0.7},
    "actuators": {"preset": "remus100"},
    "guidance": {"kind": "ilos", "heading_bandwidth": 2.4, "lookahead": 16.0},
    "uncertainty": {
        **{k: [0.97, 1.03] for k in ("m11", "m22", "m33")},
        **{k: [0.8, 1.2] for k in ("d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")},
    },
    "disturbance": {"current_speed": 0.2},
    "simulation": {"horizon": 120.0},
}


@pytest.mark.slow
def test_a_current_refused_whole_is_certified_by_cells_of_its_along_track_part_and_runs_stay_inside():
    cfg = config_from_dict(CURRENT, "current")
    problem, cert = _certified_by_cells(cfg)
    assert current_cells_apply(problem)
    assert cert.current_cells > 1
    box = cert.errors[:7]
    lo, hi = np.asarray(problem.plant.box.lo), np.asarray(problem.plant.box.hi)
    # plants: the smallest Munk coefficient (m11 high, m22 low) with the drag low, its opposite with the
    # drag high; currents at the bound: head, tail, across from both sides and four diagonals (the track
    # heads 0.7 rad)
    k11 = PARAMETERS.index("m11")
    weak, strong = lo.copy(), hi.copy()
    weak[k11], strong[k11] = hi[k11], lo[k11]
    angles = 0.7 + np.pi * np.arange(8) / 4.0
    currents = [problem.plant.current * np.array([np.cos(a), np.sin(a)]) for a in angles]
    plants = [weak if k % 2 == 0 else strong for k in range(len(currents))]
    worst, peaks = _worst_run(cfg, problem, plants, currents)
    for name, w, b in zip(STATES, worst, box, strict=True):
        assert w <= b, f"{name}: simulated {w:.4g} above the certified {b:.4g}"
    assert peaks[0] <= cert.actuation.thrust and peaks[1] <= cert.actuation.rudder
    # not vacuous: the along-track error, driven by the current's drag, reaches a fifth of its bound
    assert worst[STATES.index("along_track")] >= 0.2 * box[STATES.index("along_track")], (worst, box)


@pytest.mark.slow
def test_a_refusal_by_the_cells_names_the_cell_refused(masses):
    _, problem = masses
    strong = replace(problem, plant=replace(problem.plant, current=0.3))
    cert = certify_cascade(strong)
    assert not cert.holds and cert.cells == 1
    assert "cells of the current and the masses do not certify either" in cert.reason
    assert "m11 " in cert.reason and "kg" in cert.reason and "refused" in cert.reason


@pytest.mark.slow
def test_a_refusal_by_the_cells_names_only_what_was_cut(masses):
    # no box declared: the cells are the current's alone, and the refusal does not speak of masses
    _, problem = masses
    exact = replace(problem, plant=replace(problem.plant, box=ParameterBox(problem.plant.model), current=0.45))
    cert = certify_cascade(exact)
    assert not cert.holds
    assert "cells of the current do not certify either" in cert.reason
    assert "masses" not in cert.reason.split("cells of")[1].split(":")[0]


#: Three REMUS 100 line abreast on a lawn-mower (150 m turns) with masses +-3 % and damping +-20 % in a
#: 0.2 m/s current: refused; the whole box at once certifies only a current below 0.005 m/s, its cells
#: certify several times more.
TURNING = {
    "vehicle": {"preset": "remus100"},
    "formation": {"n": 3, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 15.0], [0.0, -15.0]]},
    "reference": {"kind": "lawnmower", "speed": 1.5, "leg_length": 400.0, "spacing": 600.0, "turn_radius": 150.0},
    "actuators": {"preset": "remus100"},
    "guidance": {"kind": "ilos", "heading_bandwidth": 2.4, "lookahead": 16.0},
    "uncertainty": {k: [0.97, 1.03] for k in ("m11", "m22", "m33")}
    | {k: [0.8, 1.2] for k in ("d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")},
    "disturbance": {"current_speed": 0.2},
}


@pytest.mark.slow
def test_the_advised_smaller_current_is_raised_by_cells_and_certifies_when_rerun():
    from auv_hinf.certificate.assembly import certify
    from auv_hinf.certificate.parts.guidance import _kept_apart, _with

    cfg = config_from_dict(TURNING, "turning box")
    summary = guidance_summary(cfg)
    assert not summary.holds and summary.current_speed is not None
    advised = summary.current_speed
    # above what the whole box certifies at once: that test refuses the advised current
    assert not _kept_apart(cfg, _with(cfg, summary.problem, current=advised))
    rerun = config_from_dict(TURNING | {"disturbance": {"current_speed": advised}}, "turning box, advised")
    cert = certify(rerun)
    assert cert.verdict("guidance").ok, cert.reasons


@pytest.mark.slow
def test_a_budget_of_cells_stops_the_same_search_sooner():
    tables = {k: v for k, v in CELLS_LINE.items() if k != "simulation"}
    cfg = config_from_dict(tables, "cells line")
    problem = cascade_problem(cfg, design_point(cfg))
    full = certify_cascade(problem)
    assert full.holds and full.cells > 1  # the whole box is refused: cells certify it
    # the probes of an advice certify within a smaller budget: the same search, stopped sooner
    assert certify_cascade(problem, budget=64).position_bound == full.position_bound
    short = certify_cascade(problem, budget=1)
    assert not short.holds and "1 cells were tried" in short.reason
