"""Every simulation figure at N = 3 and N = 1000: its legend entries, its colours, its units.

A vehicle's line (or the fleet's band) must never look like a line it is measured against: the
desired centre and the certified bound are black, the limits red, the outline and the density grey.
The rule is written here independently of the module's: a colour is red when its hue is within
20 degrees of red, grey when its HSV saturation is below 0.2 (tab20's greys are 0, its palest blue 0.25).
"""

from __future__ import annotations

import colorsys
import re
from collections.abc import Iterator

import matplotlib.colors as mcolors
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.quiver import Quiver

from auv_hinf.figures import simulation as plots
from auv_hinf.models.envelope import Envelope
from tests.figures.test_figures import synthetic_result

ENVELOPE = Envelope(u=(0.0, 3.5), v=(-1.0, 1.0), r=(-0.5, 0.5))
CERTIFIED, LIMITS = (150.0, 20.0, 8.0), (200.0, 60.0, 12.0)
#: Labels of the lines the vehicles are measured against (their lower twins are hidden from the legend).
REFERENCES = {"desired centre", plots.CERTIFIED_LABEL, plots.LIMIT_LABEL}
BANDS = ["min - max", "5 - 95 %", "median"]


@pytest.fixture(autouse=True)
def _close_figures() -> Iterator[None]:
    yield
    plt.close("all")


def reads_as_reference(colour: object) -> bool:
    """Red (hue within 20 degrees of red), grey or black (saturation below 0.2)."""
    hue, saturation, _ = colorsys.rgb_to_hsv(*mcolors.to_rgb(colour))
    return saturation < 0.2 or min(hue, 1.0 - hue) * 360.0 <= 20.0


def figures(n: int) -> dict[str, plt.Figure]:
    res = synthetic_result(n, envelope=ENVELOPE)
    return {
        "trajectories": plots.trajectories(res, marker_every=40.0),
        "velocities": plots.velocities(res),
        "errors": plots.errors(res),
        "forces": plots.forces(res, certified=CERTIFIED, limits=LIMITS),
    }


def data_colours(fig: plt.Figure) -> list[tuple[str, object]]:
    """``(what, colour)`` of every line, band and arrow that is not a reference: the vehicles and the fleet."""
    out: list[tuple[str, object]] = []
    for ax in fig.axes:
        for line in ax.get_lines():
            label = line.get_label().removeprefix("_").removesuffix(" (lower)")
            if label not in REFERENCES and line.get_linestyle() != ":":  # dotted: the envelope
                out.append((label, line.get_color()))
        for c in ax.collections:
            if isinstance(c, Quiver):
                out += [("heading", tuple(rgba)) for rgba in c.get_facecolor()]
            elif isinstance(c, PolyCollection) and c.get_array() is None:  # a band (a density has data)
                out += [(c.get_label(), tuple(rgba)) for rgba in c.get_facecolor()]
    return out


def legend_entries(fig: plt.Figure) -> list[list[str]]:
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend()] + list(fig.legends)
    return [[t.get_text() for t in legend.get_texts()] for legend in legends]


def check_units(fig: plt.Figure) -> None:
    for ax in fig.axes:
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            assert not label or re.search(r"\[.+\]$", label), label  # every axis label ends with its unit
    for entries in legend_entries(fig):
        for text in entries:  # a number in a legend carries its unit
            assert all(
                re.match(r"\s+(m|s|N|N m|m/s|rad|rad/s)\b", text[m.end() :]) for m in re.finditer(r"\d\.\d", text)
            )


@pytest.mark.slow
@pytest.mark.parametrize("n", [3, pytest.param(1000, marks=pytest.mark.slow)])
def test_every_figure_reads_at_this_fleet_size(n):
    figs = figures(n)
    for name, fig in figs.items():
        fig.set_dpi(
            30
        )  # the layout is in inches: a coarse draw runs it (a collapsed one warns) at a fraction of the cost
        fig.canvas.draw()
        colours = data_colours(fig)
        assert colours, name
        assert [what for what, c in colours if reads_as_reference(c)] == [], name
        check_units(fig)
    vehicles = [f"AUV {i + 1}" for i in range(n)]
    bound_and_limit = [plots.CERTIFIED_LABEL, plots.LIMIT_LABEL]
    assert legend_entries(figs["errors"]) == [["shape error", "centre error"]]
    if n <= plots.MAX_VEHICLE_LINES:
        assert legend_entries(figs["velocities"]) == [vehicles]
        assert legend_entries(figs["forces"]) == [vehicles + bound_and_limit]
        assert legend_entries(figs["trajectories"]) == [[*vehicles, "desired centre", "heading psi"]]
        lines = [line.get_color() for line in figs["velocities"].axes[0].get_lines() if line.get_linestyle() != ":"]
        assert len(set(lines)) == n  # one colour per vehicle
        return
    assert legend_entries(figs["velocities"]) == [BANDS]
    assert legend_entries(figs["forces"]) == [BANDS + bound_and_limit]
    # the trajectories: the density and the worst vehicles on the map, the slot-error bands below
    slot = synthetic_result(n).mission_error
    worst = np.argsort(slot.max(axis=0))[::-1][: plots.WORST_VEHICLES]
    on_map, below = legend_entries(figs["trajectories"])
    assert on_map[0] == f"positions of all {n} vehicles (density)" and on_map[-1] == "desired centre"
    assert on_map[1:-1] == [f"AUV {i + 1}: largest slot error {slot[:, i].max():.3g} m" for i in worst]
    assert below == BANDS + [f"AUV {i + 1}" for i in worst]
    ax_map, ax_err = figs["trajectories"].axes[:2]
    assert len(ax_map.get_lines()) == plots.WORST_VEHICLES + 1  # not a path per vehicle
    assert ax_err.get_ylabel() == "slot error |p_i - p_d,i| [m]" and ax_err.get_yscale() == "log"
    median = next(line for line in ax_err.get_lines() if line.get_label() == "median")
    np.testing.assert_allclose(median.get_ydata(), np.median(slot, axis=1))


def test_the_vehicle_colours_are_many_distinct_and_none_reads_as_a_reference():
    assert len(set(plots.VEHICLE_COLOURS)) == len(plots.VEHICLE_COLOURS) > plots.MAX_VEHICLE_LINES
    assert not any(reads_as_reference(c) for c in plots.VEHICLE_COLOURS)
    assert all(reads_as_reference(c) for c in (plots.REFERENCE_COLOUR, plots.LIMIT_COLOUR, plots.OUTLINE_COLOUR))
    assert reads_as_reference("C3") and not plots.distinct_from_references("C3")  # matplotlib's 4th: red
