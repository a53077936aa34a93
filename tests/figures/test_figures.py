"""Figures: legends, units, tight trajectory limits, headings, the sigma colour scale.

The simulation figures are fed a small synthetic stand-in with the attributes they read,
not a 300 s simulation.
"""

from __future__ import annotations

from collections.abc import Iterator
from types import SimpleNamespace

import matplotlib.colors as mcolors
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.collections import QuadMesh
from matplotlib.contour import ContourSet
from matplotlib.quiver import Quiver

from auv_hinf.actuation.limits import Actuators, RudderActuation
from auv_hinf.design.sigma import vehicle_sigma
from auv_hinf.exceptions import ParameterError
from auv_hinf.figures import sigma as sigma_figure
from auv_hinf.figures import simulation as plots
from auv_hinf.models.envelope import Envelope, envelope_lambda
from auv_hinf.models.vehicle import VehicleParams, paper2011

N_VEHICLES = 4
HORIZON = 120.0
SNAPSHOT_EVERY = 40.0


@pytest.fixture(autouse=True)
def _close_figures() -> Iterator[None]:
    yield
    plt.close("all")


def synthetic_result(n: int = N_VEHICLES, *, envelope: Envelope | None = None) -> SimpleNamespace:
    """A long, flat mission (300 m x 60 m) like the paper's, with turning headings."""
    t = np.linspace(0.0, HORIZON, 241)
    centre = np.column_stack([2.5 * t, 30.0 * np.sin(0.05 * t)])
    offsets = 8.0 * np.column_stack([np.cos(2 * np.pi * np.arange(n) / n), np.sin(2 * np.pi * np.arange(n) / n)])
    states = np.zeros((len(t), n, 6))
    states[..., 0:2] = centre[:, None, :] + offsets[None]
    states[..., 2] = np.arctan2(1.5 * np.cos(0.05 * t), 2.5)[:, None] + 0.1 * np.arange(n)[None]
    states[..., 3] = 2.5 + 0.1 * np.arange(n)[None]
    states[..., 4] = 0.05 * np.sin(t)[:, None]
    states[..., 5] = 0.02 * np.cos(t)[:, None]
    forces = np.stack([np.full((len(t), n), 100.0), np.zeros((len(t), n)), np.full((len(t), n), -3.0)], -1)
    forces = forces + np.arange(n)[None, :, None]
    # each vehicle's slot error decays from its own start error: vehicle i starts i/n m off its slot
    slot = (1.0 + np.arange(n) / n)[None, :] * np.exp(-t / 15.0)[:, None]
    return SimpleNamespace(
        t=t,
        states=states,
        forces=forces,
        shape_error=np.exp(-t / 10.0),
        center_error=0.5 * np.exp(-t / 20.0),
        mission_error=slot,
        desired_center=centre,
        scenario=SimpleNamespace(name="synthetic", envelope=envelope),
    )


def legend_texts(ax: plt.Axes) -> list[str]:
    legend = ax.get_legend()
    assert legend is not None, "axes has no legend"
    return [text.get_text() for text in legend.get_texts()]


@pytest.mark.parametrize("n", [2, N_VEHICLES, 12])
def test_velocity_legend_has_one_entry_per_vehicle(n):
    env = Envelope(u=(0.0, 3.5), v=(-1.0, 1.0), r=(-0.5, 0.5))
    fig = plots.velocities(synthetic_result(n, envelope=env))
    assert legend_texts(fig.axes[0]) == [f"AUV {i + 1}" for i in range(n)]
    assert [ax.get_ylabel() for ax in fig.axes] == ["u [m/s]", "v [m/s]", "r [rad/s]"]
    assert fig.axes[-1].get_xlabel() == "t [s]"
    # the envelope bounds are drawn as horizontal lines on each axes
    for ax, rng in zip(fig.axes, (env.u, env.v, env.r)):
        hlines = {line.get_ydata()[0] for line in ax.get_lines() if line.get_linestyle() == ":"}
        assert hlines == set(rng)


def test_velocity_figure_without_envelope():
    fig = plots.velocities(synthetic_result())
    assert all(line.get_linestyle() != ":" for ax in fig.axes for line in ax.get_lines())
    assert "envelope" not in fig.axes[0].get_title()


def test_force_legend_and_units():
    fig = plots.forces(synthetic_result())
    assert legend_texts(fig.axes[0]) == [f"AUV {i + 1}" for i in range(N_VEHICLES)]
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["tau_x [N]", "tau_y [N]", "tau_psi [N m]"]
    # each vehicle's line carries that vehicle's data
    res = synthetic_result()
    for i, line in enumerate(fig.axes[0].get_lines()):
        np.testing.assert_array_equal(line.get_ydata(), res.forces[:, i, 0])


def test_a_rudder_vehicles_force_figure_draws_its_authority_at_the_runs_top_speed():
    """A torpedo's law saturates in a propeller and a rudder (no force box): the figure draws the thrust
    limit and the rudder's sway force and yaw moment at the largest surge speed of the run (they grow
    as u^2), and says so, instead of failing on a force box it does not have."""
    res = synthetic_result()
    rudder = RudderActuation(tau_x=67.0, rudder_max=0.2374, rudder_sway=9.64, rudder_yaw=-6.15)
    res.scenario.law = SimpleNamespace(actuators=rudder)
    fig = plots.forces(res)
    top = float(np.abs(res.states[..., 3]).max())
    want = (67.0, *rudder.authority(top))
    for ax, level in zip(fig.axes, want, strict=True):
        drawn = [ln.get_ydata()[0] for ln in ax.get_lines() if ln.get_label().startswith(plots.LIMIT_LABEL)]
        assert drawn == pytest.approx([level]), (ax.get_ylabel(), drawn, level)
    assert f"the rudder's at {top:.3g} m/s" in fig.axes[0].get_title()


def test_error_figure_units():
    fig = plots.errors(synthetic_result())
    (ax,) = fig.axes
    assert ax.get_ylabel() == "error [m]"
    assert ax.get_xlabel() == "t [s]"
    assert ax.get_yscale() == "log"
    assert legend_texts(ax) == ["shape error", "centre error"]


def test_trajectory_headings_are_arrows_along_psi():
    res = synthetic_result()
    fig = plots.trajectories(res, marker_every=SNAPSHOT_EVERY)
    (ax,) = fig.axes
    quivers = [c for c in ax.collections if isinstance(c, Quiver)]
    snapshots = np.arange(0.0, HORIZON + 1e-9, SNAPSHOT_EVERY)
    assert len(quivers) == len(snapshots)
    for q, tm in zip(quivers, snapshots):
        k = int(np.argmin(np.abs(res.t - tm)))
        np.testing.assert_allclose(q.X, res.states[k, :, 0])
        np.testing.assert_allclose(q.Y, res.states[k, :, 1])
        np.testing.assert_allclose(np.arctan2(q.V, q.U), res.states[k, :, 2], atol=1e-12)
    (legend,) = fig.legends
    labels = [text.get_text() for text in legend.get_texts()]
    assert labels[:N_VEHICLES] == [f"AUV {i + 1}" for i in range(N_VEHICLES)]
    assert "desired centre" in labels and any("heading" in s for s in labels)
    assert ax.get_xlabel() == "x [m]" and ax.get_ylabel() == "y [m]"


def test_trajectory_limits_are_tight_and_axes_fill_the_figure():
    res = synthetic_result()
    fig = plots.trajectories(res)
    (ax,) = fig.axes
    fig.canvas.draw()
    pts = np.concatenate([res.states[..., 0:2].reshape(-1, 2), res.desired_center])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    # every point is shown, with at most a 5 % margin of the larger span on each side
    pad = 0.05 * (hi - lo).max()
    assert x0 <= lo[0] and x1 >= hi[0] and y0 <= lo[1] and y1 >= hi[1]
    assert lo[0] - x0 <= pad and x1 - hi[0] <= pad and lo[1] - y0 <= pad and y1 - hi[1] <= pad
    assert ax.get_aspect() == 1.0
    # equal aspect on a 5:1 mission must not leave the figure mostly white
    box = ax.get_position()
    assert box.width * box.height > 0.5


@pytest.fixture(scope="module")
def heatmap_inputs() -> tuple[SimpleNamespace, SimpleNamespace]:
    vehicle = paper2011()
    env = Envelope(u=(0.0, 3.5), v=(-1.0, 1.0), r=(-0.5, 0.5))
    lam = envelope_lambda(vehicle, env)
    sigma = vehicle_sigma(vehicle, env, lam, 3)
    cfg = SimpleNamespace(name="synthetic", vehicle=vehicle, envelope=env)
    cert = SimpleNamespace(lam=lam, sigma=sigma)
    return cfg, cert


def test_sigma_heatmap_colour_scale_is_the_data_range(heatmap_inputs):
    cfg, cert = heatmap_inputs
    fig = sigma_figure.sigma_heatmap(cfg, cert, resolution=41)
    meshes = [c for ax in fig.axes[:2] for c in ax.collections if isinstance(c, QuadMesh)]
    assert len(meshes) == 2
    data = np.concatenate([np.ravel(m.get_array()) for m in meshes])
    for m in meshes:
        assert m.get_clim() == pytest.approx((data.min(), data.max()), rel=0, abs=0)
    assert data.min() > 0.0  # the scale does not start at 0
    # the slices pass through the certified vertex: their maximum is the certified value
    assert data.max() == pytest.approx(cert.sigma.lower, rel=1e-12)
    assert data.max() <= cert.sigma.upper
    assert fig.axes[2].get_ylabel().endswith("[1/s]"), "the colour bar is labelled in 1/s"


def figure_legend_texts(fig: plt.Figure) -> list[str]:
    assert len(fig.legends) == 1
    return [text.get_text() for text in fig.legends[0].get_texts()]


def test_sigma_heatmap_marks_vertex_and_explains_contour(heatmap_inputs):
    cfg, cert = heatmap_inputs
    fig = sigma_figure.sigma_heatmap(cfg, cert, resolution=41)
    u_w, v_w, r_w = (getattr(cert.sigma.witness, k)[0] for k in ("u", "v", "r"))
    for ax, at in zip(fig.axes[:2], (u_w, v_w)):
        stars = [line for line in ax.get_lines() if line.get_marker() == "*"]
        assert len(stars) == 1
        assert (stars[0].get_xdata()[0], stars[0].get_ydata()[0]) == pytest.approx((at, r_w))
    labels = figure_legend_texts(fig)
    assert any("certified vertex" in s for s in labels)
    # on these slices sigma stays above 90 % of the certified value: the legend says so
    (contour_label,) = [s for s in labels if "90%" in s]
    assert "not reached" in contour_label
    assert all(len(ax.collections) == 1 for ax in fig.axes[:2])


def test_sigma_heatmap_contour_at_ninety_percent():
    """Surge drag spans [0, 1.75] 1/s, sway drag is constant: the 90 % level is crossed."""
    vehicle = VehicleParams(200.0, 210.0, 80.0, 0.0, 100.0, 100.0, 0.0, 50.0, 0.0)
    env = Envelope(u=(0.0, 3.5), v=(-0.5, 0.5), r=(-0.2, 0.2))
    lam = envelope_lambda(vehicle, env)
    sigma = vehicle_sigma(vehicle, env, lam, 3)
    cfg = SimpleNamespace(name="wide", vehicle=vehicle, envelope=env)
    fig = sigma_figure.sigma_heatmap(cfg, SimpleNamespace(lam=lam, sigma=sigma), resolution=41)
    contours = [c for ax in fig.axes[:2] for c in ax.collections if isinstance(c, ContourSet)]
    assert contours, "the 90 % level lies inside the plotted range"
    for c in contours:
        assert list(c.levels) == pytest.approx([0.9 * sigma.upper])
    (contour_label,) = [s for s in figure_legend_texts(fig) if "90%" in s]
    assert "not reached" not in contour_label


@pytest.mark.slow
def test_save_simulation_plots_writes_four_pngs(tmp_path):
    paths = plots.save_simulation_plots(synthetic_result(), tmp_path)
    assert [p.name for p in paths] == ["trajectories.png", "velocities.png", "errors.png", "forces.png"]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert plt.get_fignums() == []


CERTIFIED = (150.0, 20.0, 8.0)
LIMITS = (200.0, 60.0, 12.0)


def labelled_levels(ax: plt.Axes, label: str) -> list[tuple[float, str, str]]:
    """``(y, linestyle, colour)`` of the horizontal lines of ``ax`` labelled ``label`` or ``_label (lower)``."""
    out = []
    for line in ax.get_lines():
        if line.get_label() in (label, f"_{label} (lower)"):
            y = np.asarray(line.get_ydata(), dtype=float)
            assert np.all(y == y[0]), "a bound is a horizontal line"
            out.append((float(y[0]), line.get_linestyle(), mcolors.to_hex(line.get_color())))
    return sorted(out)


def test_force_figure_draws_the_certified_bound_and_the_actuator_limits():
    fig = plots.forces(synthetic_result(), certified=CERTIFIED, limits=LIMITS)
    assert len(fig.axes) == 3
    for ax, bound, limit in zip(fig.axes, CERTIFIED, LIMITS):
        assert labelled_levels(ax, "certified bound") == [(-bound, "--", "#000000"), (bound, "--", "#000000")]
        assert labelled_levels(ax, "actuator limit") == [(-limit, "-", "#ff0000"), (limit, "-", "#ff0000")]
        lo, hi = ax.get_ylim()
        assert lo <= -limit and hi >= limit, "the limits are inside the view"
    # one legend entry each (the lower lines are hidden), after the vehicles
    assert legend_texts(fig.axes[0]) == [f"AUV {i + 1}" for i in range(N_VEHICLES)] + [
        "certified bound",
        "actuator limit",
    ]
    title = fig.axes[0].get_title()
    assert "certified bound" in title and "actuator limit" in title
    # the vehicles' data lines are unchanged
    res = synthetic_result()
    for i, line in enumerate(fig.axes[0].get_lines()[:N_VEHICLES]):
        np.testing.assert_array_equal(line.get_ydata(), res.forces[:, i, 0])


def test_force_figure_without_bounds_draws_no_horizontal_lines():
    fig = plots.forces(synthetic_result())
    for ax in fig.axes:
        assert len(ax.get_lines()) == N_VEHICLES
        assert labelled_levels(ax, "certified bound") == [] and labelled_levels(ax, "actuator limit") == []
    assert "certified" not in fig.axes[0].get_title()


def test_force_figure_takes_the_limits_of_the_law_and_an_explicit_override():
    res = synthetic_result()
    res.scenario.law = SimpleNamespace(actuators=Actuators(*LIMITS))
    fig = plots.forces(res)
    for ax, limit in zip(fig.axes, LIMITS):
        assert [y for y, _, _ in labelled_levels(ax, "actuator limit")] == [-limit, limit]
        assert labelled_levels(ax, "certified bound") == []
    assert legend_texts(fig.axes[0])[-1] == "actuator limit"
    other = (300.0, 70.0, 15.0)
    fig = plots.forces(res, limits=other)
    for ax, limit in zip(fig.axes, other):
        assert [y for y, _, _ in labelled_levels(ax, "actuator limit")] == [-limit, limit]


@pytest.mark.parametrize("bad", [(1.0, 2.0), (1.0, -2.0, 3.0), (1.0, float("nan"), 3.0)])
def test_force_figure_rejects_bad_bounds(bad):
    with pytest.raises(ParameterError, match="certified"):
        plots.forces(synthetic_result(), certified=bad)
    with pytest.raises(ParameterError, match="limits"):
        plots.forces(synthetic_result(), limits=bad)


@pytest.mark.slow
def test_save_simulation_plots_passes_the_bound_and_limits_to_the_force_figure(tmp_path, monkeypatch):
    drawn: list[plt.Figure] = []
    real = plots.forces

    def spy(res, **kw):
        drawn.append(real(res, **kw))
        return drawn[-1]

    monkeypatch.setattr(plots, "forces", spy)
    paths = plots.save_simulation_plots(synthetic_result(), tmp_path, certified=CERTIFIED, limits=LIMITS)
    assert (tmp_path / "forces.png") in paths and plt.get_fignums() == []
    (fig,) = drawn
    for ax, bound, limit in zip(fig.axes, CERTIFIED, LIMITS):
        assert [y for y, _, _ in labelled_levels(ax, "certified bound")] == [-bound, bound]
        assert [y for y, _, _ in labelled_levels(ax, "actuator limit")] == [-limit, limit]


@pytest.mark.slow
def test_force_figure_of_a_simulated_run_with_actuators(tmp_path):
    """A real (short) certified run: the law's limits are drawn, its forces stay within the bound."""
    from dataclasses import replace

    from auv_hinf.certificate.run_plan import plan_run
    from auv_hinf.config.presets import preset_config
    from auv_hinf.simulation.engine import simulate

    cfg = replace(preset_config("paper-triangle"), actuators=Actuators(1400.0, 400.0, 250.0))
    plan = plan_run(cfg, horizon=5.0, samples=51)
    assert plan.covered and plan.coverage is not None and plan.coverage.thrust is not None
    res = simulate(plan.scenario)
    certified = plan.coverage.thrust.as_tuple()
    fig = plots.forces(res, certified=certified)
    for ax, k in zip(fig.axes, range(3)):
        assert [y for y, _, _ in labelled_levels(ax, "actuator limit")] == [
            -cfg.actuators.limits()[k],
            cfg.actuators.limits()[k],
        ]
        assert [y for y, _, _ in labelled_levels(ax, "certified bound")] == [-certified[k], certified[k]]
        assert np.abs(res.forces[..., k]).max() <= certified[k]
    assert len(plots.save_simulation_plots(res, tmp_path, certified=certified)) == 4


@pytest.mark.slow
def test_large_fleets_are_drawn_as_bands_without_warnings():
    n = plots.MAX_VEHICLE_LINES + 188  # 200 vehicles
    res = synthetic_result(n)
    for fig in (plots.velocities(res), plots.forces(res), plots.trajectories(res, marker_every=SNAPSHOT_EVERY)):
        for ax in fig.axes:
            labels = [t.get_text() for t in ax.get_legend().get_texts()] if ax.get_legend() else []
            assert len(labels) <= plots.WORST_VEHICLES + 3, labels  # a few band entries, not 200
        fig.canvas.draw()  # constrained layout runs here; a collapsed layout would warn (an error in pytest)
    top = plots.forces(res).axes[0]
    assert {"min - max", "5 - 95 %", "median"} <= {t.get_text() for t in top.get_legend().get_texts()}
    # the median line is the fleet's median of the data
    median = next(line for line in top.get_lines() if line.get_label() == "median")
    np.testing.assert_allclose(median.get_ydata(), np.median(res.forces[:, :, 0], axis=1))


def test_guidance_errors_draw_the_certified_bounds_in_physical_units():
    from auv_hinf.figures.guidance import guidance_errors

    t = np.linspace(0.0, 10.0, 11)
    run = SimpleNamespace(
        t=t,
        along_track=np.zeros((11, 2)),
        cross_track=np.zeros((11, 2)),
        heading_error=np.zeros((11, 2)),
    )
    bounds = {"along_track": 0.03, "cross_track": 0.6, "heading": 0.001}
    fig = guidance_errors(run, bounds)
    levels = [
        sorted(
            {
                round(float(line.get_ydata()[0]), 9)
                for line in ax.lines
                if len(set(line.get_ydata())) == 1 and len(line.get_ydata()) == 2
            }
        )
        for ax in fig.axes
    ]
    # plus and minus each bound, the heading's in degrees
    assert levels == [[-0.03, 0.03], [-0.6, 0.6], [round(-np.degrees(0.001), 9), round(np.degrees(0.001), 9)]]
    plt.close(fig)
    bare = guidance_errors(run)
    assert all(len(ax.lines) == 2 for ax in bare.axes)  # one line per vehicle, no bound
    plt.close(bare)


@pytest.mark.parametrize(("horizon", "every"), [(30.0, 5.0), (300.0, 50.0), (900.0, 200.0), (3000.0, 500.0)])
def test_the_default_snapshots_follow_the_run_length(horizon, every):
    """About SNAPSHOTS formation snapshots whatever the horizon, at a round interval (1, 2 or 5 x 10^k s)."""
    got = plots.snapshot_interval(horizon)
    assert got == pytest.approx(every)
    assert plots.SNAPSHOTS / 2.5 <= horizon / got <= plots.SNAPSHOTS


def _guidance_record(certified: bool) -> dict:
    """A ``certify --json`` object of a guidance fleet, as much of it as its certificate figure reads."""
    largest = {"current_speed": None if certified else 0.0293, "box_scale": None, "navigation_scale": None}
    return {
        "preset": "torpedoes",
        "certified": certified,
        "guidance": {
            "kind": "ilos",
            "certified": certified,
            "current_speed": 0.2,
            "error_bounds": {"along_track": 0.16, "cross_track": 0.17, "heading": 4e-4} if certified else None,
            "certified_peak": {"force_x": 5.7, "rudder": 0.0069} if certified else None,
            "limits": {"force_x": 67.0, "rudder": 0.2374},
            "largest_certifiable": largest,
        },
        "formation": {
            "certified": certified,
            "min_separation": 2.0,
            "min_separation_certified": 14.5 if certified else None,
            "slot_distance": 15.0,
        },
    }


def _bar_widths(ax) -> list[float]:
    return [p.get_width() for p in ax.patches]


def test_a_certified_guidance_fleet_is_drawn_against_its_limits_and_its_bounds():
    from auv_hinf.figures.guidance import guidance_certificate_figure

    use, apart, bounds = guidance_certificate_figure(_guidance_record(True)).axes
    # the actuators as fractions of their limits (the limit is drawn at 1), the distances and the bounds in m
    assert _bar_widths(use) == pytest.approx([5.7 / 67.0, 0.0069 / 0.2374])
    assert [line.get_xdata()[0] for line in use.lines] == [1.0]
    assert _bar_widths(apart) == pytest.approx([2.0, 14.5, 15.0])
    assert _bar_widths(bounds) == pytest.approx([0.16, 0.17]) and "0.0229 deg" in bounds.get_title()


def test_a_refused_guidance_fleet_is_drawn_with_the_value_that_certifies_against_the_declared():
    from auv_hinf.figures.guidance import guidance_certificate_figure

    fig = guidance_certificate_figure(_guidance_record(False))
    use, apart, answer = fig.axes
    assert not use.patches and "does not hold" in use.texts[0].get_text()
    assert _bar_widths(apart) == pytest.approx([2.0, 15.0])  # no certified closest approach: said in words
    assert any(t.get_text().strip() == "none certified" for t in apart.texts)
    assert _bar_widths(answer) == pytest.approx([0.2, 0.0293])  # the declared current, and the answer's
    assert "NOT certified" in fig.texts[0].get_text()
