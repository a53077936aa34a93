"""Matplotlib figures of certificates and simulations.

Every function returns a :class:`~matplotlib.figure.Figure`; library code never calls
``show()``. The simulation figures read only ``t``, ``states``, ``forces``,
``shape_error``, ``center_error``, ``desired_center`` and ``scenario.name`` /
``scenario.envelope`` (and, if present, ``scenario.law.actuators``) of a result, so any object
with those attributes can be plotted.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from auv_hinf.simulation.results import SimulationResult

#: Relative margin around the data in the trajectory figure.
TRAJECTORY_MARGIN = 0.04

#: Largest fleet drawn one line per vehicle; larger fleets are drawn as percentile bands.
MAX_VEHICLE_LINES = 12

#: Legend labels of the force figure's horizontal lines.
CERTIFIED_LABEL = "certified bound"
LIMIT_LABEL = "actuator limit"


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


def trajectories(res: SimulationResult, marker_every: float = 50.0) -> Figure:
    """Paths of the vehicles, the desired centre path and the formation every ``marker_every`` s.

    At each snapshot the formation polygon is drawn and every vehicle's heading ``psi``
    is shown as an arrow. The axes have equal aspect and are fitted to the data; the
    figure's height follows the data's aspect ratio, so a long, flat mission does not
    leave the figure mostly empty.

    Parameters
    ----------
    res : SimulationResult
        A simulation result (see the module docstring for the attributes read).
    marker_every : float
        Time between formation snapshots, s.

    Returns
    -------
    matplotlib.figure.Figure
        One axes, in m.
    """
    t = np.asarray(res.t, dtype=float)
    states = np.asarray(res.states, dtype=float)
    xy = states[..., 0:2]
    centre = np.asarray(res.desired_center, dtype=float)
    pts = np.concatenate([xy.reshape(-1, 2), centre.reshape(-1, 2)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    pad = TRAJECTORY_MARGIN * span.max()
    n = xy.shape[1]
    many = n > MAX_VEHICLE_LINES  # a large fleet gets one legend entry for all its paths
    legend_rows = 1 if many else -(-(n + 2) // 6)
    # axes about 9.1 in wide; title, x label and the legend rows below take about 1.1 + 0.25/row in
    axes_height = float(np.clip(9.1 * (span[1] + 2 * pad) / (span[0] + 2 * pad), 2.0, 8.0))
    fig, ax = plt.subplots(figsize=(10.0, axes_height + 1.1 + 0.25 * legend_rows), constrained_layout=True)
    colours = [f"C{i % 10}" for i in range(n)]
    for i, label in enumerate(_vehicle_labels(n)):
        if many:
            label = f"paths of the {n} vehicles" if i == 0 else "_"
        ax.plot(xy[:, i, 0], xy[:, i, 1], lw=0.6 if many else 1, color=colours[i], label=label)
    ax.plot(centre[:, 0], centre[:, 1], "k--", lw=0.8, label="desired centre")
    arrow_len = 0.03 * span.max()
    for k in _snapshot_indices(t, marker_every):
        snap = xy[k]
        ax.fill(snap[:, 0], snap[:, 1], fill=False, ec="0.45", lw=0.7)
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
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{_scenario_name(res)}: paths; formation and headings every {marker_every:g} s")
    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], color="0.3", marker=">", ls="-", lw=1, ms=5))
    labels.append("heading psi")
    fig.legend(handles, labels, loc="outside lower center", fontsize=7, ncol=min(len(labels), 6))
    return fig


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
    fig, axes = _per_vehicle_axes(
        res.t,
        np.asarray(res.states, dtype=float)[:, :, 3:6],
        ("u [m/s]", "v [m/s]", "r [rad/s]"),
        _envelope_ranges(env),
    )
    envelope_note = "" if env is None else " (dotted: certified envelope)"
    axes[0].set_title(f"{_scenario_name(res)}: surge, sway and yaw rate{envelope_note}")
    return fig


def _per_vehicle_axes(
    t: Any, data: FloatArray, labels: tuple[str, str, str], ranges: Any = (None, None, None)
) -> tuple[Figure, Any]:
    """Three stacked axes of ``data[:, i, k]`` (one line per vehicle i, axis k), bounds dotted."""
    n = data.shape[1]
    tt = np.asarray(t, dtype=float)
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True, constrained_layout=True)
    for ax, k, label, rng in zip(axes, range(3), labels, ranges):
        if n <= MAX_VEHICLE_LINES:
            lines = ax.plot(tt, data[:, :, k], lw=1)
            for line, name in zip(lines, _vehicle_labels(n)):
                line.set_label(name)
        else:  # a large fleet: its range, the 5-95 % band and the median, not n lines
            lo, p5, p50, p95, hi = np.percentile(data[:, :, k], [0, 5, 50, 95, 100], axis=1)
            ax.fill_between(tt, lo, hi, color="C0", alpha=0.2, lw=0, label="min - max")
            ax.fill_between(tt, p5, p95, color="C0", alpha=0.45, lw=0, label="5 - 95 %")
            ax.plot(tt, p50, color="C0", lw=1.2, label="median")
        for b in rng or ():
            ax.axhline(b, color="r", ls=":", lw=0.8)
        ax.set_ylabel(label)
    _vehicle_legend(axes[0], n)
    axes[-1].set_xlabel("t [s]")
    return fig, axes


def errors(res: SimulationResult) -> Figure:
    """Shape and centre error on a log scale.

    Parameters
    ----------
    res : SimulationResult
        A simulation result.

    Returns
    -------
    matplotlib.figure.Figure
        One axes, errors in m (floored at 1e-16 for the log scale).
    """
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    ax.semilogy(res.t, np.maximum(res.shape_error, 1e-16), label="shape error")
    ax.semilogy(res.t, np.maximum(res.center_error, 1e-16), label="centre error")
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
    if limits is None:
        act = getattr(getattr(getattr(res, "scenario", None), "law", None), "actuators", None)
        limits = None if act is None else act.limits()
    data = np.asarray(res.forces, dtype=float)
    fig, axes = _per_vehicle_axes(res.t, data, ("tau_x [N]", "tau_y [N]", "tau_psi [N m]"))
    notes = []
    for levels, label, word, style in (
        (_channel_levels("certified", certified), CERTIFIED_LABEL, "dashed", {"color": "k", "ls": "--"}),
        (_channel_levels("limits", limits), LIMIT_LABEL, "red", {"color": "r", "ls": "-"}),
    ):
        for ax, level in zip(axes, levels or ()):
            ax.axhline(level, label=label, lw=1.2, **style)
            ax.axhline(-level, label=f"_{label} (lower)", lw=1.2, **style)  # "_": not in the legend
        notes += [f"{word}: {label}"] if levels else []
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
    paths = []
    for name, fn in figures:
        fig = fn(res)
        path = Path(out) / f"{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


__all__ = [
    "CERTIFIED_LABEL",
    "LIMIT_LABEL",
    "MAX_VEHICLE_LINES",
    "TRAJECTORY_MARGIN",
    "errors",
    "forces",
    "save_simulation_plots",
    "trajectories",
    "velocities",
]
