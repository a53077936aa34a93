"""Mission paths, their bounds, the shaped start and the sound reference tubes."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import quad
from scipy.optimize import minimize_scalar

from auv_hinf.exceptions import ParameterError
from auv_hinf.mission.fleet import (
    BLEND_H0,
    BLEND_H1,
    H0_SUP,
    H1_SUP,
    REFERENCES,
    FleetReference,
    reference_from_dict,
    shaped_start,
    wrap_angle,
)
from auv_hinf.mission.paths import (
    GL_NODES,
    SMOOTHSTEP,
    SMOOTHSTEP_D1_MAX,
    SMOOTHSTEP_D2_MAX,
    SMOOTHSTEP_D3_MAX,
    CircleReference,
    LawnmowerReference,
    LineReference,
    SineReference,
    heading_from_velocity,
)
from auv_hinf.mission.tubes import TUBE_RTOL, fleet_tube, mission_tube, shaped_tube
from auv_hinf.models.jacobi import JacobiTransform

MISSIONS = {
    "sine-paper": SineReference(),
    "sine-gentle": SineReference(speed=1.5, amplitude=2.0, omega=0.05),
    "line": LineReference(1.2, heading=2.5, start=(3.0, -4.0)),
    "circle": CircleReference(1.3, 40.0, center=(5.0, 7.0)),
    "lawnmower": LawnmowerReference(1.5, 80.0, 30.0, 6.0, start=(1.0, 2.0)),
}


def _norm(x: np.ndarray) -> np.ndarray:
    return np.hypot(x[..., 0], x[..., 1])


def _fd(f, t: np.ndarray, h: float) -> np.ndarray:
    """Fourth-order central difference of ``f`` at ``t``."""
    return (-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h)


def _angle_rate(f, t: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """Time derivative of an angle-valued ``f`` (free of 2 pi jumps): ``Im(conj(e^{i f}) d/dt e^{i f})``."""
    return np.imag(np.conj(np.exp(1j * f(t))) * _fd(lambda s: np.exp(1j * f(s)), t, h))


def _turn_advance(ref: LawnmowerReference) -> float:
    """Advance ``D`` (m) of a 90-degree turn along each axis, ``s T90 int_0^1 cos((pi/2) b(x)) dx``,
    by 64-point Gauss-Legendre (the class uses :data:`GL_NODES` points)."""
    x, w = np.polynomial.legendre.leggauss(64)
    return ref.speed * ref.t90 * 0.5 * float(np.sum(w * np.cos(0.5 * np.pi * SMOOTHSTEP(0.5 * (x + 1)))))


def _segment_starts(ref: LawnmowerReference) -> np.ndarray:
    """Start times (s) of the 8 segments of one period, then the period: +x leg, left turn, transit
    of ``spacing - 2 D``, left turn, -x leg, right turn, transit, right turn (the class docstring)."""
    leg, transit = ref.leg_length / ref.speed, (ref.spacing - 2.0 * _turn_advance(ref)) / ref.speed
    return np.concatenate([[0.0], np.cumsum([leg, ref.t90, transit, ref.t90] * 2)])


def _joins(ref: LawnmowerReference, periods: int = 3) -> np.ndarray:
    t0 = _segment_starts(ref)
    return (t0[:-1][None, :] + t0[-1] * np.arange(periods)[:, None]).ravel()


# ---------------------------------------------------------------- paths


@pytest.mark.parametrize("name", sorted(MISSIONS))
def test_derivatives_are_consistent(name: str, rng: np.random.Generator) -> None:
    ref = MISSIONS[name]
    t = rng.uniform(0.0, 600.0, 300)
    if isinstance(ref, LawnmowerReference):  # straddle every join of three periods
        t = np.concatenate([t, _joins(ref) + 0.004, _joins(ref)[1:] - 0.004])
    out = ref(t)
    h = 1e-3
    for k in range(3):
        fd = _fd(lambda s, k=k: ref(s)[k], t, h)
        scale = np.abs(out[k + 1]).max() + 1e-3
        assert np.allclose(fd, out[k + 1], rtol=0, atol=1e-6 * scale), (name, k)
    assert all(x.shape == (*t.shape, 2) for x in out)
    assert all(x.shape == (4, 5, 2) for x in ref(np.ones((4, 5))))


def test_lawnmower_positions_integrate_velocity(rng: np.random.Generator) -> None:
    """q(t1) - q(t0) equals the integral of q' (composite 20-point Gauss on pieces between joins)."""
    ref = MISSIONS["lawnmower"]
    assert isinstance(ref, LawnmowerReference)
    joins = _joins(ref)
    x, w = np.polynomial.legendre.leggauss(20)
    for t1 in np.concatenate([rng.uniform(0.0, joins[-1], 40), joins[1:] + 1e-3]):
        t0 = max(0.0, t1 - rng.uniform(1.0, 150.0))
        edges = np.unique(np.concatenate([np.linspace(t0, t1, 41), joins[(joins > t0) & (joins < t1)]]))
        lo, hi = edges[:-1, None], edges[1:, None]
        nodes = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x
        d = np.einsum("kn,n,kni->i", 0.5 * (hi - lo) + 0 * nodes, w, ref(nodes)[1])
        assert np.allclose(ref(t1)[0] - ref(t0)[0], d, rtol=0, atol=1e-10 * (t1 - t0))
    assert quad(lambda s: ref(s)[1][1], 0.0, joins[2], points=joins[1:2], epsabs=1e-12)[0] > 0


def test_lawnmower_quadrature_order_and_geometry() -> None:
    ref = LawnmowerReference(2.0, 50.0, 25.0, 4.0)
    assert GL_NODES < 64
    t0 = _segment_starts(ref)
    # each turn, integrated with GL_NODES points, advances D (64 points) along both axes
    d = _turn_advance(ref)
    for k, sign in ((1, (1, 1)), (3, (-1, 1)), (5, (-1, 1)), (7, (1, 1))):
        step = ref(t0[k + 1])[0] - ref(t0[k])[0]
        assert np.allclose(step, np.multiply(sign, d), rtol=0, atol=1e-13 * ref.spacing), k
    # the segments start where _segment_starts says: peak yaw rate s/R mid-turn (left, left, right,
    # right), none mid-straight; one period moves the pattern by (0, 2 spacing)
    rate = _sampled(ref, 0.5 * (t0[:-1] + t0[1:]))["rate"]
    w1 = ref.speed / ref.turn_radius
    assert np.allclose(rate, [0, w1, 0, w1, 0, -w1, 0, -w1], rtol=0, atol=1e-12 * w1)
    assert np.allclose(ref(t0[-1])[0] - ref(0.0)[0], [0.0, 2 * ref.spacing], atol=1e-12 * ref.spacing)
    # legs alternate +x / -x and the heading progresses in +y with period shift (0, 2 spacing)
    q = ref(np.array([10.0, t0[4] + 10.0, t0[-1] + 10.0]))
    assert q[1][0, 0] > 0 and q[1][1, 0] < 0 and np.allclose(q[1][2], q[1][0])
    assert np.allclose(q[0][2] - q[0][0], [0.0, 2 * ref.spacing], atol=1e-9)


def test_lawnmower_heading_is_c2_across_joins() -> None:
    ref = MISSIONS["lawnmower"]
    assert isinstance(ref, LawnmowerReference)
    joins = _joins(ref)[1:]
    eps = 1e-9
    lo, hi = ref(joins - eps), ref(joins + eps)
    for k, tol in enumerate((1e-7, 1e-7, 1e-7, 1e-6)):
        assert np.allclose(lo[k], hi[k], rtol=0, atol=tol), k
    hl, hh = heading_from_velocity(*lo[1:]), heading_from_velocity(*hi[1:])
    for a, b in zip(hl, hh):
        assert np.allclose(np.angle(np.exp(1j * (a - b))), 0.0, atol=1e-7)


def _sampled(ref, t: np.ndarray) -> dict[str, np.ndarray]:
    _, q1, q2, q3 = ref(t)
    _, c1, c2 = heading_from_velocity(q1, q2, q3)
    return {"speed": _norm(q1), "accel": _norm(q2), "jerk": _norm(q3), "rate": c1, "racc": np.abs(c2)}


@pytest.mark.parametrize("name", sorted(MISSIONS))
def test_bounds_hold_on_random_times(name: str, rng: np.random.Generator) -> None:
    ref = MISSIONS[name]
    t = np.concatenate([rng.uniform(0.0, 2e3, 50_000), rng.uniform(0.0, 1e6, 50_000)])
    s, b = _sampled(ref, t), ref.bounds()
    assert b.speed_min <= s["speed"].min() and s["speed"].max() <= b.speed_max
    assert s["accel"].max() <= b.accel_max and s["jerk"].max() <= b.jerk_max
    assert b.turn_rate_min <= s["rate"].min() and s["rate"].max() <= b.turn_rate_max
    assert s["racc"].max() <= b.turn_accel_max
    if np.isfinite(b.snap_max):
        assert _norm(ref.snap(t)).max() <= b.snap_max


def test_lawnmower_snap_bound_is_finite_and_close_to_the_turns_peak() -> None:
    # the bound sums the normal and tangential parts' peaks, which sit at different times
    lm = MISSIONS["lawnmower"]
    assert isinstance(lm, LawnmowerReference)
    b = lm.bounds()
    t1 = lm.leg_length / lm.speed
    t = np.linspace(t1, t1 + lm.t90, 200_001)
    peak = float(_norm(lm.snap(t)).max())
    assert np.isfinite(b.snap_max) and peak <= b.snap_max <= 2.0 * peak
    assert 0 <= SMOOTHSTEP_D3_MAX - float(np.abs(SMOOTHSTEP.deriv(3)(np.linspace(0, 1, 100_001))).max()) < 1e-6


def _maximise(f, lo: float, hi: float, n: int = 20_001) -> float:
    grid = np.linspace(lo, hi, n)
    i = int(np.argmax(f(grid)))
    res = minimize_scalar(
        lambda x: -f(np.array(x)),
        bounds=(grid[max(i - 1, 0)], grid[min(i + 1, n - 1)]),
        method="bounded",
        options={"xatol": 1e-12},
    )
    return float(max(-res.fun, f(grid).max()))


@pytest.mark.parametrize("params", [(1.0, 30.0, 0.1), (1.5, 2.0, 0.05), (2.0, 5.0, 0.3), (0.7, 0.0, 0.2)])
def test_sine_bounds_are_exact(params: tuple[float, float, float]) -> None:
    ref = SineReference(*params)
    b, period = ref.bounds(), 2 * np.pi / ref.omega
    for key, val, sign in (
        ("speed", b.speed_max, 1),
        ("speed", b.speed_min, -1),
        ("accel", b.accel_max, 1),
        ("jerk", b.jerk_max, 1),
        ("rate", b.turn_rate_max, 1),
        ("rate", b.turn_rate_min, -1),
        ("racc", b.turn_accel_max, 1),
    ):
        best = sign * _maximise(lambda t, key=key, sign=sign: sign * _sampled(ref, t)[key], 0.0, period)
        assert abs(best - val) <= 1e-9 * max(abs(val), 1e-12), (key, best, val)


def test_circle_and_lawnmower_constants_are_exact(rng: np.random.Generator) -> None:
    ref = MISSIONS["circle"]
    s, b = _sampled(ref, rng.uniform(0, 1e4, 1000)), ref.bounds()
    for key, val in (
        ("speed", b.speed_max),
        ("speed", b.speed_min),
        ("accel", b.accel_max),
        ("jerk", b.jerk_max),
        ("rate", b.turn_rate_max),
        ("rate", b.turn_rate_min),
    ):
        assert np.allclose(s[key], val, rtol=1e-9, atol=0)
    assert np.allclose(s["racc"], 0.0, atol=1e-15)
    assert np.allclose(ref(0.0)[1], [ref.speed, 0.0]) and np.allclose(ref(0.0)[0], [5.0, 7.0 - 40.0])
    lm = MISSIONS["lawnmower"]
    assert isinstance(lm, LawnmowerReference)
    b = lm.bounds()
    t1 = lm.leg_length / lm.speed  # start of the first (left) turn, after the first +x leg
    mid = t1 + 0.5 * lm.t90
    peak2 = t1 + lm.t90 * (0.5 - 0.5 / np.sqrt(5.0))
    got = _sampled(lm, np.array([mid, peak2]))
    assert abs(got["rate"][0] - b.turn_rate_max) < 1e-9 * b.turn_rate_max
    assert abs(got["accel"][0] - b.accel_max) < 1e-9 * b.accel_max
    assert abs(got["racc"][1] - b.turn_accel_max) < 1e-9 * b.turn_accel_max
    assert abs(got["racc"][1] - 0.5 * np.pi * 84 / (5 * np.sqrt(5)) / lm.t90**2) < 1e-12
    assert abs(1 / lm.turn_radius - got["rate"][0] / lm.speed) < 1e-12  # peak curvature = 1/R
    assert 0 <= SMOOTHSTEP_D1_MAX - 35 / 16 < 1e-11 and 0 <= SMOOTHSTEP_D2_MAX - 84 / (5 * np.sqrt(5)) < 1e-10


def test_line_bounds_are_zero() -> None:
    b = MISSIONS["line"].bounds()
    assert b.accel_max == b.jerk_max == b.turn_rate_min == b.turn_rate_max == b.turn_accel_max == 0.0


@pytest.mark.parametrize(
    ("cls", "kwargs", "field"),
    [
        (SineReference, {"speed": -1.0}, "speed"),
        (SineReference, {"amplitude": -2.0}, "amplitude"),
        (SineReference, {"omega": float("nan")}, "omega"),
        (LineReference, {"speed": 0.0}, "speed"),
        (LineReference, {"speed": 1.0, "start": (0.0, np.inf)}, "start"),
        (CircleReference, {"speed": 1.0, "radius": 0.0}, "radius"),
        (LawnmowerReference, {"speed": 1.0, "leg_length": 10.0, "spacing": 5.0, "turn_radius": 3.0}, "spacing"),
        (LawnmowerReference, {"speed": 1.0, "leg_length": -1.0, "spacing": 50.0, "turn_radius": 3.0}, "leg_length"),
    ],
)
def test_invalid_parameters_raise(cls: type, kwargs: dict, field: str) -> None:
    with pytest.raises(ParameterError, match=field):
        cls(**kwargs)


def test_registry_round_trip() -> None:
    assert set(REFERENCES) == {"sine", "line", "circle", "lawnmower"}
    for ref in MISSIONS.values():
        assert reference_from_dict(**ref.to_dict()) == ref
    with pytest.raises(ParameterError, match="kind"):
        reference_from_dict("spiral")
    with pytest.raises(ParameterError, match="circle"):
        reference_from_dict("circle", speed=1.0)
    with pytest.raises(ParameterError, match="t"):
        MISSIONS["line"](np.array([0.0, np.nan]))


def test_heading_from_velocity(rng: np.random.Generator) -> None:
    # a smooth non-mission curve: v(t) = [cos 0.3t + 2, sin 0.7 t], compared with finite differences
    def vel(t: np.ndarray) -> np.ndarray:
        return np.stack([np.cos(0.3 * t) + 2, np.sin(0.7 * t)], -1)

    def acc(t: np.ndarray) -> np.ndarray:
        return np.stack([-0.3 * np.sin(0.3 * t), 0.7 * np.cos(0.7 * t)], -1)

    def jer(t: np.ndarray) -> np.ndarray:
        return np.stack([-0.09 * np.cos(0.3 * t), -0.49 * np.sin(0.7 * t)], -1)

    t = rng.uniform(0, 50, (7, 3))
    chi, c1, c2 = heading_from_velocity(vel(t), acc(t), jer(t))
    assert chi.shape == c1.shape == c2.shape == (7, 3)
    assert np.allclose(chi, np.arctan2(vel(t)[..., 1], vel(t)[..., 0]))
    assert np.allclose(_angle_rate(lambda s: heading_from_velocity(vel(s), acc(s), jer(s))[0], t), c1, atol=1e-9)
    assert np.allclose(_fd(lambda s: heading_from_velocity(vel(s), acc(s), jer(s))[1], t, 1e-3), c2, atol=1e-9)
    with pytest.raises(ParameterError, match="nonzero"):
        heading_from_velocity(np.zeros((2, 2)), np.ones((2, 2)), np.ones((2, 2)))


def test_mission_tube_matches_bounds() -> None:
    ref = MISSIONS["sine-paper"]
    b, tube = ref.bounds(), mission_tube(ref)
    assert tube.speed.tolist() == [[b.speed_min, b.speed_max]] and tube.offset.tolist() == [[0.0, 0.0]]
    assert tube.yaw_rate.tolist() == [[b.turn_rate_min, b.turn_rate_max]]
    assert tube.accel.tolist() == [b.accel_max] and tube.yaw_accel.tolist() == [b.turn_accel_max]


# ---------------------------------------------------------------- blend basis and shaped start


def test_blend_basis_conditions_symbolically() -> None:
    x = sp.symbols("x")
    h0 = sum(sp.Rational(str(c)) * x**k for k, c in enumerate(BLEND_H0.coef))
    h1 = sum(sp.Rational(str(c)) * x**k for k, c in enumerate(BLEND_H1.coef))
    assert sp.expand(h1 - x * (1 - x) ** 4 * (1 + 4 * x)) == 0
    assert (h0.subs(x, 0), sp.diff(h0, x).subs(x, 0), h1.subs(x, 0), sp.diff(h1, x).subs(x, 0)) == (1, 0, 0, 1)
    for k in range(4):
        assert sp.diff(h0, x, k).subs(x, 1) == 0 and sp.diff(h1, x, k).subs(x, 1) == 0
    grid = np.linspace(0, 1, 200_001)
    for k in range(4):
        for poly, sup in ((BLEND_H0, H0_SUP[k]), (BLEND_H1, H1_SUP[k])):
            dense = np.abs(poly.deriv(k)(grid)).max()
            assert dense <= sup <= dense * (1 + 1e-9)


def _triangle_offsets() -> np.ndarray:
    return JacobiTransform(3).to_positions(np.array([[0.0, 10.0], [20.0, 0.0], [0.0, 0.0]]))


def _random_starts(mission, off: np.ndarray, rng: np.random.Generator, s: int) -> np.ndarray:
    _, q1, _, _ = mission(0.0)
    chi0 = np.arctan2(q1[1], q1[0])
    init = np.empty((s, off.shape[0], 6))
    init[..., :2] = off + mission(0.0)[0] + rng.normal(0.0, 8.0, (s, off.shape[0], 2))
    init[..., 2] = chi0 + rng.uniform(-1.0, 1.0, (s, off.shape[0])) + 2 * np.pi * rng.integers(-1, 2, (s, 1))
    init[..., 3] = rng.uniform(0.6, 2.0, (s, off.shape[0]))
    init[..., 4] = rng.uniform(-0.3, 0.3, (s, off.shape[0]))
    init[..., 5] = rng.uniform(-0.1, 0.1, (s, off.shape[0]))
    return init


@pytest.mark.parametrize("name", ["sine-paper", "lawnmower", "circle"])
def test_shaped_start_matches_initial_state_and_mission(name: str, rng: np.random.Generator) -> None:
    mission, off = MISSIONS[name], _triangle_offsets()
    init, current, tb = _random_starts(mission, off, rng, 8), (0.2, -0.1), 60.0
    fleet = shaped_start(mission, off, init, tb, current=current)
    m = fleet.motion(np.zeros(8))
    m_scalar = fleet.motion(0.0)  # a scalar time broadcasts over the batch of 8 starts
    assert m_scalar.p.shape == (8, 3, 2) and m_scalar.r.shape == (8, 3) and np.array_equal(m_scalar.r, m.r)
    psi, u, v = init[..., 2], init[..., 3], init[..., 4]
    vel = np.stack([np.cos(psi) * u - np.sin(psi) * v, np.sin(psi) * u + np.cos(psi) * v], -1) + current
    assert np.allclose(m.p, init[..., :2], rtol=0, atol=1e-12 * np.abs(init[..., :2]).max())
    assert np.allclose(m.v, vel, rtol=0, atol=1e-12 * _norm(vel).max())
    assert np.allclose(wrap_angle(m.psi - psi), 0.0, atol=1e-12)
    assert np.allclose(m.r, init[..., 5], rtol=0, atol=1e-12 * max(1.0, np.abs(m.r).max()))
    plain = FleetReference(mission, off)
    t = np.concatenate([[tb], tb + rng.uniform(0, 1e4, 7)])
    for a, b in zip(fleet.motion(t).__dict__.values(), plain.motion(t).__dict__.values()):
        assert np.array_equal(a, b)
    # the shaped motion is smooth: its derivatives are the finite differences of its values
    ts = np.concatenate([rng.uniform(0.0, tb, 10), [1e-2, tb - 1e-2]])[:, None]  # (12, 1) x batch (8,)
    ms = fleet.motion(ts)
    for f, g in (("p", "v"), ("v", "a"), ("r", "r_dot")):
        fd = _fd(lambda s, f=f: getattr(fleet.motion(s), f), ts, 1e-3)
        assert np.allclose(fd, getattr(ms, g), rtol=0, atol=1e-7), (f, g)
    assert np.allclose(_angle_rate(lambda s: fleet.motion(s).psi, ts), ms.r, rtol=0, atol=1e-7)


def test_motion_shapes_unshaped() -> None:
    mission, off = MISSIONS["sine-paper"], _triangle_offsets()
    fleet = FleetReference(mission, off)
    m0, ms = fleet.motion(3.0), fleet.motion(np.array([1.0, 2.0, 3.0]))
    assert m0.p.shape == (3, 2) and m0.psi.shape == (3,) and ms.p.shape == (3, 3, 2) and ms.r_dot.shape == (3, 3)
    q = mission(3.0)
    chi, c1, c2 = heading_from_velocity(q[1], q[2], q[3])
    assert np.array_equal(m0.p, off + q[0]) and np.array_equal(m0.v, np.broadcast_to(q[1], (3, 2)))
    assert np.allclose(m0.psi, chi) and np.allclose(m0.r, c1) and np.allclose(m0.r_dot, c2)
    assert np.array_equal(ms.p[2], m0.p)


def test_shaped_start_rejects_rest_and_bad_shapes() -> None:
    mission, off = MISSIONS["sine-paper"], _triangle_offsets()
    init = np.zeros((3, 6))
    with pytest.raises(ParameterError, match="at rest"):
        shaped_start(mission, off, init, 50.0)
    with pytest.raises(ParameterError, match="shape"):
        shaped_start(mission, off, np.zeros((2, 6)), 50.0)
    init[:, 3] = 1.0
    with pytest.raises(ParameterError, match="blend_time"):
        shaped_start(mission, off, init, 0.0)


# ---------------------------------------------------------------- tubes


def _check_tube(fleet: FleetReference, tube, t: np.ndarray) -> None:
    """Every quantity sampled at ``t`` (shape (M, S)) lies in its cell of ``tube``."""
    sh = fleet.shaping
    assert sh is not None
    s, n = t.shape[1], fleet.offsets.shape[0]
    k = (tube.speed.shape[0] - 1) // (s * n)
    assert tube.speed.shape[0] == s * n * k + 1
    (_, v, a, _), (d0, _, _) = fleet.kinematics(t)
    m = fleet.motion(t)
    cell = np.minimum((t / (sh.blend_time / k)).astype(int), k - 1)
    rows = (np.arange(s)[None, :, None] * n + np.arange(n)[None, None, :]) * k + cell[..., None]
    rows = np.where((t < sh.blend_time)[..., None], rows, tube.speed.shape[0] - 1)
    for val, iv in ((_norm(v), tube.speed), (d0, tube.offset), (m.r, tube.yaw_rate)):
        assert np.all(iv[rows, 0] <= val) and np.all(val <= iv[rows, 1])
    assert np.all(_norm(a) <= tube.accel[rows]) and np.all(np.abs(m.r_dot) <= tube.yaw_accel[rows])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["sine-paper", "lawnmower", "circle"])
def test_shaped_tube_is_sound(name: str, rng: np.random.Generator) -> None:
    mission = MISSIONS[name]
    n_total = 0
    for off in (_triangle_offsets(), rng.uniform(-30, 30, (4, 2))):
        s = 6
        init = _random_starts(mission, off, rng, s)
        fleet = shaped_start(mission, off, init, rng.uniform(30.0, 120.0), current=(0.1, 0.05))
        tube = shaped_tube(fleet, resolution=5e-3)
        assert fleet.shaping is not None
        tb = fleet.shaping.blend_time
        t = np.concatenate(
            [
                rng.uniform(0, tb, (4000, s)),
                rng.uniform(tb, 5 * tb, (300, s)),
                np.linspace(0, tb, 200)[:, None] + np.zeros(s),
            ]
        )
        _check_tube(fleet, tube, t)
        n_total += t.size * off.shape[0]
    assert n_total >= 100_000


def test_tube_pad_shrinks_with_the_resolution(rng: np.random.Generator) -> None:
    mission = MISSIONS["sine-paper"]
    off = rng.uniform(-30, 30, (6, 2))
    fleet = shaped_start(mission, off, _random_starts(mission, off, rng, 1)[0], 100.0)
    widths = [np.max(shaped_tube(fleet, resolution=r).speed[:-1] @ [-1, 1]) for r in (1e-1, 1e-2, 1e-3)]
    assert widths[0] > widths[1] > widths[2]
    assert widths[2] <= 2 * (1e-3 + TUBE_RTOL * 10)  # pad <= resolution, plus the rounding margin
    tube = fleet_tube(fleet)
    assert np.all(tube.speed[:, 0] > 0) and np.array_equal(tube.speed, shaped_tube(fleet, resolution=1e-3).speed)
    assert shaped_tube(fleet, cells=1000).speed.shape == (6 * 1000 + 1, 2)


def test_unshaped_tube_is_mission_tube_and_vanishing_speed_raises() -> None:
    mission, off = MISSIONS["sine-paper"], _triangle_offsets()
    plain = shaped_tube(FleetReference(mission, off))
    ref = mission_tube(mission)
    assert all(np.array_equal(getattr(plain, f), getattr(ref, f)) for f in ("speed", "offset", "yaw_rate", "accel"))
    line = LineReference(1.0, heading=0.4)
    init = np.zeros((3, 6))
    init[:, :2] = off
    init[:, 2] = 0.4 + np.pi  # moving against the mission velocity: p' = q'(1 - k h1') crosses zero
    init[:, 3] = 2.0
    with pytest.raises(ParameterError, match="bounded away from 0"):
        shaped_tube(shaped_start(line, off, init, 20.0))
    with pytest.raises(ParameterError, match="cells"):
        shaped_tube(
            shaped_start(mission, off, _random_starts(mission, off, np.random.default_rng(1), 1)[0], 50.0), cells=0
        )


def test_a_shaped_start_at_rest_is_refused_in_plain_words():
    """Vehicles at rest have no course: the refusal gives the speed needed and the one found in m/s, with no
    Python names or reprs in it."""
    from auv_hinf.mission.paths import LineReference

    offsets = np.array([[0.0, 0.0], [0.0, 4.0]])
    at_rest = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 4.0, 0.0, 0.0, 0.0, 0.0]])
    with pytest.raises(ParameterError) as err:
        shaped_start(LineReference(speed=0.4), offsets, at_rest, 10.0)
    text = str(err.value)
    assert "at least 0.0004 m/s" in text and "got 0 m/s" in text
    assert "np." not in text and "START_SPEED_RTOL" not in text
