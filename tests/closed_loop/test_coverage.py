"""Coverage of one run by the closed-loop certificate (:mod:`auv_hinf.closed_loop.coverage`).

The verdicts are checked against independent computations: the ellipsoid extents by
sampling the ellipsoid's boundary, the envelope margins of the sine mission in closed
form, the thrust bound against the forces of a simulated run, and the blend-time search
against an enumeration of the candidates in their documented order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

import auv_hinf.closed_loop.coverage as coverage
from auv_hinf.actuation.limits import Actuators
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.run_plan import plan_run, with_start
from auv_hinf.closed_loop.coverage import BLEND_TIMES, TURN_TIMES, check_run, cover_start, initial_errors
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import FormationConfig
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import FleetReference, shaped_start
from auv_hinf.mission.margins import envelope_margins
from auv_hinf.mission.tubes import shaped_tube
from auv_hinf.models.jacobi import regular_polygon
from auv_hinf.simulation.engine import simulate


@dataclass(frozen=True)
class Setup:
    cfg: FormationConfig
    gains: Gains
    cert: ClosedLoopCertificate
    fleet: FleetReference

    def check(self, initial: np.ndarray, fleet: FleetReference | None = None, **kw):
        g = self.gains
        return check_run(
            self.cert,
            self.cfg.vehicle,
            self.cfg.envelope,
            g,
            self.fleet if fleet is None else fleet,
            initial,
            **kw,
        )

    def cover(self, initial: np.ndarray, **kw):
        g = self.gains
        return cover_start(
            self.cert,
            self.cfg.vehicle,
            self.cfg.envelope,
            g,
            self.fleet.mission,
            self.fleet.offsets,
            initial,
            **kw,
        )


@pytest.fixture(scope="module")
def tri() -> Setup:
    cfg = preset_config("paper-triangle")
    point = design_point(cfg)
    gains = point.require_gains()
    cert = closed_loop_for(point)
    return Setup(cfg, gains, cert, design_point(cfg).fleet())


def start_with_errors(fleet: FleetReference, e, de, ep, dep) -> np.ndarray:
    """Initial states whose errors against ``fleet`` at ``t = 0`` are the given ones."""
    m = fleet.motion(0.0)
    psi = m.psi + ep
    vel = m.v + de
    c, s = np.cos(psi), np.sin(psi)
    u, v = c * vel[:, 0] + s * vel[:, 1], -s * vel[:, 0] + c * vel[:, 1]
    return np.column_stack([m.p + e, psi, u, v, m.r + dep])


def worst_corner(setup: Setup, scale: float, rng: np.random.Generator) -> np.ndarray:
    """Starts at ``scale`` times the region's radii that maximise both Lyapunov levels.

    ``rho = p11 |e|^2 + 2 p12 e.e' + p22 |e'|^2`` is largest over the box when ``e`` and
    ``e'`` are parallel with the sign of ``p12`` (likewise for the heading pair and ``q12``),
    so these starts attain the region's own error bounds.
    """
    reg, p2, q = setup.cert.region.region, setup.cert.region.p2, setup.cert.region.q
    n = setup.fleet.offsets.shape[0]
    th = rng.uniform(0, 2 * np.pi, n)
    w = np.column_stack([np.cos(th), np.sin(th)])
    e = scale * reg.position * w
    de = scale * reg.velocity * np.sign(p2[0, 1]) * w
    sg = rng.choice([-1.0, 1.0], n)
    ep = scale * reg.heading * sg
    dep = scale * reg.yaw_rate * np.sign(q[0, 1]) * sg
    return start_with_errors(setup.fleet, e, de, ep, dep)


def far_start(setup: Setup, rng: np.random.Generator, dist: float = 20.0) -> np.ndarray:
    """A start ``dist`` m from the slots, heading off by up to 1 rad, at 1-1.5 m/s."""
    n = setup.fleet.offsets.shape[0]
    x = start_with_errors(setup.fleet, np.zeros((n, 2)), np.zeros((n, 2)), np.zeros(n), np.zeros(n))
    th = rng.uniform(0, 2 * np.pi, n)
    x[:, 0] += dist * np.cos(th)
    x[:, 1] += dist * np.sin(th)
    x[:, 2] += rng.uniform(-1.0, 1.0, n)
    x[:, 3] = rng.uniform(1.0, 1.5, n)
    x[:, 4] = rng.uniform(-0.3, 0.3, n)
    x[:, 5] = rng.uniform(-0.1, 0.1, n)
    return x


def ellipsoid_extent_sampled(m: np.ndarray, rho: float, k: int = 200_001) -> tuple[float, float]:
    """``max |x1|, |x2|`` over ``x^T M x = rho`` by sampling its boundary (independent check)."""
    chol = np.linalg.cholesky(m)
    t = np.linspace(0, 2 * np.pi, k)
    x = np.sqrt(rho) * np.linalg.solve(chol.T, np.stack([np.cos(t), np.sin(t)]))
    return float(np.abs(x[0]).max()), float(np.abs(x[1]).max())


@pytest.mark.slow
def test_raw_start_inside_region_is_covered(tri, rng):
    x = worst_corner(tri, 1.0, rng)
    cov = tri.check(x)
    assert cov.covered and cov.start == "paper" and cov.blend_time is None
    assert cov.margins is not None and cov.margins.ok
    # the worst corner attains the region's bounds
    rb = tri.cert.region.bounds
    for f in ("position", "velocity", "heading", "yaw_rate"):
        assert getattr(cov.bounds, f) == pytest.approx(getattr(rb, f), rel=1e-9)
    # extents checked by sampling the ellipsoids through the actual start
    e, de, ep, dep = initial_errors(tri.fleet, x)
    p2, q = tri.cert.region.p2, tri.cert.region.q
    rho_p = max(p2[0, 0] * e[i] @ e[i] + 2 * p2[0, 1] * e[i] @ de[i] + p2[1, 1] * de[i] @ de[i] for i in range(3))
    rho_q = max(q[0, 0] * ep[i] ** 2 + 2 * q[0, 1] * ep[i] * dep[i] + q[1, 1] * dep[i] ** 2 for i in range(3))
    ext_p, ext_q = ellipsoid_extent_sampled(p2, rho_p), ellipsoid_extent_sampled(q, rho_q)
    np.testing.assert_allclose([cov.bounds.position, cov.bounds.velocity], ext_p, rtol=1e-6)
    np.testing.assert_allclose([cov.bounds.heading, cov.bounds.yaw_rate], ext_q, rtol=1e-6)
    # margins of the sine mission in closed form: speed in [s, sqrt(s^2 + (A w)^2)], no
    # heading offset, turn rate within +-A w^2/s
    b, env, mb = cov.bounds, tri.cfg.envelope, tri.fleet.mission.bounds()
    s_lo, s_hi = 1.0, math.hypot(1.0, 30.0 * 0.1)
    turn = 30.0 * 0.1**2 / 1.0
    assert mb.speed_max == pytest.approx(s_hi, rel=1e-11) and mb.turn_rate_max == pytest.approx(turn, rel=1e-11)
    m = cov.margins
    assert m.u_hi == pytest.approx(env.u[1] - (s_hi + b.velocity), abs=1e-9)
    assert m.u_lo == pytest.approx(s_lo * math.cos(b.heading) - b.velocity - env.u[0], abs=1e-9)
    assert m.v_hi == pytest.approx(env.v[1] - (s_hi * math.sin(b.heading) + b.velocity), abs=1e-9)
    assert m.r_hi == pytest.approx(env.r[1] - (turn + b.yaw_rate), abs=1e-9)
    # a raw start that is covered needs no shaping
    shaped = tri.cover(x, start="shaped")
    assert shaped.covered and shaped.reference.shaping is None and shaped.blend_time is None


def test_start_just_outside_along_worst_direction_is_not_covered(tri, rng):
    seed = int(rng.integers(1 << 30))
    inside = tri.check(worst_corner(tri, 1.0, np.random.default_rng(seed)))
    outside = tri.check(worst_corner(tri, 1.001, np.random.default_rng(seed)))
    assert inside.covered and inside.margins.min >= 0
    assert outside.margins is not None and outside.margins.min < 0
    assert not outside.covered and "margin" in outside.reason
    # one readable line: the channel, the edge and the unit, with one "not covered" prefix
    assert outside.reason.count("not covered") == 1
    assert any(f"{c} would cross" in outside.reason for c in ("surge speed", "sway speed", "yaw rate"))
    assert outside.reason.rstrip(")").endswith("< 0") and ("m/s" in outside.reason or "rad/s" in outside.reason)
    # the bounds scale with the start
    assert outside.bounds.position == pytest.approx(1.001 * inside.bounds.position, rel=1e-9)


def test_shaped_start_has_zero_errors_at_t0(tri, rng):
    for _ in range(3):
        x = far_start(tri, rng)
        for tb, th in ((30.0, 20.0), (120.0, 60.0)):
            fleet = shaped_start(tri.fleet.mission, tri.fleet.offsets, x, tb, turn_time=th)
            e, de, ep, dep = initial_errors(fleet, x)
            # zero up to the rounding of p - (off + q + dp) with |p| ~ 30 m
            np.testing.assert_allclose(e, 0.0, atol=1e-12)
            np.testing.assert_allclose(de, 0.0, atol=1e-12)
            np.testing.assert_allclose(ep, 0.0, atol=1e-12)
            np.testing.assert_allclose(dep, 0.0, atol=1e-12)
            cov = tri.check(x, fleet=fleet)
            assert cov.bounds.position <= 1e-11 and cov.bounds.heading <= 1e-11
            # after the blend the reference is the plain mission
            later = np.array([tb, tb + 3.7])
            np.testing.assert_array_equal(fleet.motion(later).p, tri.fleet.motion(later).p)


@pytest.mark.slow
def test_blend_time_search_returns_smallest_covered_candidate(tri):
    rng = np.random.default_rng(4)
    x = far_start(tri, rng, dist=25.0)
    cov = tri.cover(x, start="shaped")
    assert cov.covered and cov.blend_time is not None
    order = [(tb, th) for tb in BLEND_TIMES for th in ([t for t in TURN_TIMES if t <= tb] or [tb])]
    first = next(
        i
        for i, (tb, th) in enumerate(order)
        if tri.check(x, fleet=shaped_start(tri.fleet.mission, tri.fleet.offsets, x, tb, turn_time=th)).covered
    )
    assert (cov.blend_time, cov.turn_time) == order[first]
    assert first > 0, "the first candidate already covers: the search is not exercised"
    np.testing.assert_array_equal(
        cov.reference.shaping.dp,
        shaped_start(tri.fleet.mission, tri.fleet.offsets, x, *order[first][:1], turn_time=order[first][1]).shaping.dp,
    )
    # a fixed blend time is the only candidate tried
    fixed = tri.cover(x, start="shaped", blend_time=order[first][0])
    assert fixed.covered and fixed.blend_time == order[first][0]
    if first > 0 and order[0][0] != order[first][0]:
        too_short = tri.cover(x, start="shaped", blend_time=order[0][0])
        assert not too_short.covered and too_short.blend_time == order[0][0]


@pytest.mark.slow
def test_actuator_limit_below_certified_thrust_is_not_covered(tri, rng):
    x = worst_corner(tri, 0.8, rng)
    cov = tri.check(x)
    assert cov.covered and cov.thrust is not None
    t = np.array([cov.thrust.force_x, cov.thrust.force_y, cov.thrust.moment])
    assert tri.check(x, actuators=Actuators(*(1.001 * t))).covered
    for k in range(3):
        lim = 1.001 * t
        lim[k] = 0.999 * t[k]
        low = tri.check(x, actuators=Actuators(*lim))
        assert not low.covered and "actuators give" in low.reason
    # the bound holds on the simulated run
    plan = plan_run(with_start(tri.cfg, x), start="paper", horizon=40.0, samples=801)
    assert plan.covered
    res = simulate(plan.scenario)
    assert res.exit_time is None
    f = np.abs(res.forces).max(axis=(0, 1))
    assert np.all(f <= t), (f, t)


def chunked_and_whole(tri, monkeypatch, n: int = 40):
    """Coverage of one shaped N = 40 fleet with the default chunks and in one piece."""
    assert n > coverage.TUBE_CHUNK
    offsets = regular_polygon(n, 60.0)
    fleet0 = FleetReference(tri.fleet.mission, offsets)
    rng = np.random.default_rng(40)
    x = start_with_errors(
        fleet0,
        rng.uniform(-8, 8, (n, 2)),
        rng.uniform(-0.3, 0.3, (n, 2)),
        rng.uniform(-0.6, 0.6, n),
        rng.uniform(-0.05, 0.05, n),
    )
    fleet = shaped_start(tri.fleet.mission, offsets, x, 60.0, turn_time=40.0)
    chunked = tri.check(x, fleet=fleet)
    with monkeypatch.context() as mp:
        mp.setattr(coverage, "TUBE_CHUNK", 10 * n)
        whole = tri.check(x, fleet=fleet)
    return fleet, chunked, whole


MARGINS = ("u_hi", "u_lo", "v_hi", "v_lo", "r_hi", "r_lo")


@pytest.mark.slow
def test_chunked_fleet_margins_agree_to_tube_resolution(tri, monkeypatch):
    fleet, chunked, whole = chunked_and_whole(tri, monkeypatch)
    assert chunked.bounds == whole.bounds and chunked.covered == whole.covered
    # both are sound; the tube pads each cell by about its speed resolution (1e-3 m/s)
    for f in MARGINS:
        assert getattr(chunked.margins, f) == pytest.approx(getattr(whole.margins, f), abs=1e-3)
    direct = envelope_margins(shaped_tube(fleet), whole.bounds, tri.cfg.envelope)
    assert all(getattr(whole.margins, f) == getattr(direct, f) for f in MARGINS)


@pytest.mark.slow
def test_chunked_fleet_gives_unchunked_margins(tri, monkeypatch):
    _, chunked, whole = chunked_and_whole(tri, monkeypatch)
    assert chunked.margins == whole.margins and chunked.thrust == whole.thrust


def search_as_before(setup: Setup, x: np.ndarray):
    """The blend-time search as it was written before the lazy thrust: every candidate checked in full, in order."""
    base = setup.check(x, start="shaped")
    if base.covered:
        return base
    best = None
    for tb in BLEND_TIMES:
        for th in [t for t in TURN_TIMES if t <= tb] or [tb]:
            fleet = shaped_start(setup.fleet.mission, setup.fleet.offsets, x, tb, turn_time=th)
            cov = setup.check(x, fleet=fleet, start="shaped")
            if cov.covered:
                return cov
            if best is None or (cov.margins.min if cov.margins else -math.inf) > (
                best.margins.min if best.margins else -math.inf
            ):
                best = cov
    return best


def assert_same_search(setup: Setup, x: np.ndarray) -> None:
    new, old = setup.cover(x, start="shaped"), search_as_before(setup, x)
    assert (new.covered, new.blend_time, new.turn_time) == (old.covered, old.blend_time, old.turn_time)
    assert new.bounds == old.bounds and new.margins == old.margins and new.thrust == old.thrust
    assert new.thrust is not None
    assert new.reason.endswith(old.reason.removeprefix("not covered: "))


@pytest.mark.slow
def test_search_gives_the_verdict_blend_margins_and_thrust_of_the_full_search(tri):
    x = far_start(tri, np.random.default_rng(4), dist=25.0)
    assert_same_search(tri, x)


@pytest.mark.slow
def test_search_of_an_uncovered_start_reports_the_full_search_best_candidate(tri):
    x = far_start(tri, np.random.default_rng(1), dist=150.0)
    assert not tri.cover(x, start="shaped").covered
    assert_same_search(tri, x)


@pytest.mark.slow
def test_a_failing_region_solve_certifies_nothing_and_the_search_goes_on(monkeypatch):
    """A heading SDP whose solve fails above some start size is not the answer: the region search
    keeps the sizes whose solves succeed and verify (here: nothing of the heading, when every solve fails)."""
    from auv_hinf.certificate.design_point import design_point
    from auv_hinf.certificate.parts.closed_loop import closed_loop_for
    from auv_hinf.closed_loop import region as region_module
    from auv_hinf.config.presets import preset_config
    from auv_hinf.exceptions import SolverError

    point = design_point(preset_config("paper-triangle"))
    assert closed_loop_for(point).region.region.heading > 0.0  # the honest solve certifies a heading start

    def failing(*args, **kwargs):
        raise SolverError("heading-region SDP: the returned Q fails the strict eigvalsh re-check")

    monkeypatch.setattr(region_module, "lmi_heading_region", failing)
    cert = closed_loop_for(point)
    reg = cert.region.region
    assert reg.heading == 0.0 and reg.yaw_rate == 0.0 and cert.region.q is None
    assert reg.position > 0.0 and reg.velocity > 0.0 and cert.region.margins.ok
