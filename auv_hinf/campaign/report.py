"""Campaign outputs: the verdict, ``summary.json``, ``runs.parquet`` and the histograms.

A run *passes* when a certificate applies to it and every measured error stayed within its
certified bound, the velocities in the envelope and the peak commanded force within the
certificate's thrust bound; or, when no certificate applies, when it merely stayed in the
envelope. The robust certificate applies to every run when a box or a current is declared and
it covers them; otherwise the nominal one applies to the runs with the nominal plant and no
current.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from auv_hinf.actuation.limits import CHANNELS
from auv_hinf.campaign.runs import ERROR_KINDS, FORCE_COLUMNS
from auv_hinf.campaign.setup import COEFFICIENTS, implementation_summary, nominal_certificate
from auv_hinf.certificate.document import json_safe
from auv_hinf.mission.margins import ERROR_UNITS

if TYPE_CHECKING:
    import pandas as pd

    from auv_hinf.campaign.runner import Campaign

#: Units of the error kinds of :data:`~auv_hinf.campaign.runs.ERROR_KINDS`.
UNITS = ERROR_UNITS
#: Units of the summary's numbers in the text of ``auv-hinf campaign`` (see ``REPORT_UNITS`` of
#: :mod:`auv_hinf.certificate.run_plan` for the forms): counts of runs, the fraction of the covered runs inside
#: their bounds, the worst measured / certified ratio, the throughput.
SUMMARY_UNITS: dict[str, Any] = {
    "runs": "runs",
    "runs_requested": "runs",
    "n": "vehicles",
    "horizon": "s",
    "counts": "runs",
    "fraction_inside": "of the covered runs",
    "worst_ratio": "of the certified bound as checked (widened by the integrator's slack)",
    "worst_tail_position_ratio": "of the certified bound as checked",
    "throughput": {
        "runs_per_second": "runs/s",
        "vehicle_seconds_per_wall_second": "vehicle-s/s",
        "wall_time": "s",
        "setup_time": "s",
    },
}
#: Note added to the summary when some runs are outside the nominal certificate's scope.
ROBUST_NOTE = (
    "runs with a perturbed plant or a current have inside_bounds = NA: the robust certificate "
    "does not cover the declared box and current, and the nominal one assumes a known plant, no current"
)


#: Note added to the summary when a sampled implementation's runs are covered by no certificate.
SAMPLED_NOTE = (
    "the runs of the sampled implementation have inside_bounds = NA: the continuous certificates do not cover "
    "a sampled, delayed, noisy law, and the composed certificate does not cover it"
)


def _composition(s: Any, k: int) -> str:
    """The campaign's sample composition, in words."""
    checked = s.checked
    if checked is None:
        return (
            f"{k} runs from starts uniform in the certified start region; plants uniform in the declared box; "
            "currents uniform in the declared disc"
        )
    corners = checked.vertex_runs(k)
    starts = (
        "starts uniform in the robust invariant sets"
        if checked.kind == "robust"
        else f"starts uniform in the composed certificate's start set ({checked.scale:.3g} of the nominal region)"
    )
    return (
        f"{k} runs: {corners} at box vertices (every other run, current at the declared speed, random direction; "
        f"{checked.vertices} vertices in all), {k - corners} uniform in the box with currents uniform in the disc; "
        + starts
    )


def _start_region(s: Any) -> Any:
    """The summary's ``start_region``: the radii the starts are drawn in, or the robust sets' name."""
    checked = s.checked
    if checked is None:
        return nominal_certificate(s).region.region.to_dict()
    return checked.region() if checked.kind == "composed" else "robust invariant ellipsoids"


def passed(table: pd.DataFrame) -> pd.Series:
    """Per-run verdict: ``inside_bounds & within_certified_force`` where they apply, else ``stayed_in_envelope``.

    Parameters
    ----------
    table : pandas.DataFrame
        The run table (``runs.parquet``'s columns).
    """
    inside = table["inside_bounds"]
    if "within_certified_force" in table:
        inside = inside & table["within_certified_force"]
    return inside.fillna(table["stayed_in_envelope"]).astype(bool)


def summarize(camp: Campaign) -> dict[str, Any]:
    """The ``summary.json`` object: counts, fractions, worst ratios, forces (N, N m), throughput (s, runs/s).

    Of an interrupted campaign it summarises the runs that finished (``runs``) and says so
    (``interrupted``, ``runs_requested``).

    Parameters
    ----------
    camp : Campaign
        The campaign, or the part of it that finished.
    """
    t, s = camp.table, camp.setup
    k = len(t)
    applicable = t["inside_bounds"].notna()
    n_app = int(applicable.sum())
    inside = int(t["inside_bounds"].fillna(False).astype(bool).sum())
    worst: dict[str, float | None] = {}
    for kind in ERROR_KINDS:
        col = t.loc[applicable, f"ratio_{kind}_error"]
        worst[f"{kind}_error"] = float(col.max()) if n_app else None
    # the measured rate is that of the nominal Lyapunov function towards zero error: with a
    # perturbed plant or a current the errors settle at an offset, so it says nothing there
    rates = t.loc[applicable & t["nominal"], "measured_decay_rate"].dropna()
    notes = []
    if n_app < k and s.separation is None and s.certificate_applies:  # else the notes below say why
        note = ROBUST_NOTE if s.covers_sampled_runs else SAMPLED_NOTE
        notes.append(note + (f" ({s.robust_reason})" if s.robust_reason else ""))
    if s.separation is not None:
        notes.append(f"the certified bounds do not keep [formation] min_separation ({s.separation}): it covers no run")
    elif not s.certificate_applies:
        notes.append("the certified thrust exceeds the configured thrust limit: the certificate covers no run")
    forces = force_summary(camp)
    veh_s = k * s.n * s.horizon
    wall = camp.wall_time
    return {
        "config": s.name,
        "n": s.n,
        "runs": k,
        "runs_requested": k if camp.requested is None else camp.requested,
        "interrupted": camp.interrupted,
        "seed": s.seed,
        "horizon": s.horizon,
        "chunk": camp.chunk,
        "executor": camp.executor,
        # the certificate the runs are checked against (None: it covers none of them)
        "certificate": None if not n_app else "nominal" if s.checked is None else s.checked.kind,
        "start_region": _start_region(s),
        "region_error_bounds": certified_bounds(camp),
        "box_vertex_runs": 0 if s.checked is None else s.checked.vertex_runs(k),
        "composition": _composition(s, k),
        "uncertainty_box": {c: list(b) for c, b in zip(COEFFICIENTS, s.box.tolist()) if b != [1.0, 1.0]},
        "current_speed": s.current_speed,
        "implementation": implementation_summary(s.implementation, s.noise_pattern, not s.implementation.continuous),
        "counts": {
            "runs": k,
            "certificate_applies": n_app,
            "not_applicable": k - n_app,
            "inside_bounds": inside,
            "outside_bounds": n_app - inside,
            "left_envelope": int((~t["stayed_in_envelope"].astype(bool)).sum()),
            "exceeded_certified_force": forces["exceeded_certified_force"],
            "saturated": int((t["saturated_fraction"] > 0).sum()),
            "passed": int(passed(t).sum()),
        },
        "fraction_inside": inside / n_app if n_app else None,
        "worst_ratio": worst,
        "worst_tail_position_ratio": float(t.loc[applicable, "ratio_tail_position_error"].max()) if n_app else None,
        "forces": forces,
        "certified_decay_rate": nominal_certificate(s).rate if s.checked is None else s.checked.decay_rate,
        "min_measured_decay_rate": float(rates.min()) if len(rates) else None,
        "throughput": {
            "runs_per_second": k / wall if wall > 0 else None,
            "vehicle_seconds_per_wall_second": veh_s / wall if wall > 0 else None,
            "wall_time": wall,
            "setup_time": camp.setup_time,
        },
        # as simulate's exit code: every run passed, and a certificate covers every run
        "ok": bool(passed(t).all()) and n_app == k,
        "notes": notes,
    }


def certified_thrust(camp: Campaign) -> dict[str, float]:
    """Thrust bound the runs are checked against (N, N, N m): the composed or robust one's, else the nominal one's.

    Parameters
    ----------
    camp : Campaign
        The finished campaign (its setup and run table).
    """
    checked = camp.setup.checked
    if checked is not None:
        return {c: float(b) for c, b in zip(CHANNELS, checked.thrust)}
    return dict(nominal_certificate(camp.setup).thrust.to_dict())


def force_summary(camp: Campaign) -> dict[str, Any]:
    """The ``forces`` object of the summary: peak commanded forces against the bound and the limits.

    ``certified_thrust`` and ``actuator_limits`` (None when undeclared) are ``{force_x, force_y,
    moment}`` (N, N, N m); ``max_commanded`` is the peak over all runs before saturation;
    ``worst_ratio`` the largest peak / certified bound over the runs a certificate applies to
    (None when there are none) and ``tightness`` its inverse, how many times the worst sampled
    run the certified bound is (the bound's conservatism as measured; at least 1 when sound);
    ``within_certified_force`` and ``exceeded_certified_force`` count those runs.

    Parameters
    ----------
    camp : Campaign
        The finished campaign (its setup and run table).
    """
    t = camp.table
    within = t["within_certified_force"]
    app = within.notna()
    n_app, n_in = int(app.sum()), int(within.fillna(False).astype(bool).sum())
    bound = certified_thrust(camp)
    act = camp.setup.law.actuators
    worst = {c: float(t.loc[app, col].max() / bound[c]) if n_app else None for c, col in zip(CHANNELS, FORCE_COLUMNS)}
    return {
        "certified_thrust": bound,
        "actuator_limits": None if act is None else act.to_dict(),
        "max_commanded": {c: float(t[col].max()) for c, col in zip(CHANNELS, FORCE_COLUMNS)},
        "worst_ratio": worst,
        "tightness": {c: None if r is None or r <= 0.0 else 1.0 / r for c, r in worst.items()},
        "within_certified_force": n_in,
        "exceeded_certified_force": n_app - n_in,
        "max_saturated_fraction": float(t["saturated_fraction"].max()),
    }


def certified_bounds(camp: Campaign) -> dict[str, float]:
    """Bounds over every start the campaign draws: the composed or robust certificate's, else the nominal region's.

    Parameters
    ----------
    camp : Campaign
        The finished campaign (its setup and run table).
    """
    checked = camp.setup.checked
    if checked is not None:
        return {kind: float(b) for kind, b in zip(ERROR_KINDS, checked.bounds)}
    return dict(nominal_certificate(camp.setup).region.bounds.to_dict())


def save_histograms(camp: Campaign, out: Path) -> list[Path]:
    """Histograms of the measured excursions with the certified bounds as vertical lines.

    ``excursions.png``: per error kind, the largest error of each run (over time and
    vehicles) and the certificate's bound over the whole start region.
    ``bound_ratios.png``: per kind, measured / per-start certified bound of the runs the
    certificate applies to, with the line at 1. Returns the paths written.

    Parameters
    ----------
    camp : Campaign
        The finished campaign (its setup and run table).
    out : Path
        Existing directory the two PNG files are written to.
    """
    from matplotlib.figure import Figure  # no pyplot: no backend or display needed

    t = camp.table
    region = certified_bounds(camp)
    paths = []
    fig = Figure(figsize=(14, 3.4), layout="constrained")
    axes = fig.subplots(1, 4)
    for ax, kind in zip(axes, ERROR_KINDS):
        ax.hist(t[f"max_{kind}_error"].to_numpy(float), bins=30, color="tab:blue", alpha=0.8)
        ax.axvline(region[kind], color="tab:red", lw=1.5, label="certified bound (start set)")
        ax.set_xlabel(f"max {kind.replace('_', ' ')} error [{UNITS[kind]}]")
        ax.set_ylabel("runs")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{camp.setup.name}: {len(t)} runs, measured excursions")
    paths.append(out / "excursions.png")
    fig.savefig(paths[-1], dpi=110)
    app = t[t["inside_bounds"].notna()]
    fig = Figure(figsize=(14, 3.4), layout="constrained")
    axes = fig.subplots(1, 4)
    for ax, kind in zip(axes, ERROR_KINDS):
        vals = app[f"ratio_{kind}_error"].to_numpy(float)
        ax.hist(vals[np.isfinite(vals)], bins=30, color="tab:green", alpha=0.8)
        ax.axvline(1.0, color="tab:red", lw=1.5, label="certified bound of the start")
        ax.set_xlabel(f"{kind.replace('_', ' ')}: measured / certified")
        ax.set_ylabel("runs")
    axes[0].legend(fontsize=7)
    which = "nominal" if camp.setup.checked is None else camp.setup.checked.kind
    fig.suptitle(f"{camp.setup.name}: {len(app)} runs covered by the {which} certificate")
    paths.append(out / "bound_ratios.png")
    fig.savefig(paths[-1], dpi=110)
    return paths


def write_outputs(camp: Campaign, out: Path) -> dict[str, Any]:
    """Write ``runs.parquet``, ``summary.json`` and the PNG histograms to ``out``; return the summary.

    Parameters
    ----------
    camp : Campaign
        The finished campaign (its setup and run table).
    out : Path
        Output directory (created if missing).
    """
    out.mkdir(parents=True, exist_ok=True)
    summary = summarize(camp)
    camp.table.to_parquet(out / "runs.parquet", index=False)
    (out / "summary.json").write_text(json.dumps(json_safe(summary), indent=2))
    save_histograms(camp, out)
    return summary


__all__ = [
    "ROBUST_NOTE",
    "SAMPLED_NOTE",
    "SUMMARY_UNITS",
    "UNITS",
    "certified_bounds",
    "certified_thrust",
    "force_summary",
    "passed",
    "save_histograms",
    "summarize",
    "write_outputs",
]
