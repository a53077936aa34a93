"""The survey figure: each vehicle's track and swath over the survey area, with snapshots of the formation.

:func:`survey_figure` draws a simulated run seen from above: one track per vehicle, the strip
its sensor sweeps (``swath`` m wide, centred on the track, as a translucent band), and the
formation at the middle of every straight leg with an arrow along the course, so that the
orientation of the shape on each leg can be read off. Figures are returned, never shown.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from auv_hinf.figures.simulation import VEHICLE_COLOURS
from auv_hinf.simulation.results import SimulationResult

#: Points per inch: a line width is in points, the swath in data metres.
_POINTS_PER_INCH = 72.0


def leg_midpoints(course: np.ndarray, straight_atol: float = 1e-9) -> list[int]:
    """Sample indices at the middle of each straight leg along x (``|sin chi| <= straight_atol``).

    Parameters
    ----------
    course : ndarray, shape (T,)
        The course ``chi`` (rad) of each sample.
    straight_atol : float
        Largest ``|sin chi|`` of a sample on a straight leg.
    """
    straight = np.abs(np.sin(course)) <= straight_atol
    edges = np.flatnonzero(np.diff(straight.astype(int)))
    starts = [0, *(edges + 1)] if straight[0] else list(edges + 1)
    out = []
    for s in starts:
        if not straight[s]:
            continue
        end = s + int(np.argmin(straight[s:])) if not straight[s:].all() else len(straight)
        out.append(int((s + end - 1) // 2))
    return out


def survey_figure(result: SimulationResult, course: np.ndarray, swath: float) -> Figure:
    """Tracks, swaths (m) and the formation at the middle of each leg of ``result``.

    Parameters
    ----------
    result : SimulationResult
        A simulated run (positions in m, inertial frame).
    course : ndarray, shape (T,)
        The mission's course ``chi`` (rad) at ``result.t``.
    swath : float
        Width of the strip each vehicle's sensor covers (m), centred on its track.
    """
    fig, ax = plt.subplots(figsize=(9, 6))
    pos = result.states[:, :, :2]
    ax.set_aspect("equal")
    colours = [VEHICLE_COLOURS[i % len(VEHICLE_COLOURS)] for i in range(pos.shape[1])]  # none red: the lead's
    for i, colour in enumerate(colours):
        ax.plot(pos[:, i, 0], pos[:, i, 1], lw=0.8, color=colour)
    fig.canvas.draw()  # fixes the axes' scale, so the band width in points matches swath metres
    x0, x1 = ax.get_xlim()
    width_in = ax.get_window_extent().width / fig.dpi
    band = swath * width_in * _POINTS_PER_INCH / (x1 - x0)
    for i in range(pos.shape[1]):
        ax.plot(pos[:, i, 0], pos[:, i, 1], lw=band, alpha=0.25, solid_capstyle="butt", color=colours[i])
    for k in leg_midpoints(course):
        ax.plot(pos[k, :, 0], pos[k, :, 1], "k.", ms=6)
        ax.plot(pos[k, 0, 0], pos[k, 0, 1], "r^", ms=8)
        ax.annotate(
            "",
            xy=(pos[k, 0, 0] + 25 * np.cos(course[k]), pos[k, 0, 1] + 25 * np.sin(course[k])),
            xytext=(pos[k, 0, 0], pos[k, 0, 1]),
            arrowprops={"arrowstyle": "->", "color": "r"},
        )
    ax.set_xlabel("x, inertial [m]")
    ax.set_ylabel("y, inertial [m]")
    ax.set_title(f"{result.scenario.name}: tracks, {swath:g} m swaths and the formation on each leg (lead: red)")
    return fig


__all__ = ["leg_midpoints", "survey_figure"]
