"""Campaigns of the guidance cascade: the fleet on sampled plants of the box and in sampled currents.

Every run reports its worst along-track, cross-track and heading errors, its commanded thrust
and rudder against the limits, how long it saturated and how close two vehicles came, and
whether the guidance certificate (:mod:`auv_hinf.certificate.parts.guidance`) covers it and it
stayed within the certified bounds; the summary takes the worst of each over the runs.

Sampling follows the formation law's campaigns (:mod:`auv_hinf.campaign.starts`): every
:data:`~auv_hinf.campaign.starts.CORNER_PERIOD`-th run is a vertex of the ``[uncertainty]`` box
until the vertices are used, in a current of the full ``[disturbance] current_speed`` in a
random direction; the other runs are uniform in the box with a current uniform in the disc.
Without a declared current speed every run is in the ``[simulation] current``.
Run ``i`` draws from ``SeedSequence(seed, spawn_key=(i,))`` alone, so a run is the same in any
campaign; so do its measurement errors within ``[implementation.noise]`` (with ``[simulation]
noise_pattern = "mixed"``, run ``i`` takes ``NOISE_PATTERNS[i mod 5]``). Every vehicle starts on
its slot, heading into the run's current. The rudder's
coefficients (``[actuators] rudder_sway`` and ``rudder_yaw``) are not in the box and are exact.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from auv_hinf._typing import NOISE_PATTERNS
from auv_hinf.campaign.setup import COEFFICIENTS, box_multipliers, implementation_summary, scaled_plant
from auv_hinf.campaign.starts import declared_rows, sample_plant_and_current, vertex_index
from auv_hinf.cascade.certificate import CascadeCertificate
from auv_hinf.certificate.document import json_safe
from auv_hinf.certificate.parts.guidance import fleet_refusal, guidance_certificate, run_coverage
from auv_hinf.certificate.run_plan import guidance_run
from auv_hinf.config.settings import FormationConfig
from auv_hinf.exceptions import ConfigError, Interrupted, ParameterError

#: Units of the run table's columns (the multipliers are relative and have none).
COLUMN_UNITS: dict[str, str] = {
    "current_x": "m/s",
    "current_y": "m/s",
    "along_track": "m",
    "cross_track": "m",
    "heading": "rad",
    "cross_track_final": "m",
    "force_x": "N",
    "rudder": "rad",
    "saturation_fraction": "1",
    "min_separation": "m",
    "peak_sway_speed": "m/s",
    "covered": "bool",
    "within_bounds": "bool",
    "stayed_in_envelope": "bool",
}
#: Units of the summary's figures (the text of ``campaign``).
SUMMARY_UNITS: dict[str, Any] = {
    "worst_errors": {"along_track": "m", "cross_track": "m", "heading": "rad", "cross_track_final": "m"},
    "worst_commanded_peak": {"force_x": "N", "rudder": "rad"},
    "limits": {"force_x": "N", "rudder": "rad"},
    "min_separation": "m",
    "required_min_separation": "m",
    "horizon": "s",
    "current_speed": "m/s",
    "certified_errors": {"along_track": "m", "cross_track": "m", "heading": "rad"},
    "worst_ratio": "of the certified bound",
    **dict.fromkeys(
        (
            "runs",
            "runs_asked",
            "vertex_runs",
            "saturated_runs",
            "runs_below_min_separation",
            "covered_runs",
            "runs_outside_bounds",
            "counts",
        ),
        "runs",
    ),
    "vertices": "vertices",
    "implementation": {
        "sample_time": "s",
        "delay": "s",
        "noise": {"position": "m", "velocity": "m/s", "heading": "rad", "yaw_rate": "rad/s"},
    },
}


@dataclass(frozen=True)
class GuidanceCampaign:
    """The runs of a guidance campaign.

    Attributes
    ----------
    config : FormationConfig
        The configuration the runs sample.
    table : pandas.DataFrame
        One row per finished run (columns: ``run``, ``vertex`` (-1 for an interior run), the
        nine multipliers, :data:`COLUMN_UNITS`).
    runs : int
        Runs asked for (the table may hold fewer after an interruption).
    seed : int
        The campaign's seed.
    horizon : float
        Length of every run (s).
    """

    config: FormationConfig
    table: pd.DataFrame
    runs: int
    seed: int
    horizon: float

    def summary(self) -> dict[str, Any]:
        """The worst figures over the runs, with the limits and the required separation (SI units)."""
        cfg, t = self.config, self.table
        act = cfg.actuators
        limits = {"force_x": float(getattr(act, "tau_x", math.inf)), "rudder": float(getattr(act, "rudder_max", 0.0))}
        vertices = 2 ** len(declared_rows(box_multipliers(cfg)))
        saturated = int(np.sum(t["saturation_fraction"] > 0.0))
        close = int(np.sum(t["min_separation"] < cfg.min_separation))
        done = len(t)
        summary = guidance_certificate(cfg)
        cert = summary.certificate
        certified = cert is not None and not fleet_refusal(cfg, summary)  # the cascade, and the separation it keeps
        covered = int(np.sum(t["covered"])) if done else 0
        outside = int(np.sum(~t["within_bounds"])) if done else 0
        inside = t["covered"].astype(bool) & t["within_bounds"].astype(bool)
        passed = inside & (t["saturation_fraction"] <= 0.0) & (t["min_separation"] >= cfg.min_separation)
        return {
            "config": cfg.name,
            "law": "guidance",
            "kind": cfg.guidance.kind if cfg.guidance else None,
            "runs": done,
            "runs_asked": self.runs,
            "seed": self.seed,
            "horizon": self.horizon,
            "vertex_runs": int(np.sum(t["vertex"] >= 0)),
            "vertices": vertices,
            "current_speed": float(cfg.disturbance.current_speed or 0.0),
            "implementation": implementation_summary(
                cfg.implementation, cfg.simulation.noise_pattern, not cfg.implementation.noise.exact
            ),
            "worst_errors": {
                "along_track": _worst(t, "along_track"),
                "cross_track": _worst(t, "cross_track"),
                "heading": _worst(t, "heading"),
                "cross_track_final": _worst(t, "cross_track_final"),
            },
            "worst_commanded_peak": {"force_x": _worst(t, "force_x"), "rudder": _worst(t, "rudder")},
            "limits": limits,
            "saturated_runs": saturated,
            "min_separation": float(t["min_separation"].min()) if done else None,
            "required_min_separation": cfg.min_separation,
            "runs_below_min_separation": close,
            "certified": certified,
            "certified_errors": None if not certified or cert is None else cert.error_bounds,
            "covered_runs": covered,
            "certificate_covers_runs": done > 0 and covered == done,
            "runs_outside_bounds": outside,
            "counts": {
                "runs": done,
                "certificate_applies": covered,
                "not_applicable": done - covered,
                "inside_bounds": int(inside.sum()),
                "outside_bounds": outside,
                "saturated": saturated,
                "below_min_separation": close,
                "passed": int(passed.sum()),
            },
            "worst_ratio": worst_ratios(t, cert if certified else None),
            # every run passed: covered by the certificate and inside its bounds, unsaturated, separated
            "ok": done > 0 and bool(passed.all()),
            "notes": [
                "every run is checked against the guidance certificate when it covers the run (plant in the box, "
                "current within the bound, certified start); runs_outside_bounds counts covered runs whose measured "
                "errors or commands exceeded their certified bounds (a soundness failure: it must be 0)",
                "the rudder coefficients are exact; the box scales the nine hull coefficients",
            ],
        }

    def write(self, out: Path) -> dict[str, Any]:
        """Write ``runs.parquet`` and ``summary.json`` to ``out`` (created); return the summary.

        Parameters
        ----------
        out : pathlib.Path
            Output directory.
        """
        out.mkdir(parents=True, exist_ok=True)
        summary = self.summary()
        self.table.to_parquet(out / "runs.parquet", index=False)
        (out / "summary.json").write_text(json.dumps(json_safe(summary), indent=2))
        return summary


#: The measured columns a campaign holds against the certificate, and the certified figure each is held to.
RATIO_COLUMNS = ("along_track", "cross_track", "heading", "force_x", "rudder")


def worst_ratios(t: pd.DataFrame, cert: CascadeCertificate | None) -> dict[str, float | None]:
    """The largest measured / certified value of each of :data:`RATIO_COLUMNS` over the covered runs of ``t``.

    ``None`` for every column when no certificate holds or no run is covered. Above 1 only if a covered
    run left its bounds (``runs_outside_bounds`` counts those runs).

    Parameters
    ----------
    t : pandas.DataFrame
        The campaign's run table.
    cert : CascadeCertificate or None
        The guidance certificate that holds (``None``: none does).
    """
    rows = t[t["covered"].astype(bool)]
    if cert is None or cert.error_bounds is None or cert.actuation is None or not len(rows):
        return dict.fromkeys(RATIO_COLUMNS)
    certified = {**cert.error_bounds, "force_x": cert.actuation.thrust, "rudder": cert.actuation.rudder}
    return {k: float(rows[k].max() / certified[k]) if certified[k] > 0.0 else None for k in RATIO_COLUMNS}


def _worst(t: pd.DataFrame, column: str) -> float | None:
    return float(t[column].max()) if len(t) else None


def run_inputs(cfg: FormationConfig, seed: int, index: int) -> tuple[int, np.ndarray, np.ndarray]:
    """Vertex index (-1: interior), multipliers (9,) and current (2,, m/s) of run ``index``.

    Without a ``[disturbance] current_speed`` every run is in the ``[simulation] current``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (its box and current speed).
    seed : int
        The campaign's seed.
    index : int
        Run index.
    """
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))
    box = box_multipliers(cfg)
    declared = declared_rows(box)
    speed = cfg.disturbance.current_speed
    corner = vertex_index(index, 2 ** len(declared)) if declared or speed else None
    mult, current = sample_plant_and_current(rng, box, declared, speed or 0.0, corner)
    if speed is None:  # no [disturbance] current: every run in the [simulation] current
        current = np.asarray(cfg.simulation.current, dtype=float)
    return (-1 if corner is None else corner), mult, current


def run_guidance_campaign(
    cfg: FormationConfig, runs: int, seed: int = 0, horizon: float | None = None, progress: bool = False
) -> GuidanceCampaign:
    """Run ``runs`` simulations of the cascade on sampled plants and currents (see the module docstring).

    Parameters
    ----------
    cfg : FormationConfig
        A ``[guidance]`` configuration.
    runs : int
        Number of runs (>= 1).
    seed : int
        Seed (>= 0).
    horizon : float, optional
        Length of every run (s); default ``[simulation] horizon``.
    progress : bool
        Show a tqdm progress bar (stderr) over the runs.

    Raises
    ------
    ConfigError
        If the configuration has no ``[guidance]``.
    ParameterError
        For a bad number of runs, seed or horizon.
    Interrupted
        On Ctrl-C; its ``partial`` is the campaign of the finished runs (``None`` when none).
    """
    if cfg.guidance is None:
        raise ConfigError("a guidance campaign needs a [guidance] table")
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise ParameterError(f"runs must be an integer >= 1, got {runs!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParameterError(f"seed must be an integer >= 0, got {seed!r}")
    hor = float(cfg.simulation.horizon if horizon is None else horizon)
    if not (math.isfinite(hor) and hor > 0.0):
        raise ParameterError(f"horizon must be > 0 s, got {horizon!r}")
    from tqdm import tqdm

    rows: list[dict[str, Any]] = []
    try:
        for i in tqdm(range(runs), unit="run", desc="guidance campaign", disable=not progress):
            rows.append(_run_row(cfg, seed, i, hor))
    except KeyboardInterrupt:
        partial = GuidanceCampaign(cfg, pd.DataFrame(rows), runs, seed, hor) if rows else None
        raise Interrupted(len(rows), runs, partial) from None
    return GuidanceCampaign(cfg, pd.DataFrame(rows), runs, seed, hor)


def _run_row(cfg: FormationConfig, seed: int, index: int, horizon: float) -> dict[str, Any]:
    corner, mult, current = run_inputs(cfg, seed, index)
    plant = scaled_plant(cfg.vehicle, mult)
    flow = (float(current[0]), float(current[1]))
    pattern = cfg.simulation.noise_pattern
    noise = (
        int(np.random.SeedSequence(seed, spawn_key=(index,)).generate_state(1)[0]),
        NOISE_PATTERNS[index % len(NOISE_PATTERNS)] if pattern == "mixed" else pattern,
    )
    rep = guidance_run(cfg, horizon, plant=plant, current=flow, noise=noise).report(envelope=cfg.envelope)
    noisy = not cfg.implementation.noise.exact
    coverage = run_coverage(cfg, rep, np.asarray(mult, dtype=float), flow, cfg.simulation.initial)
    errors, final, peak = rep["measured_errors"], rep["final_errors"], rep["commanded_peak"]
    return {
        "run": index,
        "vertex": corner,
        **{k: float(m) for k, m in zip(COEFFICIENTS, mult, strict=True)},
        "current_x": float(current[0]),
        "current_y": float(current[1]),
        "along_track": errors["along_track"],
        "cross_track": errors["cross_track"],
        "heading": errors["heading"],
        "cross_track_final": final["cross_track"],
        "force_x": peak["force_x"],
        "rudder": peak["rudder"],
        "saturation_fraction": rep["saturation_fraction"],
        "min_separation": rep["min_separation"],
        "peak_sway_speed": rep["peak_sway_speed"],
        "covered": bool(coverage["certificate_covers_run"]),
        "within_bounds": coverage["within_certified_bounds"] is not False,
        "stayed_in_envelope": bool(rep["stayed_in_envelope"]),
        # the run's own measurement errors: their seed and pattern reproduce them (empty without noise)
        "implementation_seed": noise[0] if noisy else -1,
        "noise_pattern": noise[1] if noisy else "",
    }


__all__ = [
    "COLUMN_UNITS",
    "SUMMARY_UNITS",
    "GuidanceCampaign",
    "run_guidance_campaign",
    "run_inputs",
]
