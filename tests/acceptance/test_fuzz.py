"""Fuzzing the CLI and the configuration API: every input gets an exit code and no traceback.

Every ``certified`` verdict is re-checked here with an independent small-gain computation
(lambda and sigma by brute-force vertex enumeration), and every alpha printed by
``design`` or ``certify`` is compared with its closed form.
"""

from __future__ import annotations

import itertools
import json
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from auv_hinf.cli.main import main
from auv_hinf.config.settings import FormationConfig, config_from_dict
from auv_hinf.exceptions import ConfigError, EnvelopeError
from auv_hinf.models.envelope import Envelope
from tests.helpers import to_toml


def fuzz(examples: int) -> settings:
    """Deterministic, deadline-free settings (examples are cheap but some call solvers)."""
    return settings(
        max_examples=examples, deadline=None, derandomize=True, database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture],
    )  # fmt: skip


NAMES = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")
PAPER = dict(zip(NAMES, (200.0, 250.0, 80.0, 70.0, 100.0, 100.0, 200.0, 50.0, 100.0)))
SQRT_HALF = 1 / math.sqrt(2)


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(argv)
    out, err = capsys.readouterr()
    assert code in (0, 1, 2), (argv, code)
    assert "Traceback" not in err and "Traceback" not in out
    assert all(line.startswith("auv-hinf: ") for line in err.splitlines()), err
    return code, out, err


# --- closed forms and an independent small-gain check -------------------------------------------


def alpha_closed_forms(lam: float, gamma: float) -> dict[str, float | None]:
    """Stabilising root of c a^2 + 2 lam a + 1 = 0 (c = 1/gamma^2 - 2), the paper's eq. (32), the minimal gain."""
    c = 1 / gamma**2 - 2
    disc = lam * lam - c
    real = lam < 0 and gamma >= 1 / math.sqrt(lam * lam + 2) * (1 - 1e-12)
    s = math.sqrt(max(disc, 0.0))
    stab = 1 / (-lam + s) if real else None
    paper = None
    if real and abs(c) > 1e-6:
        paper = 1 / (-lam + s) if c < 0 else (-lam + s) / c
    return {"stabilizing": stab, "paper": paper, "minimal": max(0.0, 1 / gamma + lam)}


def check_alphas(alpha: dict[str, Any], lam: float, gamma: float) -> None:
    """Compare with the closed forms. Eq. (32) as printed, ``(-lam - s)/c``, cancels when
    ``|lam| >> 1``; its round-off, about ``eps lam^2 / |c|`` relative, is allowed for ``paper``."""
    c = abs(1 / gamma**2 - 2)
    for key, ref in alpha_closed_forms(lam, gamma).items():
        got = alpha.get(key)
        if got is None or ref is None:
            continue
        rel = 1e-7 + (4e-16 * lam * lam / c if key == "paper" else 0.0)
        assert got == pytest.approx(ref, rel=rel, abs=1e-12), (key, lam, gamma)


def brute_force_lambda_sigma(
    p: dict[str, float], env: dict[str, list[float]], lam: float | None
) -> tuple[float, float]:
    """lambda (most negative diagonal over the envelope) and sigma = max ||B - lam I|| over all 8 vertices."""

    def abs_box(lo: float, hi: float) -> tuple[float, float]:
        return (0.0, max(-lo, hi)) if lo <= 0 <= hi else (min(abs(lo), abs(hi)), max(abs(lo), abs(hi)))

    ua, va = abs_box(*env["u"]), abs_box(*env["v"])
    if lam is None:
        lam = min(
            -(p["d11_lin"] + p["d11_quad"] * ua[1]) / p["m11"], -(p["d22_lin"] + p["d22_quad"] * va[1]) / p["m22"]
        )
    sigma = 0.0
    for a, b, r in itertools.product(ua, va, env["r"]):
        d11, d22 = p["d11_lin"] + p["d11_quad"] * a, p["d22_lin"] + p["d22_quad"] * b
        k = p["m22"] - p["m11"]
        blk = np.array([[-d11 / p["m11"] - lam, k * r / p["m11"]], [k * r / p["m22"], -d22 / p["m22"] - lam]])
        sigma = max(sigma, float(np.linalg.norm(blk, 2)))
    return lam, sigma


# --- design ----------------------------------------------------------------------------------------

lams = st.one_of(
    st.floats(-20, -1e-6),
    st.floats(-1e-2, -1e-300),  # lambda near 0-
    st.sampled_from([-1.2, -2.1, -1e-3, 0.0, 1.0, -1e6]),
)


@st.composite
def design_args(draw: st.DrawFn) -> tuple[float, float]:
    lam = draw(lams)
    gmin = 1 / math.sqrt(lam * lam + 2)
    gamma = draw(
        st.one_of(
            st.floats(1e-3, 1e3),
            st.floats(-1e-9, 1e-9).map(lambda e: SQRT_HALF * (1 + e)),  # gamma ~ 1/sqrt2
            st.floats(-1e-9, 1e-6).map(lambda e: gmin * (1 + e)),  # gamma ~ 1/sqrt(lam^2 + 2)
            st.sampled_from([SQRT_HALF, gmin, 0.0, -1.0, 1e8]),
        )
    )
    return lam, gamma


@pytest.mark.slow
@given(args=design_args(), n=st.sampled_from(["2", "2", "3", "1", "x"]))
@fuzz(20)
def test_design_fuzz(args: tuple[float, float], n: str, capsys: pytest.CaptureFixture[str]) -> None:
    lam, gamma = args
    code, out, _ = run(["design", "--lam", repr(lam), "--gamma", repr(gamma), "--n", n, "--json"], capsys)
    event(f"design exit {code}")
    if n in ("1", "x") or gamma <= 0 or lam >= 0:
        assert code == 2
    if code in (0, 1) and out:
        data = json.loads(out)
        check_alphas(data["alpha"], data["lambda"], data["gamma"])


@given(words=st.lists(st.sampled_from(["--lam", "--gamma", "--n", "--k1", "--json", "-1e-3", "1", "nan", "-inf",
                                       "1e999", "--", "-", "design", "x"]), max_size=8))  # fmt: skip
@fuzz(40)
def test_design_argv_fuzz(words: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    run(["design", *words], capsys)


# --- certify on random configuration files ---------------------------------------------------------

pos = st.floats(1e-2, 1e4)
interval = st.tuples(st.floats(-4, 4), st.floats(0, 4)).map(lambda t: [t[0], t[0] + t[1]])
junk = st.sampled_from(["200", math.nan, math.inf, -1.0, 0, True, [1, 2], {"a": 1}, 1e300, 1e-300])


@st.composite
def config_dicts(draw: st.DrawFn) -> dict[str, Any]:
    vehicle = {"preset": "paper2011"} if draw(st.booleans()) else {k: draw(pos) for k in NAMES}
    if "m11" in vehicle:
        for k in NAMES[3:]:
            vehicle[k] = draw(st.one_of(st.just(0.0), st.floats(0, 1e3)))
    design: dict[str, Any] = {"method": draw(st.sampled_from(["paper", "stabilizing", "minimal"]))}
    if draw(st.booleans()):
        design["gamma"] = draw(st.one_of(st.floats(1e-2, 10), st.just(SQRT_HALF)))
    if draw(st.booleans()):
        design["lambda"] = draw(st.one_of(st.floats(-5, -1e-6), st.just(-1e-3)))
    data: dict[str, Any] = {
        "vehicle": vehicle,
        "formation": {"n": draw(st.integers(2, 4)), "polygon_radius": draw(st.floats(1, 50))},
        "envelope": {"u": draw(interval), "v": draw(interval), "r": draw(interval)},
        "design": design,
    }
    for _ in range(draw(st.integers(0, 2))):  # corrupt a few entries
        table = draw(st.sampled_from(sorted(data)))
        key = draw(st.sampled_from([*data[table], "gama", "uu", "methd", "extra"]))
        data[table][key] = draw(junk)
    if draw(st.integers(0, 9)) == 0:
        data[draw(st.sampled_from(["controller", "name", "simulation"]))] = draw(junk)
    return data


@pytest.mark.slow
@given(data=config_dicts())
@fuzz(30)
def test_certify_fuzz(data: dict[str, Any], tmp_path_factory: pytest.TempPathFactory,
                      capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    f = tmp_path_factory.mktemp("cfg") / "fuzz.toml"
    f.write_text(to_toml(data))
    code, out, err = run(["certify", "--config", str(f), "--json"], capsys)
    event(f"certify exit {code}")
    if code == 2:  # bad input: one line on stderr, and the same answer as one JSON object on stdout
        assert err and json.loads(out)["exit_code"] == 2
        return
    if not out:  # a solver/internal failure reported on stderr
        assert err
        return
    cert = json.loads(out)
    if "certified" not in cert:  # a failure before the report, as one JSON object
        assert cert["ok"] is False and err
        return
    check_alphas(cert["alpha"], cert["lambda"], cert["gamma"])
    if code == 0:
        assert cert["certified"] is True
        params = {k: float(v) for k, v in cert["vehicle"].items() if k in NAMES}
        lam, sigma = brute_force_lambda_sigma(params, cert["envelope"], data["design"].get("lambda"))
        assert cert["lambda"] == pytest.approx(lam, rel=1e-12, abs=1e-300)
        assert cert["alpha"]["used"] - lam - sigma > 0  # the small-gain condition, recomputed
    else:
        assert cert["certified"] is False and err.startswith("auv-hinf: not certified: ")


# --- simulate: cheap runs through [simulation].horizon ----------------------------------------------


@pytest.mark.slow
@given(
    horizon=st.one_of(st.floats(0.5, 3), st.sampled_from([0.0, -1.0, math.nan])),
    n=st.integers(2, 3),
    current=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
    method=st.sampled_from(["paper", "stabilizing", "minimal"]),
    gamma=st.one_of(st.none(), st.floats(0.05, 5)),
    limit=st.one_of(st.none(), st.just([500.0, 500.0, 200.0]), st.just([-1.0, 1.0, 1.0])),
)
@fuzz(8)
def test_simulate_fuzz(horizon: float, n: int, current: tuple[float, float], method: str, gamma: float | None,
                       limit: list[float] | None, tmp_path_factory: pytest.TempPathFactory,
                       capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    sim: dict[str, Any] = {"horizon": horizon, "current": list(current)}
    design: dict[str, Any] = {"method": method} if gamma is None else {"method": method, "gamma": gamma}
    data = {"formation": {"n": n, "polygon_radius": 10.0}, "design": design, "simulation": sim}
    if limit is not None:
        data["actuators"] = dict(zip(("tau_x", "tau_y", "tau_psi"), limit))
    f = tmp_path_factory.mktemp("sim") / "fuzz.toml"
    f.write_text(to_toml(data))
    code, out, _ = run(["simulate", "--config", str(f), "--json"], capsys)
    event(f"simulate exit {code}")
    if not (horizon > 0) or (limit is not None and limit[0] < 0):
        assert code == 2
    if code == 0:
        assert isinstance(json.loads(out), dict)


# --- the Python API ----------------------------------------------------------------------------------

toml_like = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10, 10), st.floats(allow_nan=True), st.text(max_size=5)),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=4)),
    max_leaves=12,
)
table_names = st.sampled_from(["vehicle", "formation", "envelope", "design", "reference", "simulation",
                               "uncertainty", "disturbance", "other"])  # fmt: skip
key_names = st.sampled_from(["preset", "n", "shape", "offsets", "polygon_radius", "jacobi", "u", "v", "r", "psi",
                             "method", "gamma", "lambda", "k1", "kind", "speed", "radius", "horizon", "initial",
                             "current", "m11", "current_speed", "plant"])  # fmt: skip


@given(data=st.dictionaries(table_names, st.one_of(st.dictionaries(key_names, toml_like, max_size=4), toml_like),
                            max_size=4))  # fmt: skip
@pytest.mark.slow
@fuzz(150)
def test_config_from_dict_fuzz(data: dict[str, Any]) -> None:
    try:
        cfg = config_from_dict(data)
    except ConfigError as exc:
        assert str(exc) and all(line.strip() for line in str(exc).splitlines())
        return
    assert isinstance(cfg, FormationConfig)
    assert config_from_dict(cfg.to_toml_dict()) == cfg


@given(pairs=st.lists(st.one_of(st.tuples(st.floats(), st.floats()), toml_like), min_size=3, max_size=4))
@fuzz(100)
def test_envelope_fuzz(pairs: list[Any]) -> None:
    try:
        env = Envelope(*pairs)
    except EnvelopeError:
        return
    for lo, hi in (env.u, env.v, env.r, env.psi):
        assert math.isfinite(lo) and math.isfinite(hi) and lo <= hi
    assert env.psi[1] - env.psi[0] <= 2 * math.pi
