"""Matplotlib figures. Every function returns a Figure; library code never calls show()."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from .sigma import sigma_grid

if TYPE_CHECKING:
    from .certificate import Certificate
    from .config import FormationConfig
    from .simulation import SimulationResult


def sigma_heatmap(cfg: "FormationConfig", cert: "Certificate", resolution: int = 121) -> Figure:
    """sigma = ||B - lam I|| over (u, r) and (v, r) slices, with the certified level marked."""
    env, lam = cfg.envelope, cert.lam
    r = np.linspace(env.r[0], env.r[1], resolution)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, axis, rng, other in (
        (axes[0], "u", env.u, max(abs(env.v[0]), abs(env.v[1]))),
        (axes[1], "v", env.v, max(abs(env.u[0]), abs(env.u[1]))),
    ):
        x = np.linspace(rng[0], rng[1], resolution)
        s = sigma_grid(cfg.vehicle, lam, x, r, axis=axis, other=other)  # type: ignore[arg-type]
        im = ax.pcolormesh(x, r, s, shading="auto", vmin=0, vmax=cert.sigma.upper)
        ax.contour(x, r, s, levels=[0.9 * cert.sigma.upper], colors="w", linewidths=0.8)
        ax.set_xlabel(f"{axis} [m/s]")
        ax.set_ylabel("r [rad/s]")
        fixed = "|v|" if axis == "u" else "|u|"
        ax.set_title(f"sigma over ({axis}, r), {fixed} = {other:g}")
        fig.colorbar(im, ax=ax, label="||G - lam I|| [1/s]")
    fig.suptitle(f"{cfg.name}: lambda = {lam:.3g}, certified sigma = {cert.sigma.upper:.4g}")
    return fig


def save_sigma_heatmap(cfg: "FormationConfig", cert: "Certificate", path: Path) -> None:
    """Write :func:`sigma_heatmap` to ``path``."""
    fig = sigma_heatmap(cfg, cert)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def trajectories(res: "SimulationResult", marker_every: float = 50.0) -> Figure:
    """Fig. 1 / Fig. 3: paths, the desired centre path and the formation every ``marker_every`` s."""
    fig, ax = plt.subplots(figsize=(10, 5), constrained_layout=True)
    xy = res.states[..., 0:2]
    for i in range(xy.shape[1]):
        ax.plot(xy[:, i, 0], xy[:, i, 1], lw=1, label=f"AUV {i + 1}")
    ax.plot(res.desired_center[:, 0], res.desired_center[:, 1], "k--", lw=0.8, label="desired centre")
    for tm in np.arange(0.0, res.t[-1] + 1e-9, marker_every):
        k = int(np.argmin(np.abs(res.t - tm)))
        pts = xy[k]
        ax.fill(pts[:, 0], pts[:, 1], fill=False, ec="0.4", lw=0.7)
        ax.plot(pts[:, 0], pts[:, 1], ">", color="0.2", ms=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{res.scenario.name}: trajectories, formation every {marker_every:g} s")
    ax.legend(loc="best", fontsize=8)
    return fig


def velocities(res: "SimulationResult") -> Figure:
    """Fig. 2: surge, sway and yaw rate of every vehicle, with the envelope bounds."""
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True, constrained_layout=True)
    env = res.scenario.envelope
    for ax, k, label, rng in zip(axes, (3, 4, 5), ("u [m/s]", "v [m/s]", "r [rad/s]"),
                                 (None if env is None else env.u, None if env is None else env.v, None if env is None else env.r)):
        ax.plot(res.t, res.states[:, :, k], lw=1)
        if rng is not None:
            for b in rng:
                ax.axhline(b, color="r", ls=":", lw=0.8)
        ax.set_ylabel(label)
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title("surge, sway and yaw rate (dotted: certified envelope)")
    return fig


def errors(res: "SimulationResult") -> Figure:
    """Shape and centre error on a log scale."""
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    ax.semilogy(res.t, np.maximum(res.shape_error, 1e-16), label="shape error [m]")
    ax.semilogy(res.t, np.maximum(res.center_error, 1e-16), label="centre error [m]")
    ax.set_xlabel("t [s]")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    return fig


def forces(res: "SimulationResult") -> Figure:
    """Thrust and moment of every vehicle."""
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True, constrained_layout=True)
    for ax, k, label in zip(axes, range(3), ("tau_x [N]", "tau_y [N]", "tau_psi [N m]")):
        ax.plot(res.t, res.forces[:, :, k], lw=1)
        ax.set_ylabel(label)
    axes[-1].set_xlabel("t [s]")
    return fig


def save_simulation_plots(res: "SimulationResult", out: Path) -> list[Path]:
    """Write the trajectory, velocity, error and force figures as PNGs into ``out``."""
    paths = []
    for name, fn in (("trajectories", trajectories), ("velocities", velocities), ("errors", errors), ("forces", forces)):
        fig = fn(res)
        path = Path(out) / f"{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
