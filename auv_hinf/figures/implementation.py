"""Figure of the implementation certificate against the sample time (notebook ``08_implementation``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from auv_hinf.implementation.sampled_data import ImplementationCertificate


def implementation_figure(
    sample_times: Sequence[float], certs: Sequence[ImplementationCertificate], title: str = ""
) -> Figure:
    """Decay rate and certified ultimate bounds against the sample time, with the two limits.

    Left: the certified decay rate (1/s); right: the ultimate position (m) and velocity (m/s)
    error bounds of the covered sample times. Vertical lines: the certified ``max_sample_time``
    (solid) and the exact nominal limit (dashed); beyond the first nothing is certified, beyond
    the second the nominal loop itself is unstable.

    Parameters
    ----------
    sample_times : sequence of float
        Sample times (s), one per certificate.
    certs : sequence of ImplementationCertificate
        The certificates; the limits drawn are those of the first.
    title : str
        Figure title (none when empty).
    """
    fig, (ax_rate, ax_bound) = plt.subplots(1, 2, figsize=(10.5, 3.8), constrained_layout=True)
    rates = [c.decay_rate if c.decay_rate is not None else math.nan for c in certs]
    ax_rate.plot(sample_times, rates, "o-", color="C0")
    ax_rate.set(xlabel="sample time h [s]", ylabel="certified decay rate [1/s]", xscale="log")
    pos = [c.ultimate.position if c.covers and c.ultimate else math.nan for c in certs]
    vel = [c.ultimate.velocity if c.covers and c.ultimate else math.nan for c in certs]
    ax_bound.plot(sample_times, pos, "o-", label="position error [m]")
    ax_bound.plot(sample_times, vel, "s-", label="velocity error [m/s]")
    ax_bound.set(xlabel="sample time h [s]", ylabel="certified ultimate bound", xscale="log", yscale="log")
    if certs:
        first = certs[0]
        for ax in (ax_rate, ax_bound):
            ax.axvline(first.max_sample_time, color="k", lw=1.2, label="certified max sample time")
            if math.isfinite(first.exact_max_sample_time):
                ax.axvline(first.exact_max_sample_time, color="k", ls="--", lw=1.2, label="exact nominal limit")
    ax_bound.legend(fontsize=8)
    ax_bound.set_title("covered sample times only", fontsize=9)
    if title:
        fig.suptitle(title)
    return fig


__all__ = ["implementation_figure"]
