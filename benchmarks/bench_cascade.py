"""Table 11: the certificate of the ILOS cascade of a torpedo fleet, its cost and how conservative it is.

``remus-transit-ilos``: three REMUS 100 on a straight transit at 1.5 m/s, masses +-3 %, damping
+-20 %, currents up to 0.1 m/s; the same fleet with every mass +-10 %, which the whole box's
certificate refuses and the cells of the box certify; and the same fleet in currents up to 0.2 m/s,
which cells of the current's along-track component certify; and the nominal fleet in still water on
late, noisy navigation (20 Hz, 0.05 s delay, small errors), against runs in every noise pattern;
and the ``remus-survey-ilos`` V on a lawn-mower of 200 m turns in a 0.05 m/s current (nominal plant).
Peers measured in the same run: one
simulated run of the fleet (the measurement the certificate replaces) and a campaign of runs
over the box and the currents. The user's path is ``auv-hinf certify`` on the preset's TOML file
(a fresh process). Conservatism: the certified bounds against the worst of the campaign (box
vertices first, currents at the bound).

Run alone with ``python benchmarks/bench_cascade.py`` (prints the table).
"""

from __future__ import annotations

import math
import os
from typing import Any

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
from common import REPEATS, cli_certify_seconds, median_seconds, table

import auv_hinf.cascade.certificate as cascade
import auv_hinf.implementation.peak as peak_module
from auv_hinf.campaign.guidance import run_guidance_campaign
from auv_hinf.certificate.parts.guidance import guidance_summary
from auv_hinf.certificate.run_plan import guidance_run
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import FormationConfig, config_from_dict

#: Runs of the campaign the bounds are measured against (the first half are box vertices).
CAMPAIGN_RUNS = 16
#: Horizon of every simulated run (s).
HORIZON = 300.0
#: The masses' multipliers of the second fleet: the whole box is refused, its cells certify.
WIDE_MASSES = (0.9, 1.1)


def wide_masses() -> FormationConfig:
    """``remus-transit-ilos`` with every mass uncertain by :data:`WIDE_MASSES`."""
    data = preset_config("remus-transit-ilos").to_toml_dict()
    data["uncertainty"] = {**data["uncertainty"], **{k: list(WIDE_MASSES) for k in ("m11", "m22", "m33")}}
    data["name"] = "remus-transit-ilos, masses +-10 %"
    return config_from_dict(data)


#: The current of the third fleet (m/s): across the track at the bound, which the whole range of
#: currents does not certify and cells of its along-track component do.
STRONG_CURRENT = 0.2


def strong_current() -> FormationConfig:
    """``remus-transit-ilos`` in currents up to :data:`STRONG_CURRENT` (simulated across the track)."""
    data = preset_config("remus-transit-ilos").to_toml_dict()
    data["disturbance"] = {**data["disturbance"], "current_speed": STRONG_CURRENT}
    data["simulation"] = {**data["simulation"], "current": [0.0, STRONG_CURRENT]}
    data["name"] = f"remus-transit-ilos, currents up to {STRONG_CURRENT} m/s"
    return config_from_dict(data)


#: The late, noisy navigation of the fourth fleet: ``[implementation]`` sample time and delay (s) and
#: the noise bounds (m, m/s, rad, rad/s), on the nominal plant in still water (the box and the current
#: on top are refused; docs/guidance.md, "Delay and measurement noise").
NAVIGATION = {
    "sample_time": 0.05,
    "delay": 0.05,
    "noise": {"position": 0.02, "velocity": 0.0005, "heading": 0.002, "yaw_rate": 0.001},
}


def late_navigation() -> FormationConfig:
    """``remus-transit-ilos`` on its nominal plant in still water, on the :data:`NAVIGATION` navigation."""
    data = preset_config("remus-transit-ilos").to_toml_dict()
    data.pop("uncertainty", None)
    data["disturbance"] = {}
    data["implementation"] = NAVIGATION
    data["simulation"] = {**data["simulation"], "current": [0.0, 0.0], "noise_pattern": "mixed"}
    data["name"] = "remus-transit-ilos, nominal, late noisy navigation"
    return config_from_dict(data)


#: The fifth fleet: the ``remus-survey-ilos`` V (five REMUS 100, path frame) on a lawn-mower of 200 m
#: turns in currents up to 0.05 m/s, the nominal plant, with the ``remus-transit-ilos`` gains: what
#: the cascade's certificate covers on turns (docs/derivations/guidance.md, "Turns").
SURVEY_TURNS = {"turn_radius": 200.0, "spacing": 810.0}
SURVEY_CURRENT = 0.05
#: Its runs' horizon (s): the first leg, the first turn and part of the second leg.
SURVEY_HORIZON = 800.0


def survey_turns() -> FormationConfig:
    """The V of ``remus-survey-ilos`` on the :data:`SURVEY_TURNS` lawn-mower in :data:`SURVEY_CURRENT`."""
    data = preset_config("remus-survey-ilos").to_toml_dict()
    data.pop("uncertainty", None)
    data["guidance"] = {**data["guidance"], "heading_bandwidth": 2.4, "lookahead": 16.0}
    data["reference"] = {**data["reference"], **SURVEY_TURNS}
    data["disturbance"] = {"current_speed": SURVEY_CURRENT}
    data["simulation"] = {**data["simulation"], "current": [0.0, SURVEY_CURRENT]}
    data["name"] = "remus-survey-ilos V, 200 m turns, nominal plant, 0.05 m/s"
    return config_from_dict(data)


def _by_cells(
    cfg: FormationConfig,
) -> tuple[cascade.CascadeCertificate, cascade.CascadeCertificate, float, dict[str, Any]]:
    """``cfg``'s whole refusal, its certificate by cells, the latter's median time (s, cold caches) and the
    summary of a campaign on it."""
    problem = guidance_summary(cfg).problem
    assert problem is not None
    whole = cascade.certify_cascade(problem, cells=False)
    cells = _cold(problem)
    assert not whole.holds and cells.holds and cells.error_bounds is not None and cells.actuation is not None
    seconds = median_seconds(lambda: _cold(problem))
    return whole, cells, seconds, run_guidance_campaign(cfg, CAMPAIGN_RUNS, seed=0, horizon=HORIZON).summary()


def _whole(cfg: FormationConfig, horizon: float) -> tuple[cascade.CascadeCertificate, float, dict[str, Any]]:
    """``cfg``'s certificate (certified, with its bounds), its median time (s, cold caches) and the summary of a
    campaign of ``horizon`` s on it."""
    problem = guidance_summary(cfg).problem
    assert problem is not None
    cert = _cold(problem)
    assert cert.holds and cert.error_bounds is not None and cert.actuation is not None
    seconds = median_seconds(lambda: _cold(problem))
    return cert, seconds, run_guidance_campaign(cfg, CAMPAIGN_RUNS, seed=0, horizon=horizon).summary()


def _cold(problem: cascade.CascadeProblem) -> cascade.CascadeCertificate:
    """The cascade's certificate with its caches emptied (a first call: the loop's peak gains included)."""
    cascade._loop_analysis.cache_clear()
    cascade.certify_cascade.cache_clear()
    return cascade.certify_cascade(problem)


def _warm(problem: cascade.CascadeProblem) -> cascade.CascadeCertificate:
    """The fixed point alone, the loop's peak gains cached (what a bisection of the advice pays per step)."""
    cascade.certify_cascade.cache_clear()
    return cascade.certify_cascade(problem)


#: How the nominal loop's peak gains are summed: the product's way, and three peers measured beside it.
#: ``"deflated"``: until the tail bound, with the period map's slowest modes deflated, exceeds the exact
#: rest by at most TAIL_RTOL of each gain (the deflated lower bound or the signed sum's); ``"signed"``: the
#: same without the deflation, the outputs' Gramian tails against the signed sum (the method before the
#: deflation); ``"gramian"``: until the Gramian tail itself is below TAIL_RTOL of each gain (before the
#: signed sum); ``"contraction"``: the same with the contraction's tail alone and no zero floor (before
#: the outputs' Gramian tails).
SUMS = ("deflated", "signed", "gramian", "contraction")


class _NoLowerBound:
    """A stand-in of the signed sums that gives no lower bound (err = inf): the tail must itself be small,
    and both signs of the kernel get the whole tail, as before the signed sums."""

    def __init__(self, rows: int) -> None:
        self.rows = rows

    @classmethod
    def of(cls, stack: Any, *_: Any) -> _NoLowerBound:
        return cls(stack.shape[0])

    def __call__(self, state: Any) -> tuple[Any, Any]:
        shape = (self.rows, state.shape[1])
        return np.zeros(shape), np.full(shape, np.inf)


def _peak_gains(problem: cascade.CascadeProblem, how: str) -> peak_module.PeakGains:
    """The cascade's nominal loop's peak gains, cold, summed as ``how`` says (:data:`SUMS`)."""
    loop = cascade.cascade_loop(problem, problem.turns)
    saved = peak_module.GRAMIAN_AFTER, peak_module.ZERO_RTOL, peak_module._SignedSums, peak_module._deflation
    if how != "deflated":
        peak_module._deflation = lambda *_: None  # type: ignore[assignment]
    if how in ("gramian", "contraction"):
        peak_module._SignedSums = _NoLowerBound  # type: ignore[misc,assignment]
    if how == "contraction":
        peak_module.GRAMIAN_AFTER, peak_module.ZERO_RTOL = math.inf, 0.0
    try:
        peak_module._maps.cache_clear()
        peak_module._period.cache_clear()
        gains = peak_module.peak_gains(loop)
    finally:
        (peak_module.GRAMIAN_AFTER, peak_module.ZERO_RTOL, peak_module._SignedSums, peak_module._deflation) = saved  # type: ignore[misc]
    assert gains is not None
    return gains


def _tail_change(problem: cascade.CascadeProblem) -> float:
    """Largest relative change of any nonzero peak gain from the contraction's tail alone to the product's sum."""
    new, old = _peak_gains(problem, "deflated"), _peak_gains(problem, "contraction")
    reached = new.continuous > 0.0
    return float((abs(new.continuous - old.continuous)[reached] / old.continuous[reached]).max())


def _ratios(bounds: dict[str, float], worst: dict[str, float]) -> str:
    """``name certified / worst = ratio`` of the along-track, cross-track and heading errors."""
    names = ("along_track", "cross_track", "heading")
    return ", ".join(f"{k} {bounds[k]:.3g} / {worst[k]:.3g} = {bounds[k] / worst[k]:.3g}" for k in names)


def _command_ratios(cert: cascade.CascadeCertificate, camp: dict[str, Any]) -> str:
    """``thrust <ratio>, rudder <ratio>``: the certified peaks over the campaign's worst commanded ones."""
    a, worst = cert.actuation, camp["worst_commanded_peak"]
    assert a is not None
    return f"thrust {a.thrust / worst['force_x']:.2f}, rudder {a.rudder / worst['rudder']:.3g}"


def cascade_cost() -> str:
    cfg = preset_config("remus-transit-ilos")
    problem = guidance_summary(cfg).problem
    assert problem is not None
    cert = _cold(problem)
    assert cert.holds and cert.error_bounds is not None and cert.actuation is not None
    t_cold = median_seconds(lambda: _cold(problem))
    t_warm = median_seconds(lambda: _warm(problem))
    t_run = median_seconds(lambda: guidance_run(cfg, horizon=HORIZON))
    t_cli = cli_certify_seconds(cfg.to_toml_dict())
    t_gains = median_seconds(lambda: _peak_gains(problem, "deflated"))
    t_gains_signed = median_seconds(lambda: _peak_gains(problem, "signed"))
    t_gains_tail = median_seconds(lambda: _peak_gains(problem, "gramian"))
    t_gains_peer = median_seconds(lambda: _peak_gains(problem, "contraction"))
    tail_change = _tail_change(problem)
    camp = run_guidance_campaign(cfg, CAMPAIGN_RUNS, seed=0, horizon=HORIZON)
    s = camp.summary()
    worst, peak = s["worst_errors"], s["worst_commanded_peak"]
    b, a = cert.error_bounds, cert.actuation
    whole, cells, t_cells, wide_camp = _by_cells(wide_masses())
    strong_whole, ranges, t_ranges, strong_camp = _by_cells(strong_current())
    nav, t_nav, nav_camp = _whole(late_navigation(), HORIZON)
    turns, t_turns, turns_camp = _whole(survey_turns(), SURVEY_HORIZON)
    assert cells.actuation is not None and cells.error_bounds is not None and ranges.error_bounds is not None
    rows = [
        ["cascade certificate (cold caches: peak gains and fixed point)", f"{t_cold:.2f}", "yes"],
        ["cascade certificate, peak gains cached (one step of the advice's bisection)", f"{t_warm:.3f}", "yes"],
        ["the nominal loop's peak gains, its slowest modes deflated", f"{t_gains:.2f}", "-"],
        ["the same, Gramian tails against the signed sum (peer: before the deflation)", f"{t_gains_signed:.2f}", "-"],
        ["the same, summed until the Gramian tail is below 1e-4 (peer: before that)", f"{t_gains_tail:.2f}", "-"],
        ["the same, the contraction's tail alone (peer: before the Gramian)", f"{t_gains_peer:.2f}", "-"],
        [f"one simulated run of the fleet, {HORIZON:.0f} s (peer)", f"{t_run:.2f}", "-"],
        ["CLI `certify --json` of the preset (a fresh process)", f"{t_cli:.1f}", "yes"],
        [f"masses +-10 %: the whole box ({cells.cells} cells of it, cold caches)", f"{t_cells:.1f}", "yes"],
        [
            f"currents up to {STRONG_CURRENT} m/s ({ranges.current_cells} ranges of the along-track current, cold)",
            f"{t_ranges:.1f}",
            "yes",
        ],
        ["nominal fleet, 20 Hz, 0.05 s delay, measurement noise (cold caches)", f"{t_nav:.2f}", "yes"],
        ["survey V on a lawn-mower, 200 m turns, 0.05 m/s, nominal plant (cold caches)", f"{t_turns:.2f}", "yes"],
    ]
    wa, wpeak = cells.actuation, wide_camp["worst_commanded_peak"]
    wide_ratios = _ratios(cells.error_bounds, wide_camp["worst_errors"])
    ratios = _ratios(b, worst)
    note = (
        f"Medians of {REPEATS} runs, BLAS pinned to one thread. Three REMUS 100 on a straight transit at 1.5 m/s, "
        "masses +-3 %, damping +-20 %, currents up to 0.1 m/s, the cascade at 10 Hz. Conservatism against the worst "
        f"of a {CAMPAIGN_RUNS}-run campaign of {HORIZON:.0f} s ({s['vertex_runs']} box vertices, currents at the "
        f"bound in random directions; {s['covered_runs']} runs covered, {s['runs_outside_bounds']} outside their "
        f"bounds), certified / worst: {ratios}; thrust {a.thrust:.3g} N / {peak['force_x']:.3g} N = "
        f"{a.thrust / peak['force_x']:.2f}; rudder {a.rudder:.3g} rad / {peak['rudder']:.3g} rad = "
        f"{a.rudder / peak['rudder']:.3g}. The certificate replaces the campaign: it covers every plant, current and "
        f"time at once in about the time of {t_cold / t_run:.1f} simulated runs. The nominal loop's peak gains sum "
        "the kernel over the periods until the bound of the rest exceeds the exact rest by at most 1e-4 of each "
        "gain, shown by a lower bound of the rest; with the period map's two slowest modes deflated (their sum "
        f"exact, the rest's decaying at its own rate) that is {t_gains_signed / t_gains:.1f}x sooner than with "
        f"each output's Gramian tail against the rest's signed sum, {t_gains_tail / t_gains:.1f}x sooner than "
        f"until the Gramian tail itself is below 1e-4, {t_gains_peer / t_gains:.1f}x sooner than with the "
        f"contraction's tail alone, and the nonzero gains move by at most {tail_change:.1e} (relative; pairs the "
        "loop does not connect are 0). With every mass +-10 % the "
        "whole "
        f"box is refused ({whole.reason}); its {cells.cells} cells certify it, each with its own nominal loop, "
        f"and against the worst of the same campaign on that box ({wide_camp['covered_runs']} runs covered, "
        f"{wide_camp['runs_outside_bounds']} outside their bounds): {wide_ratios}; thrust {wa.thrust:.3g} N / "
        f"{wpeak['force_x']:.3g} N = {wa.thrust / wpeak['force_x']:.2f}; rudder {wa.rudder:.3g} rad / "
        f"{wpeak['rudder']:.3g} rad = {wa.rudder / wpeak['rudder']:.3g}. In currents up to {STRONG_CURRENT} m/s "
        f"the whole range of currents is refused ({strong_whole.reason}); {ranges.current_cells} ranges of the "
        "current's along-track component (a constant of each run on a straight line) certify it, and against the "
        f"worst of the same campaign in those currents ({strong_camp['covered_runs']} runs covered, "
        f"{strong_camp['runs_outside_bounds']} outside their bounds): "
        f"{_ratios(ranges.error_bounds, strong_camp['worst_errors'])}. On late, noisy navigation (the nominal "
        f"plant in still water, 20 Hz, 0.05 s delay, errors up to {NAVIGATION['noise']}) against the same campaign "
        f"in the five noise patterns in turn ({nav_camp['covered_runs']} runs covered, "
        f"{nav_camp['runs_outside_bounds']} outside their bounds): "
        f"{_ratios(nav.error_bounds, nav_camp['worst_errors'])}; {_command_ratios(nav, nav_camp)}. "
        "The survey V on a lawn-mower "
        f"(five REMUS 100 in the path frame, 200 m turns, the transit's gains, the nominal plant, currents up to "
        f"{SURVEY_CURRENT} m/s) against a {CAMPAIGN_RUNS}-run campaign of {SURVEY_HORIZON:.0f} s through the first "
        f"turn, currents at the bound ({turns_camp['covered_runs']} runs covered, "
        f"{turns_camp['runs_outside_bounds']} outside their bounds): "
        f"{_ratios(turns.error_bounds, turns_camp['worst_errors'])}; {_command_ratios(turns, turns_camp)}."
    )
    return table(TITLE, ["what is timed", "seconds", "certified"], rows, note)


TITLE = f"11. The certificate of a torpedo fleet's ILOS cascade: cost and conservatism (medians of {REPEATS})"


if __name__ == "__main__":
    print(cascade_cost())
