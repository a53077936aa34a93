"""The certificate's figure: the sigma heat map of the operating envelope.

:func:`sigma_heatmap` draws ``||G - lam I||`` over the envelope's ``(u, v)`` plane at the
yaw-rate of the certified witness, with the certified sigma as a contour; the run figures are in
:mod:`auv_hinf.figures.simulation`. Figures are returned, never shown.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from auv_hinf.design.sigma import sigma_grid
from auv_hinf.figures.simulation import PNG_DPI

if TYPE_CHECKING:
    from auv_hinf.certificate.assembly import Certificate
    from auv_hinf.config.settings import FormationConfig

#: Level of the contour drawn on the sigma heatmap, as a fraction of the certified sigma.
SIGMA_CONTOUR_FRACTION = 0.9


def _witness_vertex(cert: Certificate) -> tuple[float, float, float] | None:
    """The ``(u, v, r)`` vertex at which the certified vehicle sigma is attained, if recorded."""
    witness = getattr(cert.sigma, "witness", None)
    try:
        return float(witness.u[0]), float(witness.v[0]), float(witness.r[0])  # type: ignore[union-attr]
    except (AttributeError, IndexError, TypeError, ValueError):
        return None


def sigma_heatmap(cfg: FormationConfig, cert: Certificate, resolution: int = 121) -> Figure:
    """Vehicle-coordinate sigma over two slices of the envelope, through the certified vertex.

    The left panel sweeps surge ``u`` and yaw rate ``r`` at the sway speed of the vertex
    where the certified sigma is attained; the right panel sweeps ``v`` and ``r`` at that
    vertex's surge speed. Both panels share one colour scale spanning the plotted values
    (from their minimum, not from 0). The white contour marks
    :data:`SIGMA_CONTOUR_FRACTION` (90 %) of the certified sigma and the star the
    certified vertex.

    Parameters
    ----------
    cfg : FormationConfig
        Configuration: vehicle parameters and envelope.
    cert : Certificate
        Its certificate: ``lam`` and the vehicle-coordinate ``sigma``.
    resolution : int
        Grid points per axis.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels and a shared colour bar labelled in 1/s.
    """
    env, lam, upper = cfg.envelope, float(cert.lam), float(cert.sigma.upper)
    vertex = _witness_vertex(cert)
    if vertex is None:  # no witness recorded: slice at the largest speeds
        vertex = (max(abs(env.u[0]), abs(env.u[1])), max(abs(env.v[0]), abs(env.v[1])), env.r[1])
    u_w, v_w, r_w = vertex
    r = np.linspace(env.r[0], env.r[1], resolution)
    panels = []
    for axis, rng, other, at in (("u", env.u, abs(v_w), u_w), ("v", env.v, abs(u_w), v_w)):
        x = np.linspace(rng[0], rng[1], resolution)
        panels.append((axis, x, other, at, sigma_grid(cfg.vehicle, lam, x, r, axis=axis, other=other)))  # type: ignore[arg-type]
    lo = float(min(p[4].min() for p in panels))
    hi = float(max(p[4].max() for p in panels))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), constrained_layout=True, sharey=True)
    level = SIGMA_CONTOUR_FRACTION * upper
    im, contoured = None, False
    for ax, (axis, x, other, at, s) in zip(axes, panels):
        im = ax.pcolormesh(x, r, s, shading="auto", vmin=lo, vmax=hi, cmap="viridis")
        if s.min() < level < s.max():
            ax.contour(x, r, s, levels=[level], colors="w", linewidths=1.2)
            contoured = True
        ax.plot([at], [r_w], marker="*", ms=15, mfc="r", mec="w", ls="none", clip_on=False, zorder=4)
        ax.set_xlabel(f"{axis} [m/s]")
        fixed = "|v|" if axis == "u" else "|u|"
        ax.set_title(f"over ({axis}, r) at {fixed} = {other:.3g} m/s", fontsize=10)
    axes[0].set_ylabel("r [rad/s]")
    assert im is not None
    fig.colorbar(im, ax=list(axes), label="sigma = ||B - lam I|| [1/s]")
    contour_label = f"white contour: {SIGMA_CONTOUR_FRACTION:.0%} of certified sigma ({level:.3g} 1/s)"
    if not contoured:
        contour_label += f", not reached: sigma >= {lo:.3g} 1/s on these slices"
    handles = [
        Line2D([], [], color="w", mec="k", lw=1.2, label=contour_label),
        Line2D(
            [], [], marker="*", ms=12, mfc="r", mec="k", ls="none", label=f"certified vertex (sigma = {upper:.4g} 1/s)"
        ),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=8, facecolor="0.75")
    fig.suptitle(f"{cfg.name}: lambda = {lam:.3g} 1/s, certified sigma = {upper:.4g} 1/s")
    return fig


def save_sigma_heatmap(cfg: FormationConfig, cert: Certificate, path: Path) -> None:
    """Write :func:`sigma_heatmap` to ``path``.

    Parameters
    ----------
    cfg : FormationConfig
        Configuration.
    cert : Certificate
        Its certificate.
    path : pathlib.Path
        Image file; the format follows the suffix.
    """
    fig = sigma_heatmap(cfg, cert)
    fig.savefig(path, dpi=PNG_DPI)
    plt.close(fig)


__all__ = ["SIGMA_CONTOUR_FRACTION", "save_sigma_heatmap", "sigma_heatmap"]
