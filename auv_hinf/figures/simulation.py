"""Matplotlib figures of certificates and simulations.

Every function returns a :class:`~matplotlib.figure.Figure`; library code never calls
``show()``. The simulation figures read only ``t``, ``states``, ``forces``,
``shape_error``, ``center_error``, ``desired_center``, ``mission_error`` (the trajectory figure
of a large fleet) and ``scenario.name`` / ``scenario.envelope`` (and, if present,
``scenario.law.actuators``) of a result, so any object with those attributes can be plotted.

They read at any fleet size: one line per vehicle up to :data:`MAX_VEHICLE_LINES`, then the
fleet's percentile bands; the trajectory figure draws every path up to
:data:`MAX_TRAJECTORY_PATHS`, then the positions of the fleet as a density with the vehicles of
the largest slot error highlighted, over the slot-error percentiles. The vehicles' colours
(:data:`VEHICLE_COLOURS`) never take the colours kept for what they are measured against: black
for the desired centre and the certified bound, red for the limits, grey for the formation
outline and the density.
"""

from __future__ import annotations

import colorsys
import functools
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib
import matplotlib.colors as mcolors
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.exceptions import ParameterError
from auv_hinf.files import written
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from auv_hinf.simulation.results import SimulationResult

#: Relative margin around the data in the trajectory figure.
TRAJECTORY_MARGIN = 0.04

#: Largest fleet drawn one line per vehicle; larger fleets are drawn as percentile bands.
MAX_VEHICLE_LINES = 12

#: Largest fleet whose trajectory figure draws every path. Beyond about 50 the thin paths of a formation
#: overlap into one band in which no path can be followed (a fleet of 1000 on the paper's sine is a grey
#: ring), so the figure shows the fleet's positions as a density, the vehicles with the largest slot error
#: and the slot-error percentiles instead.
MAX_TRAJECTORY_PATHS = 50

#: Vehicles highlighted in the trajectory figure of a large fleet: those with the largest slot error.
WORST_VEHICLES = 5

#: Floor of the errors on a log scale (m): an error that is exactly zero is drawn there, at round-off.
ERROR_FLOOR = 1e-16

#: Legend labels of the force figure's horizontal lines.
CERTIFIED_LABEL = "certified bound"
#: The force figure's view reaches this multiple of its bound and limit lines, so none lies on the frame.
LEVEL_MARGIN = 1.06
LIMIT_LABEL = "actuator limit"

#: Colours kept for the lines the vehicles are measured against: the desired centre and the certified bound
#: (black), the actuator limits and the envelope (red), the formation outline and the density of a large
#: fleet (greys).
REFERENCE_COLOUR, LIMIT_COLOUR, OUTLINE_COLOUR, DENSITY_COLOURS = "k", "r", "0.45", "Greys"

#: Hue distance from red (degrees) inside which a colour reads as red, the limits' colour: tab20's red,
#: salmon and two browns are within 10 degrees of it, its orange 28 degrees away.
RED_HUE_WIDTH = 20.0

#: HSV saturation below which a colour reads as grey, the references' colour: tab20's greys have 0, its
#: lavender 0.17; its palest blue, 0.25, still reads as blue.
GREY_SATURATION = 0.2


def distinct_from_references(colour: Any) -> bool:
    """A colour that cannot be taken for a reference or a limit line: not red, not grey or black.

    Parameters
    ----------
    colour : matplotlib colour
        Any colour matplotlib reads (``"C3"``, ``"#d62728"``, an RGB tuple).
    """
    hue, saturation, _ = colorsys.rgb_to_hsv(*mcolors.to_rgb(colour))
    from_red = min(hue, 1.0 - hue) * 360.0
    return saturation >= GREY_SATURATION and from_red > RED_HUE_WIDTH


#: The vehicles' colours: tab20's strong colours, then its light ones, without those
#: :func:`distinct_from_references` refuses (13 colours: more than :data:`MAX_VEHICLE_LINES`).
#: tab20's twenty colours, strong and light in turn.
_TAB20 = [matplotlib.colormaps["tab20"](k) for k in range(20)]
VEHICLE_COLOURS: tuple[str, ...] = tuple(
    mcolors.to_hex(c) for c in (*_TAB20[0::2], *_TAB20[1::2]) if distinct_from_references(c)
)


def _vehicle_colours(n: int) -> list[str]:
    """A colour per vehicle (distinct up to ``len(VEHICLE_COLOURS)``, then repeated)."""
    return [VEHICLE_COLOURS[i % len(VEHICLE_COLOURS)] for i in range(n)]


def _vehicle_labels(n: int) -> list[str]:
    return [f"AUV {i + 1}" for i in range(n)]


def _vehicle_legend(ax: Axes, n: int) -> None:
    """The legend right of the axes (never over the data): one entry per vehicle, or the fleet bands."""
    title = "vehicle" if n <= MAX_VEHICLE_LINES else f"fleet of {n}"
    ax.legend(
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=7,
        ncol=-(-n // 16) if n <= MAX_VEHICLE_LINES else 1,
        title=title,
        title_fontsize=7,
    )


def _scenario_name(res: Any) -> str:
    return str(getattr(getattr(res, "scenario", None), "name", "simulation"))


def _scenario_envelope(res: Any) -> Any:
    return getattr(getattr(res, "scenario", None), "envelope", None)


def _snapshot_indices(t: np.ndarray, every: float) -> list[int]:
    """Sample indices nearest to ``0, every, 2 every, ...`` (no repeats)."""
    if every <= 0 or len(t) == 0:
        return [0] if len(t) else []
    times = np.arange(float(t[0]), float(t[-1]) + 1e-9, every)
    return sorted({int(np.argmin(np.abs(t - tm))) for tm in times})


#: Formation snapshots drawn on a trajectory figure by default, about: the interval between them is the
#: horizon over this, rounded to 1, 2 or 5 times a power of ten seconds (a fixed 50 s drew 60 merged
#: snapshots on a 3000 s run).
SNAPSHOTS = 8


def snapshot_interval(horizon: float) -> float:
    """The time between formation snapshots (s): ``horizon / SNAPSHOTS`` rounded to 1, 2 or 5 times a power of ten.

    Parameters
    ----------
    horizon : float
        The run's length (s).
    """
    raw = max(horizon, 1e-9) / SNAPSHOTS
    power = 10.0 ** math.floor(math.log10(raw))
    return next((m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= raw * (1.0 - 1e-12)), 10.0 * power)


def trajectories(res: SimulationResult, marker_every: float | None = None) -> Figure:
    """Paths of the vehicles, the desired centre path and the formation every ``marker_every`` s.

    At each snapshot the formation polygon is drawn and every vehicle's heading ``psi``
    is shown as an arrow. The axes have equal aspect and are fitted to the data; the
    figure's height follows the data's aspect ratio, so a long, flat mission does not
    leave the figure mostly empty. A fleet of more than :data:`MAX_TRAJECTORY_PATHS` vehicles
    is drawn as the density of its positions with the :data:`WORST_VEHICLES` vehicles of the
    largest slot error highlighted, above the slot-error percentiles over time (read from
    ``res.mission_error``, m).

    Parameters
    ----------
    res : SimulationResult
        A simulation result (see the module docstring for the attributes read).
    marker_every : float, optional
        Time between formation snapshots, s (default :func:`snapshot_interval` of the run's length; a
        large fleet has none: its density shows the shape).

    Returns
    -------
    matplotlib.figure.Figure
        One axes, in m; for a large fleet a second one, the slot errors (m) against t (s).
    """
    t = np.asarray(res.t, dtype=float)
    if marker_every is None:
        marker_every = snapshot_interval(float(t[-1] - t[0]) if t.size else 0.0)
    states = np.asarray(res.states, dtype=float)
    xy = states[..., 0:2]
    centre = np.asarray(res.desired_center, dtype=float)
    pts = np.concatenate([xy.reshape(-1, 2), centre.reshape(-1, 2)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    pad = TRAJECTORY_MARGIN * span.max()
    n = xy.shape[1]
    fleet = n > MAX_TRAJECTORY_PATHS
    many = n > MAX_VEHICLE_LINES  # a large fleet gets one legend entry for all its paths
    legend_rows = 1 if many else -(-(n + 2) // 6)
    # axes about 9.1 in wide; title, x label and the legend rows below take about 1.1 + 0.25/row in
    axes_height = float(np.clip(9.1 * (span[1] + 2 * pad) / (span[0] + 2 * pad), 2.0, 8.0))
    height = axes_height + 1.1 + 0.25 * (-(-(WORST_VEHICLES + 2) // 2) if fleet else legend_rows)
    if fleet:  # the map, then the slot errors below it
        fig, (ax, ax_err) = plt.subplots(
            2, 1, figsize=(10.0, height + 3.0), height_ratios=[axes_height, 2.4], constrained_layout=True
        )
    else:
        fig, ax = plt.subplots(figsize=(10.0, height), constrained_layout=True)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    handles: list[Any] = []
    if fleet:
        handles += _fleet_map(ax, ax_err, res, t, xy)
        title = f"{_scenario_name(res)}: {n} vehicles as a density; the {WORST_VEHICLES} with the largest slot error"
    else:
        _paths(ax, states, t, marker_every, many, span)
        title = f"{_scenario_name(res)}: paths; formation and headings every {marker_every:g} s"
    ax.plot(centre[:, 0], centre[:, 1], color=REFERENCE_COLOUR, ls="--", lw=0.8, label="desired centre")
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    more, labels = ax.get_legend_handles_labels()
    handles, labels = handles + more, [h.get_label() for h in handles] + labels
    if not fleet:
        handles.append(Line2D([], [], color="0.3", marker=">", ls="-", lw=1, ms=5))
        labels.append("heading psi")
    if fleet:  # below the map, which keeps the figure's width
        ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=7, ncol=2)
    else:
        fig.legend(handles, labels, loc="outside lower center", fontsize=7, ncol=min(len(labels), 6))
    return fig


def _paths(ax: Axes, states: FloatArray, t: FloatArray, marker_every: float, many: bool, span: FloatArray) -> None:
    """Every vehicle's path, and the formation with its headings every ``marker_every`` s."""
    xy = states[..., 0:2]
    n = xy.shape[1]
    colours = _vehicle_colours(n)
    for i, label in enumerate(_vehicle_labels(n)):
        if many:
            label = f"paths of the {n} vehicles" if i == 0 else "_"
        ax.plot(xy[:, i, 0], xy[:, i, 1], lw=0.6 if many else 1, color=colours[i], label=label)
    arrow_len = 0.03 * span.max()
    for k in _snapshot_indices(t, marker_every):
        snap = xy[k]
        ax.fill(snap[:, 0], snap[:, 1], fill=False, ec=OUTLINE_COLOUR, lw=0.7)
        psi = states[k, :, 2]
        ax.quiver(
            snap[:, 0],
            snap[:, 1],
            arrow_len * np.cos(psi),
            arrow_len * np.sin(psi),
            color=colours,
            angles="xy",
            scale_units="xy",
            scale=1.0,
            pivot="tail",
            width=0.004,
            zorder=3,
        )


def _fleet_map(ax: Axes, ax_err: Axes, res: Any, t: FloatArray, xy: FloatArray) -> list[Any]:
    """A large fleet: its positions as a density, the worst vehicles' paths, and the slot-error bands below."""
    n = xy.shape[1]
    err = np.asarray(res.mission_error, dtype=float)  # (T, N) slot errors, m
    worst = np.argsort(err.max(axis=0))[::-1][:WORST_VEHICLES]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    ax.hexbin(
        xy[..., 0].ravel(),
        xy[..., 1].ravel(),
        gridsize=150,
        extent=(x0, x1, y0, y1),
        bins="log",
        mincnt=1,
        cmap=DENSITY_COLOURS,
        linewidths=0,
    )
    density = Patch(color=matplotlib.colormaps[DENSITY_COLOURS](0.6), label=f"positions of all {n} vehicles (density)")
    _bands(ax_err, t, np.maximum(err, NUMERICAL_FLOOR))
    for k, i in enumerate(worst):
        colour = VEHICLE_COLOURS[1 + k % (len(VEHICLE_COLOURS) - 1)]  # not the bands' colour
        label = f"AUV {i + 1}: largest slot error {err[:, i].max():.3g} m"
        ax.plot(xy[:, i, 0], xy[:, i, 1], color=colour, lw=1.2, label=label)
        ax_err.plot(t, np.maximum(err[:, i], NUMERICAL_FLOOR), color=colour, lw=0.9, label=f"AUV {i + 1}")
    ax_err.set_yscale("log")
    ax_err.set_ylim(bottom=0.5 * NUMERICAL_FLOOR)
    ax_err.set_xlabel("t [s]")
    ax_err.set_ylabel("slot error |p_i - p_d,i| [m]")
    ax_err.set_title(
        f"slot errors of the {n} vehicles (drawn down to {NUMERICAL_FLOOR:g} m, the simulation's accuracy)"
    )
    ax_err.grid(True, alpha=0.3)
    _vehicle_legend(ax_err, n)
    return [density]


def _envelope_ranges(env: Any) -> Sequence[tuple[float, float] | None]:
    if env is None:
        return (None, None, None)
    return (tuple(env.u), tuple(env.v), tuple(env.r))


def velocities(res: SimulationResult) -> Figure:
    """Surge, sway and yaw rate of every vehicle (Fig. 2), with the envelope bounds dotted.

    Parameters
    ----------
    res : SimulationResult
        A simulation result.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes; the top one carries one legend entry per vehicle.
    """
    env = _scenario_envelope(res)
    fig, axes = per_vehicle_axes(
        res.t,
        np.asarray(res.states, dtype=float)[:, :, 3:6],
        ("u [m/s]", "v [m/s]", "r [rad/s]"),
        _envelope_ranges(env),
    )
    envelope_note = "" if env is None else " (dotted: certified envelope)"
    axes[0].set_title(f"{_scenario_name(res)}: surge, sway and yaw rate{envelope_note}")
    return fig


def per_vehicle_axes(
    t: Any, data: FloatArray, labels: tuple[str, str, str], ranges: Any = (None, None, None)
) -> tuple[Figure, Any]:
    """Three stacked axes of ``data[:, i, k]`` (one line per vehicle i, axis k), bounds dotted.

    Parameters
    ----------
    t : array_like, shape (T,)
        Times (s).
    data : ndarray, shape (T, N, 3)
        The three quantities of every vehicle.
    labels : tuple of 3 str
        The axes' labels, with their units.
    ranges : sequence of 3 (sequence of float or None)
        Levels drawn dotted in the limit colour on each axis (``None``: none).
    """
    n = data.shape[1]
    tt = np.asarray(t, dtype=float)
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True, constrained_layout=True)
    for ax, k, label, rng in zip(axes, range(3), labels, ranges):
        if n <= MAX_VEHICLE_LINES:
            for i, (colour, name) in enumerate(zip(_vehicle_colours(n), _vehicle_labels(n))):
                ax.plot(tt, data[:, i, k], lw=1, color=colour, label=name)
        else:  # a large fleet: its range, the 5-95 % band and the median, not n lines
            _bands(ax, tt, data[:, :, k])
        for b in rng or ():
            ax.axhline(b, color=LIMIT_COLOUR, ls=":", lw=0.8)
        ax.set_ylabel(label)
    _vehicle_legend(axes[0], n)
    axes[-1].set_xlabel("t [s]")
    return fig, axes


def _bands(ax: Axes, t: FloatArray, values: FloatArray) -> None:
    """The fleet's range, its 5-95 % band and its median of ``values (T, N)`` over the vehicles, against ``t``."""
    lo, p5, p50, p95, hi = np.percentile(values, [0, 5, 50, 95, 100], axis=1)
    colour = VEHICLE_COLOURS[0]
    ax.fill_between(t, lo, hi, color=colour, alpha=0.2, lw=0, label="min - max")
    ax.fill_between(t, p5, p95, color=colour, alpha=0.45, lw=0, label="5 - 95 %")
    ax.plot(t, p50, color=colour, lw=1.2, label="median")


def errors(res: SimulationResult) -> Figure:
    """Shape and centre error on a log scale.

    Parameters
    ----------
    res : SimulationResult
        A simulation result.

    Returns
    -------
    matplotlib.figure.Figure
        One axes, errors in m (floored at :data:`ERROR_FLOOR` for the log scale).
    """
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    ax.semilogy(res.t, np.maximum(res.shape_error, ERROR_FLOOR), color=VEHICLE_COLOURS[0], label="shape error")
    ax.semilogy(res.t, np.maximum(res.center_error, ERROR_FLOOR), color=VEHICLE_COLOURS[1], label="centre error")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("error [m]")
    ax.set_title(f"{_scenario_name(res)}: formation errors")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    return fig


def _channel_levels(name: str, values: Sequence[float] | None) -> list[float] | None:
    """``values`` as three finite levels >= 0 (N, N, N m), or None."""
    out = None if values is None else [float(v) for v in values]
    if out is not None and (len(out) != 3 or not all(np.isfinite(v) and v >= 0.0 for v in out)):
        raise ParameterError(f"{name} must be three finite values >= 0 (N, N, N m), got {values!r}")
    return out


def forces(
    res: SimulationResult,
    *,
    certified: Sequence[float] | None = None,
    limits: Sequence[float] | None = None,
) -> Figure:
    """Surge force, sway force and yaw moment of every vehicle, with the certified bound and the limits.

    Parameters
    ----------
    res : SimulationResult
        A simulation result.
    certified : sequence of 3 float, optional
        Certified bound of ``|tau_x|`` (N), ``|tau_y|`` (N), ``|tau_psi|`` (N m), e.g.
        ``certificate.thrust.as_tuple()``: drawn dashed at ``+-`` the bound, labelled
        ``"certified bound"``.
    limits : sequence of 3 float, optional
        Actuator limits (N, N, N m), e.g. ``actuators.limits()``: drawn solid red at ``+-`` the
        limit, labelled ``"actuator limit"``. Default: the limits of ``res.scenario.law.actuators``
        when it declares actuators.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes; the top one's legend has one entry per vehicle, then the bound and
        the limit when drawn.

    Raises
    ------
    ParameterError
        If ``certified`` or ``limits`` is not three finite values >= 0.
    """
    rudder_note = ""
    if limits is None:
        act = getattr(getattr(getattr(res, "scenario", None), "law", None), "actuators", None)
        if isinstance(act, RudderActuation):
            # a rudder's sway force and yaw moment grow with u^2: its most, at the run's top surge speed
            top = float(np.max(np.abs(np.asarray(res.states)[..., 3]))) if np.size(res.states) else 0.0
            limits = (act.tau_x, *act.authority(top))
            rudder_note = f", the rudder's at {top:.3g} m/s"
        elif act is not None:
            limits = act.limits()
    data = np.asarray(res.forces, dtype=float)
    fig, axes = per_vehicle_axes(res.t, data, ("tau_x [N]", "tau_y [N]", "tau_psi [N m]"))
    notes = []
    for levels, label, word, style in (
        (_channel_levels("certified", certified), CERTIFIED_LABEL, "dashed", {"color": REFERENCE_COLOUR, "ls": "--"}),
        (_channel_levels("limits", limits), LIMIT_LABEL, "red", {"color": LIMIT_COLOUR, "ls": "-"}),
    ):
        for ax, level in zip(axes, levels or ()):
            ax.axhline(level, label=label, lw=1.2, **style)
            ax.axhline(-level, label=f"_{label} (lower)", lw=1.2, **style)  # "_": not in the legend
            lo, hi = ax.get_ylim()  # the lines inside the view, not on its edge
            ax.set_ylim(min(lo, -LEVEL_MARGIN * level), max(hi, LEVEL_MARGIN * level))
        notes += [f"{word}: {label}" + (rudder_note if label == LIMIT_LABEL else "")] if levels else []
    if notes:
        _vehicle_legend(axes[0], data.shape[1])  # again, now with the bound and the limit
    note = f" ({'; '.join(notes)})" if notes else ""
    axes[0].set_title(f"{_scenario_name(res)}: thrust and yaw moment (body frame){note}")
    return fig


def save_simulation_plots(
    res: SimulationResult,
    out: Path,
    *,
    certified: Sequence[float] | None = None,
    limits: Sequence[float] | None = None,
) -> list[Path]:
    """Write the trajectory, velocity, error and force figures as PNGs into ``out``.

    Parameters
    ----------
    res : SimulationResult
        A simulation result.
    out : pathlib.Path
        Existing directory.
    certified, limits : sequence of 3 float, optional
        Certified thrust bound and actuator limits (N, N, N m) drawn on the force figure; see
        :func:`forces` (the limits default to those of the result's law).

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    figures: list[tuple[str, Callable[[SimulationResult], Figure]]] = [
        ("trajectories", trajectories),
        ("velocities", velocities),
        ("errors", errors),
        ("forces", functools.partial(forces, certified=certified, limits=limits)),
    ]
    return save_pngs(figures, res, out)


#: Resolution of the PNG files the toolbox writes (dots per inch): sharp on a laptop screen at
#: the figures' 10-12 in widths, and well under 1 MB a file.
PNG_DPI = 110


def save_pngs(figures: Sequence[tuple[str, Callable[[Any], Figure]]], data: Any, out: Path) -> list[Path]:
    """Draw each ``(name, figure_of)`` on ``data`` and write it as ``out/name.png``, closing each figure.

    Parameters
    ----------
    figures : sequence of (str, callable)
        File stems and the functions that draw the figure from ``data``.
    data : Any
        The run (or result) every function draws.
    out : pathlib.Path
        Existing directory.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order of ``figures``.
    """
    paths = []
    for name, figure_of in figures:
        fig = figure_of(data)
        path = Path(out) / f"{name}.png"
        with written(path) as tmp:  # an interrupted write leaves no truncated image
            fig.savefig(tmp, dpi=PNG_DPI)
        plt.close(fig)
        paths.append(path)
    return paths


__all__ = [
    "CERTIFIED_LABEL",
    "DENSITY_COLOURS",
    "ERROR_FLOOR",
    "GREY_SATURATION",
    "LEVEL_MARGIN",
    "LIMIT_COLOUR",
    "LIMIT_LABEL",
    "MAX_TRAJECTORY_PATHS",
    "MAX_VEHICLE_LINES",
    "OUTLINE_COLOUR",
    "PNG_DPI",
    "RED_HUE_WIDTH",
    "REFERENCE_COLOUR",
    "SNAPSHOTS",
    "TRAJECTORY_MARGIN",
    "VEHICLE_COLOURS",
    "WORST_VEHICLES",
    "distinct_from_references",
    "errors",
    "forces",
    "per_vehicle_axes",
    "save_pngs",
    "save_simulation_plots",
    "snapshot_interval",
    "trajectories",
    "velocities",
]
