"""Figures of a guidance run: the fleet's paths over its slots, the errors, the thrust and the rudder.

The limits are drawn in the limit colour (red, dotted); a large fleet is drawn as percentile
bands (:func:`~auv_hinf.figures.simulation.per_vehicle_axes`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from auv_hinf.figures.simulation import (
    MAX_TRAJECTORY_PATHS,
    REFERENCE_COLOUR,
    VEHICLE_COLOURS,
    per_vehicle_axes,
    save_pngs,
)
from auv_hinf.guidance.simulation import GuidanceRun

if TYPE_CHECKING:
    from auv_hinf.campaign.guidance import GuidanceCampaign


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
    "guidance_actuators",
    "guidance_campaign_figure",
    "guidance_errors",
    "guidance_paths",
    "save_guidance_campaign_figure",
    "save_guidance_plots",
]
