"""Figures of a guidance fleet: its certificate at a glance, and a run's paths, errors, thrust and rudder.

The limits are drawn in the limit colour (red, dotted); a large fleet is drawn as percentile
bands (:func:`~auv_hinf.figures.simulation.per_vehicle_axes`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from auv_hinf.figures.simulation import (
    LIMIT_COLOUR,
    MAX_TRAJECTORY_PATHS,
    REFERENCE_COLOUR,
    VEHICLE_COLOURS,
    per_vehicle_axes,
    save_pngs,
)
from auv_hinf.guidance.simulation import GuidanceRun

if TYPE_CHECKING:
    from auv_hinf.campaign.guidance import GuidanceCampaign


#: What :func:`guidance_certificate_figure` draws against its declared value when a fleet is refused:
#: ``largest_certifiable`` keys that hold one number (m/s, or a fraction of the declared), and their labels.
ANSWER_KEYS = {"current_speed": "current [m/s]", "box_scale": "box scale", "navigation_scale": "navigation scale"}
#: The actuators :func:`guidance_certificate_figure` draws: key, label, unit and the factor from SI.
CERTIFIED_ACTUATORS = (("force_x", "thrust", "N", 1.0), ("rudder", "rudder", "deg", 180.0 / np.pi))

#: How much wider than its longest bar a panel of :func:`guidance_certificate_figure` is drawn, for
#: the number written after each bar.
VALUE_ROOM = 1.3


def _note(ax: Axes, text: str, colour: str = "k") -> None:
    """Write ``text`` in the middle of an empty panel."""
    ax.text(0.5, 0.5, text, ha="center", va="center", fontsize=9, color=colour, transform=ax.transAxes)
    ax.set_xticks([])
    ax.set_yticks([])


def guidance_certificate_figure(record: Mapping[str, Any]) -> Figure:
    """A guidance fleet's certificate at a glance: actuator use, separation, and what certifies when refused.

    Left: the certified peak thrust and rudder as fractions of their limits (the limit is 1).
    Middle: the required and the certified closest approach of two vehicles, beside the closest
    slots' distance (m). Right: the certified along- and cross-track bounds (m) and, in the title,
    the heading's (deg); for a refused fleet instead each single value its answer names
    (``guidance.largest_certifiable``: the current, the box scale, the navigation scale) against
    the declared one (the current's is ``guidance.current_speed``; the scales' is 1).

    Parameters
    ----------
    record : mapping
        ``certify --json``'s object (or ``certificate.json``) of a fleet with a ``[guidance]`` table.
    """
    g, f = record["guidance"], record["formation"]
    fig, (use, apart, answer) = plt.subplots(1, 3, figsize=(13, 3.6), layout="constrained")
    peak, limits = g.get("certified_peak"), g.get("limits") or {}
    if peak:
        for k, (key, _, unit, to_unit) in enumerate(CERTIFIED_ACTUATORS):
            value, limit = float(peak[key]), float(limits.get(key, np.inf))
            use.barh(k, value / limit, color="tab:blue")
            words = f"  {value * to_unit:.3g} of {limit * to_unit:.3g} {unit}"
            use.text(value / limit, k, words, va="center", fontsize=8)
        use.axvline(1.0, color=LIMIT_COLOUR, ls="--", lw=1.0, label="limit")
        use.set_xlim(0.0, 1.6)
        use.set_yticks(range(len(CERTIFIED_ACTUATORS)), [a[1] for a in CERTIFIED_ACTUATORS])
        use.set_xlabel("certified peak / limit")
        use.legend(fontsize=7, loc="lower right")
    else:
        _note(use, "no certified peak:\nthe certificate does not hold")
    kept = "tab:green" if f.get("certified") else "tab:red"
    distances = (
        ("required", f.get("min_separation"), "0.6"),
        ("certified closest", f.get("min_separation_certified"), kept),
        ("closest slots", f.get("slot_distance"), "0.8"),
    )
    for k, (_, value, colour) in enumerate(distances):
        if value is None:
            apart.text(0.0, k, "  none certified", va="center", fontsize=8, color="tab:red")
        else:
            apart.barh(k, float(value), color=colour)
            apart.text(float(value), k, f"  {float(value):.3g} m", va="center", fontsize=8)
    apart.set_yticks(range(len(distances)), [d[0] for d in distances])
    apart.set_xlabel("distance between two vehicles [m]")
    found = {k: float(v) for k, v in (g.get("largest_certifiable") or {}).items() if k in ANSWER_KEYS and v is not None}
    bounds = g.get("error_bounds")
    if g.get("certified") and bounds:
        for k, key in enumerate(("along_track", "cross_track")):
            answer.barh(k, float(bounds[key]), color="tab:green")
            answer.text(float(bounds[key]), k, f"  {float(bounds[key]):.3g} m", va="center", fontsize=8)
        answer.set_yticks((0, 1), ("along-track", "cross-track"))
        answer.set_xlabel("certified error bound [m]")
        answer.set_title(f"heading within {np.degrees(float(bounds['heading'])):.3g} deg", fontsize=9)
    elif found:
        declared = {"current_speed": float(g.get("current_speed") or 0.0)}
        for k, (key, value) in enumerate(found.items()):
            answer.barh(k, declared.get(key) or 1.0, color="0.8", label="declared" if k == 0 else None)
            answer.barh(k, value, color="tab:orange", label="certifies" if k == 0 else None)
            answer.text(value, k, f"  {value:.3g}", va="center", fontsize=8)
        answer.set_yticks(range(len(found)), [ANSWER_KEYS[k] for k in found])
        answer.set_xlabel("largest certifiable, all else as declared")
        answer.legend(fontsize=7, loc="lower right")
    else:
        _note(answer, "refused: the reasons say what certifies", "tab:red")
    for ax in (apart, answer):  # room for the numbers written after the bars
        if ax.has_data():
            ax.set_xlim(0.0, VALUE_ROOM * ax.get_xlim()[1])
    verdict = "certified" if record.get("certified") else "NOT certified"
    fig.suptitle(f"{record.get('preset') or 'fleet'}: {g.get('kind', 'guidance')} cascade, {verdict}")
    return fig


def save_guidance_certificate_figure(record: Mapping[str, Any], out: Path) -> list[Path]:
    """Write :func:`guidance_certificate_figure` as ``out/guidance_certificate.png``.

    Parameters
    ----------
    record : mapping
        ``certify --json``'s object.
    out : pathlib.Path
        Existing directory.

    Returns
    -------
    list of pathlib.Path
        The file written.
    """
    return save_pngs((("guidance_certificate", guidance_certificate_figure),), record, out)


def guidance_paths(run: GuidanceRun) -> Figure:
    """The vehicles' paths (colour) over their slots' paths (black, dashed), north up (m).

    Parameters
    ----------
    run : GuidanceRun
        The simulated run.
    """
    fig, ax = plt.subplots(figsize=(8, 7), constrained_layout=True)
    n = run.states.shape[1]
    step = max(1, n // MAX_TRAJECTORY_PATHS)
    for i in range(0, n, step):
        ax.plot(run.slots[:, i, 1], run.slots[:, i, 0], color=REFERENCE_COLOUR, ls="--", lw=0.6)
        colour = VEHICLE_COLOURS[i % len(VEHICLE_COLOURS)]
        ax.plot(run.states[:, i, 1], run.states[:, i, 0], color=colour, lw=1.0, label=f"AUV {i + 1}")
    ax.set_xlabel("east y [m]")
    ax.set_ylabel("north x [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("paths (colour) over the slots (dashed)")
    if n <= 12:
        ax.legend(fontsize=7, loc="best")
    return fig


def guidance_errors(run: GuidanceRun, bounds: Mapping[str, float] | None = None) -> Figure:
    """Along-track and cross-track errors (m) and heading error (deg) against time, per vehicle.

    Parameters
    ----------
    run : GuidanceRun
        The simulated run.
    bounds : mapping or None
        The certificate's ``error_bounds`` (``along_track``, ``cross_track`` in m, ``heading`` in
        rad; ``certify --json``'s ``guidance.error_bounds``), drawn dotted at plus and minus each.
    """
    data = np.stack([run.along_track, run.cross_track, np.degrees(run.heading_error)], axis=-1)
    ranges: tuple[tuple[float, float] | None, ...] = (None, None, None)
    if bounds is not None:
        b = (bounds["along_track"], bounds["cross_track"], float(np.degrees(bounds["heading"])))
        ranges = tuple((-x, x) for x in b)
    fig, _ = per_vehicle_axes(run.t, data, ("along-track [m]", "cross-track [m]", "heading error [deg]"), ranges)
    return fig


def guidance_actuators(run: GuidanceRun) -> Figure:
    """Commanded thrust (N) and rudder (deg) against time, with the limits, and the sway speed (m/s).

    Parameters
    ----------
    run : GuidanceRun
        The simulated run.
    """
    data = np.stack([run.thrust_cmd, np.degrees(run.rudder_cmd), run.states[:, :, 4]], axis=-1)
    lim_t, lim_r = run.act.tau_x, float(np.degrees(run.act.rudder_max))
    fig, _ = per_vehicle_axes(
        run.t,
        data,
        ("thrust [N]", "rudder [deg]", "sway speed [m/s]"),
        ((-lim_t, lim_t), (-lim_r, lim_r), None),
    )
    return fig


def save_guidance_plots(run: GuidanceRun, out: Path, bounds: Mapping[str, float] | None = None) -> list[Path]:
    """Write the path, error and actuator figures of ``run`` as PNGs into the existing folder ``out``.

    Parameters
    ----------
    run : GuidanceRun
        The simulated run.
    out : pathlib.Path
        Existing directory.
    bounds : mapping or None
        The certified error bounds that cover the run, drawn on the errors' figure
        (:func:`guidance_errors`).

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    figures = (
        ("paths", guidance_paths),
        ("errors", lambda r: guidance_errors(r, bounds)),
        ("actuators", guidance_actuators),
    )
    return save_pngs(figures, run, out)


def guidance_campaign_figure(camp: GuidanceCampaign) -> Figure:
    """Per run: the worst cross- and along-track errors (m), and the thrust and rudder peaks over their limits.

    Box-vertex runs are red, interior runs blue; the dashed line on the right is the limit.

    Parameters
    ----------
    camp : GuidanceCampaign
        A finished (or interrupted) campaign.
    """
    t, act = camp.table, camp.config.actuators
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 3.6), layout="constrained")
    run = t["run"].to_numpy(int)
    colour = np.where(t["vertex"].to_numpy(int) >= 0, "tab:red", "tab:blue")
    left.scatter(run, t["cross_track"], c=colour, marker="o", s=18, label="cross-track")
    left.scatter(run, t["along_track"], c=colour, marker="x", s=18, label="along-track")
    left.set_xlabel("run")
    left.set_ylabel("worst error over the run [m]")
    left.legend(fontsize=7, title="red: box vertex", title_fontsize=7)
    tau_x, rudder_max = float(getattr(act, "tau_x", np.inf)), float(getattr(act, "rudder_max", np.inf))
    right.scatter(run, t["force_x"].to_numpy(float) / tau_x, c=colour, marker="s", s=18, label="thrust")
    right.scatter(run, t["rudder"].to_numpy(float) / rudder_max, c=colour, marker="^", s=18, label="rudder")
    right.axhline(1.0, color="k", lw=1.0, ls="--", label="limit")
    right.set_xlabel("run")
    right.set_ylabel("commanded peak / limit")
    right.legend(fontsize=7)
    fig.suptitle(f"{camp.config.name}: {len(t)} guidance runs of {camp.horizon:g} s, measured (not certified)")
    return fig


def save_guidance_campaign_figure(camp: GuidanceCampaign, out: Path) -> list[Path]:
    """Write :func:`guidance_campaign_figure` as ``out/runs.png``.

    Parameters
    ----------
    camp : GuidanceCampaign
        The campaign.
    out : pathlib.Path
        Existing directory.

    Returns
    -------
    list of pathlib.Path
        The file written.
    """
    return save_pngs((("runs", guidance_campaign_figure),), camp, out)


__all__ = [
    "ANSWER_KEYS",
    "CERTIFIED_ACTUATORS",
    "VALUE_ROOM",
    "guidance_actuators",
    "guidance_campaign_figure",
    "guidance_certificate_figure",
    "guidance_errors",
    "guidance_paths",
    "save_guidance_campaign_figure",
    "save_guidance_certificate_figure",
    "save_guidance_plots",
]
