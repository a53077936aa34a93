"""Figure of a replayed run: each vehicle's measured errors and measurement age against the certified bounds."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from auv_hinf.deployment.replay import ReplayResult
from auv_hinf.deployment.runtime import ERROR_CHANNELS, Assumptions


def replay_figure(result: ReplayResult, assumptions: Assumptions, title: str = "") -> Figure:
    """The four measured errors and the measurement age of every vehicle against their certified bounds.

    Parameters
    ----------
    result : ReplayResult
        A replay (:func:`~auv_hinf.deployment.replay.replay`).
    assumptions : Assumptions
        The certificate's assumptions (the age bound).
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Five panels sharing the time axis (s): ``|e|`` (m), ``|e'|`` (m/s), ``|e_psi|`` (rad),
        ``|e_r|`` (rad/s), each with its certified bound plus the noise (dashed), and the age (s)
        with ``delay - command_latency`` (dashed).
    """
    fig, axes = plt.subplots(5, 1, figsize=(8.0, 10.0), sharex=True, constrained_layout=True)
    n = result.errors.shape[1] if result.errors.ndim == 3 else 0
    for k, (name, unit) in enumerate(ERROR_CHANNELS):
        ax = axes[k]
        for i in range(n):
            ax.plot(result.times, result.errors[:, i, k], lw=1.0, label=f"vehicle {i + 1}")
        if result.allowed is not None:
            ax.axhline(float(result.allowed[k]), color="k", ls="--", lw=1.0, label="certified bound + noise")
        ax.set_ylabel(f"{name.replace('_', ' ')} error [{unit}]")
    for i in range(n):
        axes[4].plot(result.times, result.ages[:, i], lw=1.0, label=f"vehicle {i + 1}")
    axes[4].axhline(assumptions.measurement_age_bound, color="k", ls="--", lw=1.0, label="certified delay")
    axes[4].set(ylabel="measurement age [s]", xlabel="time [s]")
    for ax in axes:
        ax.legend(fontsize=7, loc="upper right")
    if title:
        fig.suptitle(title)
    return fig


def save_replay_figure(result: ReplayResult, assumptions: Assumptions, path: str | Path, title: str = "") -> Path:
    """Write :func:`replay_figure` as a PNG.

    Parameters
    ----------
    result : ReplayResult
        A replay.
    assumptions : Assumptions
        The certificate's assumptions.
    path : str or Path
        The PNG file (its folder is created).
    title : str
        Figure title.

    Returns
    -------
    Path
        The file written.
    """
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig = replay_figure(result, assumptions, title)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


__all__ = ["replay_figure", "save_replay_figure"]
