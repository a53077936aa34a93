"""The sub-commands of ``auv-hinf``: each takes the parsed arguments and returns the exit code.

Every command loads its configuration once, computes its design point once (through the
workflow layer) and reports its verdict as an exit code with one readable line on stderr for a
negative one (:func:`verdict`).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from auv_hinf._typing import GAIN_METHODS
from auv_hinf.actuation.limits import Actuators
from auv_hinf.certificate.document import json_safe
from auv_hinf.cli.args import EXIT_NEGATIVE, EXIT_OK, PROG, BadInput, Negative, Stopped
from auv_hinf.config.messages import input_warnings
from auv_hinf.config.schema import DEFAULT_SYNTHESIS
from auv_hinf.config.settings import FormationConfig
from auv_hinf.exceptions import AuvHinfError, ConfigError, DesignError, Interrupted, ParameterError, SolverError
from auv_hinf.files import write_text

if TYPE_CHECKING:  # the run plan imports the certificates: each command imports what it runs
    from auv_hinf.certificate.run_plan import RunPlan


def _dump(obj: Any) -> str:
    return json.dumps(json_safe(obj), indent=2)


def _prepare_out(path: Path | None, option: str = "--out", given: Path | None = None) -> None:
    """Create the directory ``path`` and check that it is writable, before any computation.

    Parameters
    ----------
    path : Path or None
        The directory (``None``: the option is not given).
    option : str
        The option that names it, for the message (``--out``, ``--save``).
    given : Path, optional
        What the user typed, when ``path`` is derived from it (``--save``'s folder).
    """
    if path is None:
        return
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        what = "" if given is None else f"{str(given)!r}: its folder "
        raise BadInput(f"{option} {what}{str(path)!r} is not a writable directory: {exc.strerror or exc}") from None


def _read(args: argparse.Namespace) -> tuple[FormationConfig, dict[str, Any] | None]:
    """The configuration of ``--preset`` or ``--config`` (with the parsed TOML of a file, for its tables).

    Every error line names the option and the file (the file's own lines name the key).
    """
    from auv_hinf.config.presets import preset_config
    from auv_hinf.config.settings import read_config

    if args.preset:
        return preset_config(args.preset), None
    try:
        cfg, data = read_config(args.config)
    except ConfigError as exc:
        given = str(args.config)
        lines = [line if line.startswith(f"{given}:") else f"{given}: {line}" for line in str(exc).splitlines()]
        raise ConfigError("\n".join(f"--config {line}" for line in lines)) from None
    for line in input_warnings(data):
        print(f"{PROG}: warning: {args.config}: {line}", file=sys.stderr)
    return cfg, data


def _load(args: argparse.Namespace) -> Any:
    return _read(args)[0]


def _formation_law_only(cfg: FormationConfig, command: str) -> FormationConfig:
    """``cfg``, or a clear refusal when it declares ``[guidance]`` (``command`` runs the formation law only)."""
    if cfg.guidance is not None:
        raise BadInput(
            f"{command} runs the fully actuated formation law; this configuration's [guidance] steers "
            f"propeller-and-rudder vehicles, which `{PROG} simulate` runs (and `{PROG} certify` reports on)"
        )
    return cfg


def _cmd_design(args: argparse.Namespace) -> int:
    from auv_hinf.design.crosscheck import crosscheck

    try:
        report = crosscheck(args.lam, args.gamma, args.n, args.k1)
    except SolverError as exc:
        if not args.json:
            raise
        # the closed form always answers; a failed numerical route is reported inside the JSON
        print(_dump(_design_without_crosscheck(args, exc)))
        return _verdict(False, f"cross-check could not run: {exc}")
    data = report.to_dict()
    if args.json:
        print(_dump(data))
        return _verdict(report.ok, f"cross-check disagrees (max relative difference {report.max_rel_diff:.3g})")
    a = data["alpha"]
    print(f"lambda = {report.lam:g} 1/s, gamma = {report.gamma:g} s, n = {report.n} vehicles")
    print(f"gamma_min = {report.conditions['gamma_min']:.6g} s  regime: gamma {report.conditions['regime']} 1/sqrt2 s")
    for key in ("paper", "stabilizing", "minimal", "care", "scipy_care", "lmi", "lmi_minimal"):
        val = a.get(key)
        print(f"  alpha[{key:<11}] = " + ("n/a" if val is None else f"{val:.9g} 1/s"))
    for flag in report.paper_flags:
        print(f"  paper: {flag}")
    h = data["closed_loop_hinf"]
    if all(h[k] is None for k in ("exact", "python_control", "lmi")):
        print("||T||_inf (stabilizing gain) n/a: no stabilizing alpha at this gamma")
    else:
        norms = ", ".join(
            f"{label} " + ("n/a" if h[k] is None else f"{h[k]:.9g} s")
            for label, k in (("exact", "exact"), ("python-control", "python_control"), ("LMI", "lmi"))
        )
        print(f"||T||_inf (stabilizing gain) {norms}")
    print(f"max relative difference {report.max_rel_diff:.3g}: {'consistent' if report.ok else 'DISAGREES'}")
    for c in report.checks:
        if not c.ok:
            print(f"  FAIL {c.name}: {c.value!r} vs {c.reference!r} (rel {c.rel_diff:.3g} > {c.tol:g})")
    return _verdict(report.ok, f"cross-check disagrees (max relative difference {report.max_rel_diff:.3g})")


def _design_without_crosscheck(args: argparse.Namespace, exc: Exception) -> dict[str, Any]:
    """``design --json`` when a numerical cross-check route fails: the closed forms and the failure."""
    from auv_hinf.design.theorem1 import design_alpha

    alpha: dict[str, float | None] = {}
    for method in GAIN_METHODS:
        try:
            alpha[method] = float(design_alpha(args.lam, args.gamma, method).alpha)
        except AuvHinfError:
            alpha[method] = None
    return {
        "lam": args.lam,
        "gamma": args.gamma,
        "n": args.n,
        "k1": args.k1,
        "alpha": alpha,
        "ok": False,
        "crosscheck_error": f"{type(exc).__name__}: {exc}",
    }


def _verdict(ok: bool, reason: str) -> int:
    """Exit code of a verdict; a negative one also gets its reason as one line on stderr."""
    if ok:
        return EXIT_OK
    print(f"{PROG}: not certified: {' '.join(reason.split())}", file=sys.stderr)
    return EXIT_NEGATIVE


def _with_design(cfg: FormationConfig, design: str | None) -> FormationConfig:
    """``cfg`` with the ``--design`` override (``None``: as the file says).

    ``--design nominal`` runs the nominal Theorem 1 gains: the file's ``[design] synthesis``, which
    chooses the robust design's gains, is then moot and set back to its default. Integral action is
    part of the robust design, so a file that declares it cannot run nominal gains.

    Raises
    ------
    BadInput
        If the file's ``[design] integral = true`` asks for the robust design.
    """
    if design is None:
        return cfg
    if design == "robust":
        return replace(cfg, robust=True)
    if cfg.integral:
        raise BadInput(
            "--design nominal runs the nominal Theorem 1 gains, and the file's [design] integral = true is part of "
            "the robust design: leave out --design, or set integral = false"
        )
    return replace(cfg, robust=False, synthesis=DEFAULT_SYNTHESIS)


def _law_options(args: argparse.Namespace, cfg: FormationConfig) -> None:
    """Refuse ``certify``'s options of the fully actuated law on a fleet they do not apply to.

    ``--method`` and ``--design`` choose the fully actuated law's gains and ``--refine-jacobi``
    tightens its Theorem 1 sweep: a ``[guidance]`` fleet runs neither. The branch-and-bound of
    ``--refine-jacobi`` exists for ``N <= 3`` on the full heading circle only; elsewhere the
    certificate is the same without it, and a warning says so.

    Raises
    ------
    BadInput
        If one of them is given for a ``[guidance]`` fleet.
    """
    given = [flag for flag, value in (("--method", args.method), ("--design", args.design)) if value]
    if args.refine_jacobi:
        given.append("--refine-jacobi")
    if cfg.guidance is not None and given:
        raise BadInput(
            f"{' and '.join(given)} {'is' if len(given) == 1 else 'are'} for the fully actuated formation law, which "
            "this fleet does not run: [guidance] steers it (its gains are [guidance] heading_bandwidth, lookahead "
            "and integral_gain)"
        )
    if args.refine_jacobi:
        from auv_hinf.design.jacobi_sigma import BNB_MAX_N, refinable

        if not refinable(cfg.n, cfg.envelope):
            why = f"N = {cfg.n}" if cfg.n > BNB_MAX_N else "[envelope] psi is not the full circle"
            print(
                f"{PROG}: warning: --refine-jacobi runs a branch-and-bound for N <= {BNB_MAX_N} on the full heading "
                f"circle; here {why}, so the closed-form Jacobi bound is used",
                file=sys.stderr,
            )


def _cmd_certify(args: argparse.Namespace) -> int:
    _prepare_out(args.out)
    cfg = _with_actuators(_load(args), args.actuators)  # bad input is answered before the certificates load

    from auv_hinf.certificate.assembly import certify

    _law_options(args, cfg)
    if args.method:
        cfg = cfg.with_method(args.method)
    cfg = _with_design(cfg, args.design)
    cert = certify(cfg, refine_jacobi=args.refine_jacobi)
    data = cert.to_dict()
    if args.out:
        from auv_hinf.figures.sigma import save_sigma_heatmap

        cert.save(args.out / "certificate.json")  # the file Certificate.load reads
        if cfg.guidance is None:  # the sigma sweep is of the fully actuated law's Theorem 1
            save_sigma_heatmap(cfg, cert, args.out / "sigma_heatmap.png")
        else:  # the cascade's: actuator use, separation, and what certifies
            from auv_hinf.figures.guidance import save_guidance_certificate_figure

            save_guidance_certificate_figure(data, args.out)
    print(_dump(data) if args.json else cert.summary())
    return _verdict(cert.certified, "; ".join(cert.reasons) or "no reason given")


def _refuse_uncertified(plan: RunPlan, allowed: bool, what: str) -> None:
    """Refuse to run gains that no certificate covers, unless ``--uncertified`` allows it."""
    refusal = plan.uncertified_gains()
    if refusal is not None and not allowed:
        raise Negative(
            f"refusing to {what} gains that no certificate covers: {refusal}; `{PROG} certify` says why and gives "
            f"the values that certify, or rerun with --uncertified to {what} them anyway"
        )


def _cmd_simulate(args: argparse.Namespace) -> int:
    _prepare_out(args.out)
    if args.save is not None:
        from auv_hinf.simulation.stream import parquet_path

        _prepare_out(parquet_path(args.save).parent, "--save", args.save)  # before any computation, as --out
    cfg = _with_actuators(_load(args), args.actuators)  # bad input is answered before the certificates load

    from auv_hinf.certificate.run_plan import REPORT_UNITS, plan_run, run_report
    from auv_hinf.simulation.engine import simulate

    if args.current is not None:
        try:
            cfg = replace(cfg, simulation=replace(cfg.simulation, current=args.current))
        except ConfigError as exc:
            raise BadInput(f"--current {','.join(f'{c:g}' for c in args.current)}: {exc}") from None
    if cfg.guidance is not None:
        return _simulate_guidance(args, cfg)
    if args.six_dof:
        raise BadInput("--six-dof runs the guidance cascade of a [guidance] fleet; this configuration has none")
    cfg = _with_design(cfg, args.design)
    try:
        plan = plan_run(cfg, start=args.start, horizon=args.horizon)
    except DesignError as exc:
        raise Negative(f"no gain to simulate with: {exc}") from None
    _refuse_uncertified(plan, args.uncertified, "simulate")
    try:
        result = simulate(plan.scenario)
    except KeyboardInterrupt:
        raise Stopped("interrupted after 0 of 1 runs; no run finished, nothing written") from None
    summary = run_report(plan, result)
    stopped = None
    if args.save is not None:
        from auv_hinf.simulation.stream import save_trajectories

        try:
            summary["saved_trajectories"] = str(save_trajectories(plan.scenario, args.save))
        except Interrupted as stop:  # the run is done; its file holds the samples streamed so far
            summary["saved_trajectories"] = str(args.save)
            summary["saved_until"] = stop.partial
            where = f"{args.out} and {args.save}" if args.out else str(args.save)
            upto = "none saved" if stop.partial is None else f"saved up to t = {stop.partial:.4g} s"
            stopped = (
                f"interrupted after 1 of 1 runs; results so far in {where} (the run finished; its trajectories "
                f"{upto} of {plan.scenario.horizon:.4g} s)"
            )
        except OSError as exc:
            raise BadInput(f"--save {str(args.save)!r}: {exc.strerror or exc}") from None
    if args.out:
        from auv_hinf.figures.simulation import save_simulation_plots

        write_text(args.out / "summary.json", _dump(summary))
        result.save_npz(args.out / "trajectory.npz")
        cov, rob = plan.coverage, plan.robust  # the bound that applies to this run (None when it is not covered)
        thrust = rob.thrust if rob is not None and rob.covered else (None if cov is None else cov.thrust)
        bound = thrust.as_tuple() if plan.covered and thrust is not None else None
        save_simulation_plots(result, args.out, certified=bound)
    if stopped is not None:
        raise Stopped(stopped)
    if args.json:
        print(_dump(summary))
    else:
        for key, val in summary.items():
            if key == "implementation":  # one line: what ran, and the seed of its draws
                print(
                    f"{key:>24}: {val['description']}"
                    + ("" if val["control_period"] is None else f", seed {val['seed']}")
                )
            elif key not in ("definitions", "null_reasons") and val is not None:  # both are in --json
                print(_report_line(key, val, REPORT_UNITS))
    if plan.certificate is None and not plan.covered:  # integral action: covered by the robust certificate
        return _verdict(False, "; ".join(plan.notes))
    if result.diverged_at is not None:
        return _verdict(
            False, f"the run diverged at t = {result.diverged_at:.4g} s ({plan.scenario.implementation.describe()})"
        )
    if not summary["stayed_in_envelope"]:
        why = f"left the certified envelope at t = {summary['first_exit_time']:.4g} s"
        if not plan.covered:
            why += f" (the certificate does not cover this run: {_run_reason(plan)})"
        return _verdict(False, why)
    if not plan.covered:  # it stayed inside, but no certificate says it had to
        return _verdict(False, f"the run stayed inside, but no certificate covers it: {_run_reason(plan)}")
    return EXIT_OK


def _refuse_uncertified_cascade(cfg: FormationConfig, allowed: bool, what: str) -> None:
    """Refuse to run a guidance cascade its certificate does not hold for, unless ``--uncertified`` allows it."""
    if allowed:
        return
    from auv_hinf.certificate.parts.guidance import fleet_refusal

    refused = fleet_refusal(cfg)
    if refused:
        raise Negative(
            f"refusing to {what} a guidance fleet that no certificate covers: {refused}; `{PROG} certify` "
            f"says why and what would certify, or rerun with --uncertified to {what} it anyway"
        )


def _simulate_guidance(args: argparse.Namespace, cfg: FormationConfig) -> int:
    """``simulate`` of a ``[guidance]`` configuration: the line-of-sight cascade on the 3-DOF model."""
    from auv_hinf.certificate.run_plan import guidance_run

    if args.save is not None or args.design or args.start:
        raise BadInput("--save, --design and --start are for the fully actuated law; a [guidance] run takes none")
    from auv_hinf.certificate.parts.guidance import plant_multipliers, run_coverage

    _refuse_uncertified_cascade(cfg, args.uncertified, "simulate")

    try:
        run = guidance_run(cfg, horizon=args.horizon, six_dof=args.six_dof)
    except KeyboardInterrupt:
        raise Stopped("interrupted after 0 of 1 runs; no run finished, nothing written") from None
    summary = run.report(envelope=cfg.envelope)
    initial = cfg.simulation.initial
    summary.update(run_coverage(cfg, summary, plant_multipliers(cfg), cfg.simulation.current, initial, args.six_dof))
    if args.out:
        from auv_hinf.figures.guidance import save_guidance_plots

        write_text(args.out / "summary.json", _dump(summary))
        covered = summary["certified_errors"] if summary["certificate_covers_run"] else None
        save_guidance_plots(run, args.out, covered)  # the certified bounds drawn when they cover the run
    if args.json:
        print(_dump(summary))
    else:
        from auv_hinf.guidance.simulation import REPORT_UNITS as GUIDANCE_UNITS

        for key, val in summary.items():
            if val is not None:  # a null (no noise, never left the envelope) is the JSON's; the text leaves it out
                print(_report_line(key, val, GUIDANCE_UNITS))
    if summary["within_certified_bounds"] is False:
        print(f"{PROG}: error: the run left its certified bounds: please report this configuration", file=sys.stderr)
        return EXIT_NEGATIVE
    return _verdict(bool(summary["certificate_covers_run"]), str(summary["coverage_reason"]))


def _report_line(key: str, value: Any, units: Mapping[str, Any]) -> str:
    """One line of a run's text report: the key, its value with its units (``units``, by key).

    The closest pair of vehicles is named as ``certify`` names vehicles, counted from 1 (the JSON
    counts from 0).
    """
    if key in ("min_separation_pair", "closest_pair") and isinstance(value, (list, tuple)) and len(value) == 2:
        first, second = (_ordinal(int(i) + 1) for i in value)
        return f"{key:>24}: the {first} and the {second} vehicle (the JSON counts them from zero)"
    return f"{key:>24}: {_short(value, units.get(key))}"


def _ordinal(k: int) -> str:
    """``1st``, ``2nd``, ``3rd``, ``4th``, ..., ``11th``, ``12th``, ``13th``, ``21st``."""
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def _run_reason(plan: RunPlan) -> str:
    """Why neither the nominal nor the robust certificate covers a run, in one line."""
    parts = list(plan.notes)
    if plan.robust is not None and not plan.robust.covered and "robust" not in plan.judged:
        parts.append(f"robust certificate: {plan.robust.reason}")
    return "; ".join(parts) or "not covered"


def _with_actuators(cfg: FormationConfig, limits: tuple[float, ...] | None) -> FormationConfig:
    """``cfg`` with the ``--actuators`` override (N, N, N m), if given.

    Raises
    ------
    BadInput
        If ``cfg`` is steered by ``[guidance]``: its vehicles have a propeller and a rudder, not the
        three force channels the flag sets.
    """
    if limits is None:
        return cfg
    if cfg.guidance is not None:
        raise BadInput(
            "--actuators sets the three force limits of a fully actuated vehicle; this fleet is steered by "
            "[guidance] with a propeller and a rudder: set [actuators] tau_x and rudder_max in the file instead"
        )
    return replace(cfg, actuators=Actuators(limits[0], limits[1], limits[2]))


#: Units of the runtime monitor's figures in the text of ``run`` and ``replay``.
MONITOR_UNITS: dict[str, str] = {
    "steps": "steps",
    "violation_count": "violations",
    "max_age": "s",
    "max_period": "s",
    "mean_period": "s",
    "std_period": "s",
}
#: What a ``null`` figure of the monitor means, in words.
MONITOR_NULLS: dict[str, str] = {
    "reproduced": "not checked (the log carries no verdicts of its own)",
    "log": "none written",
}


def _monitor_line(key: str, value: Any) -> str:
    """One ``key: value`` line of the runtime monitor's text, the number with its unit (words for a null)."""
    text = MONITOR_NULLS.get(key, "n/a") if value is None else _short(value, MONITOR_UNITS.get(key))
    return f"{key:>16}: {text}"


def _short(value: Any, unit: Any = None) -> str:
    """A value printed with 6 significant digits and its unit (floats inside dicts and lists too).

    Parameters
    ----------
    value : Any
        A number, a string, a bool, or a dict or list of them.
    unit : str, dict, tuple or None
        The unit of the number, or of every number of a list or dict; a dict of units by key; a
        tuple of units by position (the forms of ``REPORT_UNITS`` in :mod:`auv_hinf.certificate.run_plan`).
    """
    if isinstance(value, dict):
        by_key = unit if isinstance(unit, dict) else dict.fromkeys(value, unit)
        return "{" + ", ".join(f"{k}: {_short(v, by_key.get(k))}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        by_place = unit if isinstance(unit, tuple) else (unit,) * len(value)
        return "[" + ", ".join(_short(v, u) for v, u in zip(value, by_place)) + "]"
    text = f"{value:.6g}" if isinstance(value, float) else str(value)
    numeric = isinstance(value, (int, float)) and not isinstance(value, bool)
    return f"{text} {unit}" if numeric and isinstance(unit, str) else text


def _cmd_schema(args: argparse.Namespace) -> int:
    if args.certificate:
        from auv_hinf.certificate.document import certificate_schema

        print(json.dumps(certificate_schema(), indent=2))
        return EXIT_OK
    from auv_hinf.config.schema import json_schema

    print(json.dumps(json_schema(), indent=2))
    return EXIT_OK


def _cmd_init(args: argparse.Namespace) -> int:
    from auv_hinf.config.presets import annotated_toml, preset_config

    out: Path | None = args.out
    if out is not None and out.exists() and not args.force:
        raise BadInput(f"--out {str(out)!r} exists; use --force to overwrite it")
    text = annotated_toml(preset_config(args.preset))
    if out is None:
        print(text, end="")
        return EXIT_OK
    blocked = next((p for p in out.parents if p.exists() and not p.is_dir()), None)
    if blocked is not None:  # mkdir would say "File exists" of a file where a folder must go
        raise BadInput(f"--out {str(out)!r} cannot be written: {str(blocked)!r} is a file, not a directory")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise BadInput(f"--out {str(out)!r} cannot be written: {exc.strerror or exc}") from None
    print(f"wrote {out} (from preset {args.preset}); check it with: {PROG} certify --config {out}")
    return EXIT_OK


def _cmd_campaign(args: argparse.Namespace) -> int:
    from auv_hinf.campaign.report import SUMMARY_UNITS, write_outputs
    from auv_hinf.campaign.runner import dask_client, run_campaign
    from auv_hinf.certificate.run_plan import plan_run

    _prepare_out(args.out)
    cfg = _load(args)
    if cfg.guidance is not None:
        return _campaign_guidance(args, cfg)
    try:
        with ExitStack() as stack:

            def client_of(workers: int | None, scheduler: str | None) -> Any:
                try:
                    return stack.enter_context(dask_client(workers, scheduler))
                except ParameterError as exc:
                    raise BadInput(f"--scheduler {scheduler!r}: {exc}" if scheduler else str(exc)) from None

            # a scheduler given by address is reached first: a wrong one fails before the certificate's work
            client = client_of(None, args.scheduler) if args.scheduler else None
            try:
                plan = plan_run(cfg, horizon=args.horizon, samples=2)  # the gains' verdict; the runs come later
            except DesignError as exc:
                raise Negative(f"no gain to run a campaign with: {exc}") from None
            _refuse_uncertified(plan, args.uncertified, "run a campaign of")
            if not args.scheduler:
                client = client_of(args.workers, None)
            try:
                camp = run_campaign(
                    cfg, args.runs, seed=args.seed, chunk=args.chunk, horizon=args.horizon, client=client, progress=True
                )
            except DesignError as exc:
                raise Negative(f"no certified start region to sample from: {exc}") from None
    except Interrupted as stop:  # keep the runs that finished: their rows and their summary
        if stop.partial is None:
            raise Stopped(
                f"interrupted after 0 of {args.runs} runs; no run finished, nothing written (runs finish a chunk "
                "at a time: a smaller --chunk keeps more of an interrupted campaign)"
            ) from None
        write_outputs(stop.partial, args.out)
        raise Stopped(f"interrupted after {stop.done} of {args.runs} runs; results so far in {args.out}") from None
    summary = write_outputs(camp, args.out)
    if args.json:
        print(_dump(summary))
    else:
        for key in ("config", "runs", "executor", "counts", "fraction_inside", "worst_ratio", "throughput", "notes"):
            print(f"{key:>16}: {_short(summary[key], SUMMARY_UNITS.get(key))}")
    c = summary["counts"]
    uncovered = c["runs"] - c["certificate_applies"]
    # as simulate: a run no certificate covers does not pass, however it went (--uncertified gains, or
    # bounds that break [formation] min_separation); the summary's "ok" says the same
    return _verdict(
        summary["ok"],
        f"{c['outside_bounds']} of {c['certificate_applies']} covered runs outside the "
        f"certified bounds, {c['left_envelope']} of {c['runs']} runs left the envelope"
        + (f", {uncovered} runs not covered" if uncovered else ""),
    )


def _campaign_guidance(args: argparse.Namespace, cfg: FormationConfig) -> int:
    """``campaign`` of a ``[guidance]`` configuration: the cascade on sampled plants and currents."""
    from auv_hinf.campaign.guidance import SUMMARY_UNITS as GUIDANCE_SUMMARY_UNITS
    from auv_hinf.campaign.guidance import run_guidance_campaign
    from auv_hinf.figures.guidance import save_guidance_campaign_figure

    if args.scheduler or args.workers not in (None, 1) or args.chunk is not None:
        raise BadInput(
            "--workers, --scheduler and --chunk are for the formation law's campaigns; a [guidance] one runs "
            "here, one run after another"
        )

    def write(camp: Any) -> dict[str, Any]:  # the table, the summary and the figure, of any finished runs
        summary = camp.write(args.out)
        save_guidance_campaign_figure(camp, args.out)
        return dict(summary)

    _refuse_uncertified_cascade(cfg, args.uncertified, "run a campaign of")
    try:
        camp = run_guidance_campaign(cfg, args.runs, seed=args.seed, horizon=args.horizon, progress=True)
    except Interrupted as stop:
        if stop.partial is None:
            raise Stopped(f"interrupted after 0 of {args.runs} runs; no run finished, nothing written") from None
        write(stop.partial)
        raise Stopped(f"interrupted after {stop.done} of {args.runs} runs; results so far in {args.out}") from None
    summary = write(camp)
    if args.json:
        print(_dump(summary))
    else:
        for key, val in summary.items():
            print(f"{key:>26}: {_short(val, GUIDANCE_SUMMARY_UNITS.get(key))}")
    if summary["runs_outside_bounds"]:
        print(
            f"{PROG}: error: {summary['runs_outside_bounds']} covered runs left their certified bounds", file=sys.stderr
        )
        return EXIT_NEGATIVE
    return _verdict(
        bool(summary["ok"] and summary["certificate_covers_runs"]),
        f"{summary['covered_runs']} of {summary['runs']} runs covered by the guidance certificate"
        f"{'' if summary['certified'] else ' (not certified: see certify)'}, {summary['saturated_runs']} saturated, "
        f"{summary['runs_below_min_separation']} came closer than {summary['required_min_separation']:g} m",
    )


def _deploy_source(args: argparse.Namespace) -> tuple[FormationConfig, Any, Any]:
    """The configuration, the certificate of ``--certificate`` (else ``None``) and the ``[deploy]`` table."""
    from auv_hinf.certificate.assembly import Certificate
    from auv_hinf.config.messages import parse_config
    from auv_hinf.config.schema import DeployTable

    if args.certificate is not None:
        try:
            cert = Certificate.load(args.certificate)
        except ConfigError as exc:
            raise ConfigError("\n".join(f"--certificate {line}" for line in str(exc).splitlines())) from None
        return cert.config, cert, DeployTable()
    cfg, data = _read(args)
    return cfg, None, DeployTable() if data is None else parse_config(data).deploy


def _certified(cfg: FormationConfig, cert: Any) -> Any:
    """``cert``, or the certificate of ``cfg`` computed now."""
    from auv_hinf.certificate.assembly import certify

    return cert if cert is not None else certify(cfg)


def _runtime_law(cert: Any, uncertified: bool) -> Any:
    """The runtime law of ``cert``, refused (exit 1) when the certificate does not hold."""
    from auv_hinf.deployment.runtime import RuntimeLaw

    if not cert.certified and not uncertified:
        raise Negative(
            f"refusing to run a law its certificate does not cover: {'; '.join(cert.reasons)}; "
            "rerun with --uncertified to run it anyway (every step is then reported as not covered)"
        )
    try:
        return RuntimeLaw.from_certificate(cert)
    except DesignError as exc:
        raise Negative(f"no law to run: {exc}") from None


#: The MAVLink connection kinds ``run`` and ``fleet-sim`` take, with a port (``kind:host:port``).
URL_KINDS = ("udpin", "udpout", "udp", "tcp", "tcpin")


def _check_urls(urls: list[str], flag: str) -> None:
    """Refuse connection strings that are not ``kind:host:port`` with a port in 0-65535, or that repeat.

    Two vehicles on one connection would each get the other's commands; a serial device
    (``/dev/...``) is taken as given, and port 0 (a listener on an ephemeral port) may repeat.
    """
    seen: set[str] = set()
    for url in urls:
        if not url.startswith("/"):
            parts = url.split(":")
            port = parts[-1] if len(parts) == 3 else ""
            if parts[0] not in URL_KINDS or not port.isdigit() or not 0 <= int(port) <= 65535:
                raise BadInput(
                    f"{flag} {url!r} is not a MAVLink connection string: use kind:host:port with kind one of "
                    f"{', '.join(URL_KINDS)} and a port in 0-65535 (udpout:127.0.0.1:14550), or a serial device"
                )
            if int(port) == 0:  # a listener on an ephemeral port: each gets its own
                continue
        if url in seen:
            raise BadInput(f"{flag} {url!r} is given twice: each vehicle needs its own connection")
        seen.add(url)


def _cmd_run(args: argparse.Namespace) -> int:
    from auv_hinf.deployment.ardusub import ArduSubMapping
    from auv_hinf.deployment.link import VehicleLink
    from auv_hinf.deployment.monitor import MonitorConfig
    from auv_hinf.deployment.runner import run

    _prepare_out(args.log.parent, "--log", args.log)  # before any computation or connection
    cfg, cert, deploy = _deploy_source(args)
    _formation_law_only(cfg, "run")
    urls = list(args.connect or deploy.connect or [])
    n = cfg.n
    if len(urls) != n:
        raise BadInput(f"give one --connect URL per vehicle ({n}; or [deploy] connect), got {len(urls)}")
    _check_urls(urls, "--connect")
    cert = _certified(cfg, cert)
    law = _runtime_law(cert, args.uncertified)
    if law.sample_time <= 0.0:
        raise BadInput(
            "the certificate declares no sample time ([implementation] sample_time = 0): a fixed-rate loop is "
            "not what it certifies; declare the sample time and delay the vehicles run at, and certify them"
        )
    latency = deploy.command_latency if args.command_latency is None else args.command_latency
    gain = deploy.pilot_gain if args.gain is None else args.gain
    law = replace(law, assumptions=replace(law.assumptions, command_latency=latency, pilot_gain=gain))
    if not law.assumptions.varying_delay:
        print(
            f"{PROG}: warning: the certificate assumes every measurement exactly {law.delay:g} s old; a real link "
            "gives any age up to it: certify with [implementation] varying_delay = true",
            file=sys.stderr,
        )
    config = MonitorConfig.parse(args.on_violation or deploy.on_violation, args.action)
    mapping = ArduSubMapping(gain=gain, voltage=deploy.voltage if args.voltage is None else args.voltage)
    rate = deploy.telemetry_rate if args.rate is None else args.rate
    links = []
    try:
        links = [VehicleLink(u, i, mapping, telemetry_rate=rate) for i, u in enumerate(urls)]
        summary = run(
            law,
            links,
            args.duration,
            args.log,
            config=config,
            wait_timeout=args.wait,
            metadata={"config": cfg.name},
            realtime=args.realtime,
        )
    finally:
        for link in links:
            link.close()
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        for key in ("steps", "covered", "violation_count", "max_age", "max_period", "mean_period", "std_period", "log"):
            print(_monitor_line(key, summary[key]))
    steps, count = summary["steps"], summary["violation_count"]
    covered = "yes" if summary["covered"] else f"no ({count} violation(s))"
    if summary["stopped_by"] in ("sigint", "sigterm", "sighup", "stop_event"):
        print(
            f"{PROG}: interrupted ({summary['stopped_by'].upper()}) after {steps} steps: neutral sent to {n} "
            f"vehicle(s); covered so far: {covered}",
            file=sys.stderr,
        )
        return EXIT_OK
    if summary["covered"]:
        return EXIT_OK
    first = summary["violations"][0] if summary["violations"] else None
    where = "" if first is None else ("the fleet" if first["vehicle"] < 0 else f"vehicle {first['vehicle'] + 1}")
    what = "" if first is None else f"; first: {first['assumption']} on {where} at t = {first['time']:.3g} s"
    if summary["stopped_by"] == "start":
        return _verdict(
            False,
            f"the fleet starts outside the certified bounds{what}: only neutral was sent to the {n} vehicle(s); "
            "bring the vehicles to their slots at the mission's start (the certified start region), then run",
        )
    if summary["stopped_by"] == "monitor":
        return _verdict(False, f"stopped by the monitor after {steps} steps, neutral sent to {n} vehicle(s){what}")
    if count == 0:
        return _verdict(False, "the certificate does not hold (--uncertified)")
    return _verdict(False, f"the certificate did not cover the run: {count} violation(s){what}")


def _cmd_fleet_sim(args: argparse.Namespace) -> int:
    import signal

    from auv_hinf.deployment.ardusub import ArduSubMapping
    from auv_hinf.deployment.loopback import LinkFaults, LoopbackFleet, loopback_starts

    if args.report is not None:
        _prepare_out(args.report.parent, "--report", args.report)  # before the fleet starts
    cfg = _formation_law_only(_deploy_source(args)[0], "fleet-sim")
    n = len(args.listen)
    if n != cfg.n:
        raise BadInput(f"give one --listen URL per vehicle of {cfg.name!r} ({cfg.n}), got {n}")
    _check_urls(list(args.listen), "--listen")

    def each(values: tuple[float, ...], flag: str) -> tuple[float, ...]:
        if len(values) not in (1, n):
            raise BadInput(f"{flag} takes one value or one per vehicle ({n}), got {len(values)}")
        return values * n if len(values) == 1 else values

    lat, jit, loss, closs = (
        each(args.latency, "--latency"),
        each(args.jitter, "--jitter"),
        each(args.loss, "--loss"),
        each(args.command_loss, "--command-loss"),
    )
    faults = [LinkFaults(lat[i], jit[i], loss[i], closs[i]) for i in range(n)]
    fleet = LoopbackFleet(
        cfg.vehicle,
        loopback_starts(cfg, args.current),
        list(args.listen),
        ArduSubMapping(gain=args.gain, voltage=args.voltage),
        faults,
        current=args.current,
        rate=args.rate,
        odometry=args.odometry,
        timesync=not args.no_timesync,
        mode=args.mode,
        sysid=args.sysid,
        seed=args.seed,
    )

    if args.realtime:
        from auv_hinf.deployment.priority import raise_priority

        raise_priority()

    def _stop(signum: int, frame: Any) -> None:
        fleet.stopped = True

    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    print(json.dumps({"ready": True, "endpoints": fleet.endpoints, "pid": os.getpid()}), flush=True)
    try:
        fleet.run(args.duration)
    finally:
        fleet.close()
        if args.report is not None:
            args.report.parent.mkdir(parents=True, exist_ok=True)
            args.report.write_text(json.dumps(json_safe(fleet.report())), encoding="utf-8")
    return EXIT_OK


def _cmd_replay(args: argparse.Namespace) -> int:
    from auv_hinf.deployment.log import read_log
    from auv_hinf.deployment.replay import replay

    if args.plot is not None:
        _prepare_out(args.plot.parent, "--plot", args.plot)  # before the log is read and replayed
        from matplotlib.backend_bases import FigureCanvasBase

        kinds = FigureCanvasBase.get_supported_filetypes()
        if args.plot.suffix.lower().lstrip(".") not in kinds:
            raise BadInput(
                f"--plot {str(args.plot)!r}: the file's extension names the image format; use one of "
                f"{', '.join('.' + k for k in sorted(kinds))}"
            )
    cfg, cert, _ = _deploy_source(args)
    data = read_log(args.log)
    law = _runtime_law(_certified(cfg, cert), uncertified=True)
    result = replay(data, law)
    summary = result.summary
    if args.plot is not None:
        from auv_hinf.figures.deployment import save_replay_figure

        try:
            summary["plot"] = str(save_replay_figure(result, law.assumptions, args.plot, title=str(args.log)))
        except OSError as exc:
            raise BadInput(f"--plot {str(args.plot)!r}: {exc.strerror or exc}") from None
    if args.json:
        print(json.dumps(json_safe(summary)))
    else:
        for key in ("steps", "covered", "violation_count", "reproduced", "max_age", "max_period", "unchecked"):
            print(_monitor_line(key, summary[key]))
    if summary["assumptions_match"] is False:
        print(f"{PROG}: warning: the log was run under other assumptions than this certificate's", file=sys.stderr)
    if summary["reproduced"] is False:
        return _verdict(False, f"the log's verdicts are not reproduced at {len(summary['mismatches'])} step(s)")
    if not summary["covered"]:
        count = summary["violation_count"]
        why = f"{count} violation(s)" if count else "the certificate does not hold"
        return _verdict(False, f"the certificate does not cover the logged run: {why}")
    return EXIT_OK


COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "design": _cmd_design,
    "certify": _cmd_certify,
    "simulate": _cmd_simulate,
    "schema": _cmd_schema,
    "init": _cmd_init,
    "campaign": _cmd_campaign,
    "run": _cmd_run,
    "fleet-sim": _cmd_fleet_sim,
    "replay": _cmd_replay,
}


__all__ = ["COMMANDS"]
