"""Shared helpers of the benchmarks: timing, tables, fleets and the two closed-loop paths.

Import only after ``run_all`` has pinned the BLAS threads (it sets the environment before
numpy is first imported).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

import auv_hinf.simulation.engine as simulation
from auv_hinf.campaign.runs import initial_state, sample_run
from auv_hinf.campaign.setup import CampaignSetup, prepare
from auv_hinf.config.presets import annotated_toml, preset_config
from auv_hinf.config.settings import FormationConfig, config_from_dict
from auv_hinf.law.formation_law import FormationController
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.models.jacobi import JacobiTransform
from auv_hinf.models.vehicle import ground_velocity, rhs
from auv_hinf.numerics.integrators import ATOL, RTOL
from auv_hinf.simulation.engine import simulate
from auv_hinf.simulation.results import SimulationResult, build_result
from auv_hinf.simulation.scenario import Scenario

#: The paper's horizon (s) and the product's default accuracy.
HORIZON = 300.0
DEFAULT_TOL = (RTOL, ATOL)
#: Tolerance of the tight reference solutions.
TIGHT = 1e-11
#: Repeats of every timing (the median is reported).
REPEATS = 3


def timed(fn: Callable[[], Any], repeat: int = REPEATS) -> tuple[float, Any]:
    """Median wall time (s) of ``repeat`` calls and the last result."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def median_seconds(fn: Callable[[], Any], repeat: int = REPEATS) -> float:
    """Median wall time (s) of ``repeat`` calls of ``fn`` (:func:`timed` without the result)."""
    return timed(fn, repeat)[0]


def cli_certify_seconds(doc: dict[str, Any], repeat: int = REPEATS) -> float:
    """Median wall time (s) of ``auv-hinf certify --config FILE --json`` on ``doc`` as TOML, in fresh processes."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "case.toml"
        path.write_text(annotated_toml(config_from_dict(doc)), encoding="utf-8")
        cmd = [sys.executable, "-m", "auv_hinf.cli.main", "certify", "--config", str(path), "--json"]
        return median_seconds(lambda: subprocess.run(cmd, capture_output=True, check=False), repeat)


def table(title: str, header: list[str], rows: list[list[str]], note: str = "") -> str:
    """A Markdown table with a ``###`` title and an optional note below."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(header, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    body = ["| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |" for r in rows]
    text = "\n".join([f"### {title}", "", line, sep, *body, ""])
    return text + (f"\n{note}\n" if note else "")


def fleet_config(n: int) -> FormationConfig:
    """``paper-triangle`` for N = 3, else a regular polygon of radius 2N m on the sine mission."""
    if n == 3:
        return preset_config("paper-triangle")
    return config_from_dict({"name": f"polygon-{n}", "formation": {"n": n, "polygon_radius": 2.0 * n}})


@dataclass
class Fleet:
    """A certified fleet and one start inside its certified region (run 0 of a campaign)."""

    setup: CampaignSetup
    initial: np.ndarray

    def scenario(self, horizon: float = HORIZON, samples: int | None = None, idx: np.ndarray | None = None) -> Scenario:
        """The run (or its vehicles ``idx``: the fleet is decoupled, so a subset is exact)."""
        s = self.setup
        ref, init = s.reference, self.initial
        if idx is not None:
            ref, init = FleetReference(ref.mission, ref.offsets[idx]), init[idx]
        n_samples = samples if samples is not None else round(horizon / 0.1) + 1
        return Scenario(
            law=s.law,
            reference=ref,
            plant=s.nominal,
            initial=init,
            horizon=horizon,
            envelope=s.envelope,
            samples=n_samples,
            name=s.name,
        )


def fleet(n: int, seed: int = 0) -> Fleet:
    """Gains, certificate and a sampled start of :func:`fleet_config` ``(n)``."""
    setup, _ = prepare(fleet_config(n), seed=seed)
    return Fleet(setup, initial_state(setup, sample_run(setup, 0)))


def probe(n: int) -> np.ndarray:
    """Up to 8 vehicle indices spread over the fleet, for the tight reference."""
    return np.unique(np.linspace(0, n - 1, min(n, 8)).astype(int))


class RhsCounter:
    """Counts closed-loop rhs evaluations of the new path (wraps ``simulation.fleet_derivative``)."""

    def __init__(self) -> None:
        self.calls = 0
        self._orig = simulation.fleet_derivative

    def __enter__(self) -> RhsCounter:
        def counted(*args: Any) -> Any:
            self.calls += 1
            return self._orig(*args)

        simulation.fleet_derivative = counted  # type: ignore[assignment]
        return self

    def __exit__(self, *exc: object) -> None:
        simulation.fleet_derivative = self._orig  # type: ignore[assignment]


def new_path(scn: Scenario, rtol: float = RTOL, atol: float = ATOL) -> tuple[SimulationResult, int]:
    """The product: O(N) per-vehicle law, vectorised DOPRI, post-processing; with its rhs count."""
    with RhsCounter() as c:
        res = simulate(scn, rtol=rtol, atol=atol)
    return res, c.calls


def tight_reference(scn: Scenario) -> SimulationResult:
    """The same law integrated by scipy RK45 at rtol = atol = :data:`TIGHT` (cheaper per step for few vehicles)."""
    return simulate(scn, method="rk45", rtol=TIGHT, atol=TIGHT)


def old_path(scn: Scenario, rtol: float = RTOL, atol: float = ATOL) -> tuple[SimulationResult, int]:
    """The old path: dense Jacobi law (``FormationController``, O(N^2)), scipy RK45, same post-processing.

    No envelope event (the new path also locates the first exit).
    """
    law = scn.law
    ctrl = FormationController(
        params=law.params,
        transform=JacobiTransform(scn.n, "paper"),
        reference=scn.reference,
        gains=law.gains,
    )
    plant, cur = scn.plant, np.asarray(scn.current)

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        s = y.reshape(-1, 6)
        tau, _ = ctrl.forces(t, s, ground_velocity(s, cur))
        d = rhs(plant, s, tau)
        d[:, 0:2] += cur
        return d.ravel()

    sol = solve_ivp(fun, (0.0, scn.horizon), scn.initial.ravel(), method="RK45", t_eval=scn.times, rtol=rtol, atol=atol)
    states = sol.y.T.reshape(scn.times.size, scn.n, 6)
    return build_result(scn, sol.t, states, None, int(sol.nfev) // 6), int(sol.nfev)


def position_error(res: SimulationResult, ref: SimulationResult, idx: np.ndarray | None = None) -> float:
    """Max over samples and probed vehicles of ``||p - p_ref||`` (m)."""
    p = res.states[..., 0:2] if idx is None else res.states[:, idx, 0:2]
    return float(np.linalg.norm(p - ref.states[..., 0:2], axis=-1).max())
