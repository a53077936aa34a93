"""The composed certificate's advice searches and the deployed synthesis's fallback, with fake certificates.

A fake certificate covers exactly where the test says, so each search's answer is known: the
bisection's answer below its resolution, the knobs a configuration declares, and the gains the
synthesis runs when no candidate covers the declared box and current.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import pytest

from auv_hinf.certificate.deployed import deployed_problem
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.composed import JOINT_ENOUGH, composed_start
from auv_hinf.composed.advice import (
    ADVICE_DIGITS,
    ADVICE_HALVINGS,
    JOINT,
    NOISE_CHANNELS,
    WORLD,
    Advice,
    channels_put_back,
    declared_knobs,
    largest_covered,
    rounded_down,
    shrunk,
)
from auv_hinf.composed.certificate import DeployedCertificate, DeployedProblem, ForceBound
from auv_hinf.composed.loops import Errors
from auv_hinf.composed.synthesis import HEADING_GRID, POSITION_GRID, synthesise_deployed
from auv_hinf.config.settings import config_from_dict
from tests.helpers import DEPLOYED_BOXED


@pytest.fixture(scope="module")
def boxed() -> DeployedProblem:
    cfg = config_from_dict(DEPLOYED_BOXED, "boxed")
    point = design_point(cfg)
    return deployed_problem(cfg, point.mission, point.tube, point.offsets, point.gains, composed_start(point))


def _world_scale(problem: DeployedProblem, declared: DeployedProblem) -> float:
    """The current's fraction of the declared one (the world knob scales box and current alike)."""
    return problem.plant.current / declared.plant.current


def _world_covered_up_to(
    declared: DeployedProblem, edge: float, seen: list[float]
) -> Callable[[DeployedProblem], DeployedCertificate]:
    """A stand-in certificate covering the world up to ``edge`` of ``declared``'s; it records each scale in ``seen``."""

    def certify(problem: DeployedProblem) -> DeployedCertificate:
        s = _world_scale(problem, declared)
        seen.append(s)
        return DeployedCertificate(s <= edge, None, ())

    return certify


def test_a_box_and_current_declared_with_the_hardware_get_the_world_knob_before_everything_together(boxed):
    knobs = declared_knobs(boxed)
    assert WORLD == ("current", "box") and knobs.index("world") < knobs.index("together")
    calm = replace(
        boxed, implementation=replace(boxed.implementation, delay=0.0, noise=boxed.implementation.noise.scaled(0))
    )
    assert "together" not in declared_knobs(calm)  # with no noise or delay, "together" would be the world again
    world = shrunk(boxed, "world", 0.25)
    assert world.plant.current == pytest.approx(0.25 * boxed.plant.current)
    assert world.implementation == boxed.implementation  # the hardware as declared


@pytest.mark.parametrize("edge", [0.03, 0.004])
def test_a_covered_scale_below_the_bisection_is_found_by_halving_not_answered_as_zero(boxed, edge):
    """Covered up to ``edge`` of the declared world: the answer is covered, positive and within 2x of it."""
    calls: list[float] = []
    got = largest_covered(boxed, "world", _world_covered_up_to(boxed, edge, calls))
    assert got is not None and 0.5 * edge < got.scale <= edge
    assert got.scaled == ("current", "box") and got.certificate.covers
    assert len(calls) <= 1 + 4 + ADVICE_HALVINGS + 2


def test_no_covered_scale_above_the_halvings_is_answered_as_zero(boxed):
    got = largest_covered(boxed, "world", lambda p: DeployedCertificate(_world_scale(p, boxed) == 0.0, None, ()))
    assert got is not None and got.scale == 0.0


def test_with_no_candidate_for_the_box_and_current_the_gains_for_the_hardware_alone_run(boxed):
    """The synthesis falls back to the best gains of the declared implementation in still water on the model."""
    chosen = (POSITION_GRID[1], HEADING_GRID[2])

    def certify(problem: DeployedProblem) -> DeployedCertificate:
        calm = problem.plant.current == 0.0 and not problem.plant.box.declared
        g = problem.gains
        ours = ((g.alpha, g.k1), g.k_psi) == chosen
        return DeployedCertificate(calm and ours, None, ())

    def covering(problem: DeployedProblem) -> DeployedCertificate:
        cert = certify(problem)
        if not cert.covers:
            return cert
        force = ForceBound(1.0, 1.0, 0.1, (1.0, 1.0, 0.1), (0.0, 0.0, 0.0))
        return DeployedCertificate(True, None, (), errors=Errors(0.1, 0.1, 0.01, 0.01), force=force)

    design = synthesise_deployed(boxed, certify=covering)
    assert ((design.gains.alpha, design.gains.k1), design.gains.k_psi) == chosen
    assert design.value is None and design.covered == 0 and "still water on the model" in design.binding
    assert not design.certificate.covers  # its certificate is the declared world's


@pytest.mark.slow
@pytest.mark.parametrize(("world_scale", "answers"), [(0.01, ("world", "together")), (0.1, ("world",))])
def test_a_small_world_answer_is_given_beside_everything_together_and_a_large_one_alone(
    boxed, monkeypatch, world_scale, answers
):
    """The hardware kept leaves little of the box and current: the answer that shrinks the noise and
    delay with them is searched too, and both are given; from JOINT_ENOUGH of the declared, one."""
    import auv_hinf.certificate.parts.composed as composed_part

    assert JOINT_ENOUGH == 1.0 / 32.0 and (world_scale < JOINT_ENOUGH) == (len(answers) == 2)
    cfg = config_from_dict(DEPLOYED_BOXED, "boxed")
    point = design_point(cfg)
    searched = []

    def fake_largest(problem, knob, certify):
        searched.append(knob)
        scale = {"world": world_scale, "together": 0.125}.get(knob)
        if scale is None:
            return None
        return Advice(knob, scale, shrunk(problem, knob, scale), DeployedCertificate(True, None, ()), (knob,), problem)

    monkeypatch.setattr(composed_part, "within_actuators", lambda p: lambda q: DeployedCertificate(False, None, ("x",)))
    monkeypatch.setattr(composed_part, "largest_covered", fake_largest)
    monkeypatch.setattr(composed_part, "confirmed", lambda c, p, advice, certify: advice)
    summary = composed_part.composed_summary(point)
    assert tuple(a.knob for a in summary.advice) == answers
    assert searched[-1] == answers[-1]  # nothing is searched after the last answer kept


def test_an_advised_sample_time_climbs_to_near_the_longest_the_re_runs_gains_cover(boxed, monkeypatch):
    """The advice at the design's gains covered 5 % of the declared sample time; the re-run's own gains cover
    up to 30 %: a geometric bisection with those gains finds a scale within its resolution below 30 %, and
    one re-run there (which covers) is the answer; had that re-run not covered, the first answer stays."""
    from auv_hinf.certificate.parts import composed as part

    edge, runs, certified = 0.3, [], []

    def certify(problem: DeployedProblem) -> DeployedCertificate:
        scale = problem.implementation.sample_time / boxed.implementation.sample_time
        certified.append(scale)
        return DeployedCertificate(scale <= edge * (1 + 1e-12), None, ())

    def as_rerun(cfg, a: Advice) -> Advice | None:
        runs.append(a.scale)
        return replace(a, certificate=DeployedCertificate(True, None, ())) if a.scale <= edge else None

    monkeypatch.setattr(part, "_as_rerun", as_rerun)
    first = Advice("sample_time", 0.05, shrunk(boxed, "sample_time", 0.05), DeployedCertificate(True, None, ()))
    got = part._climbed(None, first, boxed, certify)
    resolution = (1.0 / 0.05) ** (1.0 / 2**part.SAMPLE_TIME_CLIMBS)
    assert edge / resolution <= got.scale <= edge and got.certificate.covers
    assert len(certified) == part.SAMPLE_TIME_CLIMBS and runs == [got.scale]
    assert got.problem.implementation.sample_time == pytest.approx(got.scale * boxed.implementation.sample_time)
    monkeypatch.setattr(part, "_as_rerun", lambda cfg, a: None)  # the re-run's own design does not cover
    assert part._climbed(None, first, boxed, certify) is first


def test_noise_at_zero_is_not_a_physical_answer():
    from auv_hinf.composed.advice import TOGETHER, physical

    assert not physical(0.0, ("noise",))
    assert not physical(0.0, TOGETHER)  # the noise shrunk with the others to nothing
    assert physical(0.0, ("delay",)) and physical(0.0, ("current", "box"))  # removable in the world or hardware
    assert physical(1e-3, ("noise",))  # a small noise is a navigation to buy


def test_the_noise_answer_keeps_the_channels_that_need_not_shrink_and_raises_the_one_that_binds(boxed):
    """Covered while the position noise is within 0.3 of its declared bound, whatever the other channels."""
    declared = boxed.implementation.noise
    assert declared.position > 0.0 and declared.velocity > 0.0  # the fixture declares both
    calls = []

    def certify(problem: DeployedProblem) -> DeployedCertificate:
        n = problem.implementation.noise
        calls.append(n)
        return DeployedCertificate(n.position <= 0.3 * declared.position, None, ())

    got = largest_covered(boxed, "noise", certify)
    assert got is not None and got.certificate.covers
    n = got.problem.implementation.noise
    assert got.channels == ("position",) and got.scale == pytest.approx(n.position / declared.position)
    assert 0.3 / 1.3 < got.scale <= 0.3  # the geometric bisection lands within its resolution of the edge
    assert (n.velocity, n.heading, n.yaw_rate) == (declared.velocity, declared.heading, declared.yaw_rate)
    assert certify(got.problem).covers  # the answer is a value the certificate covered
    assert len(calls) <= 2 + 4 + len(NOISE_CHANNELS) + 4 + 1


def test_a_noise_answer_that_needs_every_channel_shrunk_is_the_uniform_one(boxed):
    """Covered only with every channel within half its bound: nothing is put back, the uniform answer stands,
    and it names every channel."""
    declared = boxed.implementation.noise
    names = [c for c in NOISE_CHANNELS if getattr(declared, c) > 0.0]

    def certify(problem: DeployedProblem) -> DeployedCertificate:
        n = problem.implementation.noise
        return DeployedCertificate(all(getattr(n, c) <= 0.5 * getattr(declared, c) for c in names), None, ())

    got = largest_covered(boxed, "noise", certify)
    assert got is not None and got.channels == tuple(names) and 0.25 < got.scale <= 0.5  # every channel binds


def test_with_last_the_last_channel_left_is_tried_too():
    """An answer that shrinks other settings with the noise may put back every channel."""
    asked = []

    def holds(rest: tuple[str, ...]) -> bool:
        asked.append(rest)
        return True

    assert channels_put_back(NOISE_CHANNELS, holds, last=True) == ()
    assert asked[-1] == () and len(asked) == len(NOISE_CHANNELS)
    assert channels_put_back(NOISE_CHANNELS, lambda rest: True) == ("yaw_rate",)  # without it, the last stays


def test_channels_are_put_back_in_order_and_the_last_one_left_is_never_tried():
    """``channels_put_back``: each channel in turn, kept shrunk where putting it back fails."""
    asked = []

    def holds(rest: tuple[str, ...]) -> bool:
        asked.append(rest)
        return "heading" in rest  # the answer covers while the heading stays shrunk

    got = channels_put_back(NOISE_CHANNELS, holds)
    assert got == ("heading",)
    assert asked == [
        ("heading", "velocity", "yaw_rate"),  # position put back
        ("velocity", "yaw_rate"),  # heading not
        ("heading", "yaw_rate"),  # velocity put back
        ("heading",),  # yaw rate put back; the heading, alone left, is never tried
    ]
    assert channels_put_back(("position",), lambda rest: True) == ("position",)


@pytest.mark.parametrize("x", [1.0, 0.5, 0.013671875, 0.0009765625, 0.26108594541, 7.0 / 3.0, 123456.789, 1e-9])
def test_rounded_down_keeps_three_significant_digits_and_never_rounds_up(x):
    r = rounded_down(x)
    assert r <= x and x - r <= 10.0 ** (math.floor(math.log10(x)) - ADVICE_DIGITS + 1) * (1.0 + 1e-9)
    assert len(f"{r:.12e}".split("e")[0].replace(".", "").rstrip("0")) <= ADVICE_DIGITS
    assert rounded_down(0.0) == 0.0


@pytest.mark.parametrize("edge", [0.0137, 0.2611])
def test_an_advised_scale_is_the_certified_one_with_three_significant_digits(boxed, edge):
    evaluated: list[float] = []
    got = largest_covered(boxed, "world", _world_covered_up_to(boxed, edge, evaluated))
    assert got is not None and got.scale <= edge
    assert any(s == pytest.approx(got.scale, rel=1e-12) for s in evaluated)  # the value the certificate saw
    assert all(f"{s:.12e}"[:4] + "0" * 9 == f"{s:.12e}"[:13] for s in evaluated if s > 0.0)  # 3 digits each


@pytest.mark.parametrize("scale", [0.7, 0.3, 0.29, 0.0625, 0.123])
@pytest.mark.parametrize("knob", ["noise", "delay", "sample_time", "current"])
def test_a_shrunk_value_is_written_as_a_person_writes_it(boxed, knob, scale):
    """0.1 s x 0.7 is answered as 0.07 s, not 0.06999999999999999 s: the certificate is computed at the
    tidy value, which is within 1e-12 of the product."""
    got = shrunk(boxed, knob, scale)
    impl, plant = got.implementation, got.plant
    values = {
        "noise": [getattr(impl.noise, c) for c in NOISE_CHANNELS],
        "delay": [impl.delay],
        "sample_time": [impl.sample_time],
        "current": [plant.current, plant.current_rate],
    }[knob]
    old = {
        "noise": [getattr(boxed.implementation.noise, c) for c in NOISE_CHANNELS],
        "delay": [boxed.implementation.delay],
        "sample_time": [boxed.implementation.sample_time],
        "current": [boxed.plant.current, boxed.plant.current_rate],
    }[knob]
    assert any(v > 0.0 for v in values)
    for v, o in zip(values, old, strict=True):
        assert float(f"{v:.6g}") == v, v  # a few significant digits, not seventeen
        if knob != "sample_time":
            assert v == pytest.approx(o * scale, rel=1e-11, abs=0.0)


@pytest.mark.slow
def test_a_design_asked_only_whether_it_covers_skips_the_still_water_search_and_is_the_same_when_it_covers():
    """A re-run of advice asks only whether some candidate covers (:func:`rerun`): when none does, the search of
    gains that hold the hardware in still water is skipped (fewer certificates, the middle candidate, not
    covering); when one does, the design is the one ``certify`` computes."""
    from auv_hinf.composed.synthesis import HEADING_STAGE_POSITION
    from auv_hinf.config.presets import preset_config

    wide = {"m11": [0.9, 1.1], "d11_quad": [0.8, 1.2]}  # ten times the fixture's box, in 0.1 m/s
    refused = config_from_dict({**DEPLOYED_BOXED, "uncertainty": wide, "disturbance": {"current_speed": 0.1}}, "wide")
    full, quick = design_point(refused).deployed_design, design_point(refused, fallback=False).deployed_design
    assert full is not None and quick is not None
    assert full.covered == quick.covered == 0 and not quick.certificate.covers
    assert quick.tried == len(POSITION_GRID) * len(HEADING_GRID) < full.tried
    assert (quick.gains.alpha, quick.gains.k1) == HEADING_STAGE_POSITION
    covering = preset_config("bluerov2-deployed")
    a, b = design_point(covering), design_point(covering, fallback=False)
    assert a.deployed_design is not None and a.deployed_design.covered > 0
    assert a.gains == b.gains and a.deployed_design.value == b.deployed_design.value


@pytest.mark.slow
def test_two_answers_give_the_first_as_the_settings_to_write_and_both_in_the_advice(monkeypatch):
    """When any one of two answers certifies (the box and current alone, or everything together), the reason's
    settings are the first answer whole, each key once, as a re-run writes them; the JSON's advice lists both.
    Both used to be concatenated there, the same keys with two values (a file that cannot be written)."""
    import auv_hinf.certificate.parts.composed as composed_part
    from auv_hinf.certificate.assembly import certify

    cfg = config_from_dict(DEPLOYED_BOXED, "boxed")

    def fake_largest(problem, knob, certify):
        scale = {"world": 0.01, "together": 0.125}.get(knob)
        if scale is None:
            return None
        scaled = tuple(k for k in JOINT[knob] if k in declared_knobs(problem))
        return Advice(knob, scale, shrunk(problem, knob, scale), DeployedCertificate(True, None, ()), scaled, problem)

    monkeypatch.setattr(composed_part, "within_actuators", lambda p: lambda q: DeployedCertificate(False, None, ("x",)))
    monkeypatch.setattr(composed_part, "largest_covered", fake_largest)
    monkeypatch.setattr(composed_part, "confirmed", lambda c, p, advice, certify: advice)
    data = certify(cfg).to_dict()
    (reason,) = data["parts"]["composed"]["reasons"]
    keys = [(s["table"], s["key"]) for s in reason["settings"]]
    assert len(keys) == len(set(keys)) and ("disturbance", "current_speed") in keys
    answers = data["composed"]["advice"]
    assert len(answers) == 2 and "the settings given are the first" in reason["message"]
    first = {(s["table"], s["key"]): s["value"] for s in answers[0]["settings"]}
    assert {(s["table"], s["key"]): s["value"] for s in reason["settings"]} == first
