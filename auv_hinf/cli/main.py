"""Command-line interface ``auv-hinf``.

Exit codes: 0 success (consistent / certified / simulated / written); 1 a negative verdict
(cross-check disagrees, not certified, no gain) or a solver or internal failure; 2 bad input
(arguments, configuration, unusable ``--out``). Every failure is reported as one line per
problem on stderr and never as a traceback, unless ``--debug`` is given, which re-raises.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from auv_hinf._typing import GAIN_METHODS
from auv_hinf._version import __version__
from auv_hinf.campaign.sampling import MAX_CHUNK
from auv_hinf.cli.args import NUMERIC_OPTIONS, BadInput, Negative, Parser, UsageError, join_numbers, numeric, vector
from auv_hinf.config.presets import PRESETS
from auv_hinf.config.schema import DEFAULT_K1
from auv_hinf.exceptions import AuvHinfError, DesignError, SolverError
from auv_hinf.workflow.codec import json_safe

EXIT_OK, EXIT_NEGATIVE, EXIT_BAD_INPUT = 0, 1, 2
PROG = "auv-hinf"
#: Largest ``design --n``: the full-size LMI cross-check grows as (2N)^2 (25 s at N = 20).
DESIGN_MAX_N = 20


def _dump(obj: Any) -> str:
    return json.dumps(json_safe(obj), indent=2)


def _prepare_out(path: Path | None) -> None:
    """Create ``--out`` and check that it is writable, before any computation."""
    if path is None:
        return
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        raise BadInput(f"--out {str(path)!r} is not a writable directory: {exc.strerror or exc}") from None


def _load(args: argparse.Namespace) -> Any:
    from auv_hinf.config.formation import load_config
    from auv_hinf.config.presets import preset_config

    return preset_config(args.preset) if args.preset else load_config(args.config)


def build_parser() -> argparse.ArgumentParser:
    """The ``auv-hinf`` argument parser."""
    parser = Parser(prog=PROG, description="Certified H-infinity formation control for AUV fleets", allow_abbrev=False)
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("--debug", action="store_true", help="re-raise errors with their traceback")
    sub = parser.add_subparsers(dest="command", parser_class=Parser)

    d = sub.add_parser("design", help="Theorem 1 gains three ways, cross-checked four ways", allow_abbrev=False)
    numeric(d, "--lam", float, required=True, help="nominal lambda < 0 (1/s)")
    numeric(d, "--gamma", float, required=True, help="H-infinity bound gamma > 0")
    numeric(d, "--n", int, 2, DESIGN_MAX_N, default=3, help=f"number of vehicles, 2..{DESIGN_MAX_N} (default 3)")
    numeric(d, "--k1", float, default=DEFAULT_K1, help=f"Theorem 2 position gain (1/s^2), default {DEFAULT_K1:g}")
    d.add_argument("--json", action="store_true", help="print one JSON object")

    for name, text in (("certify", "certify a formation design"), ("simulate", "simulate a scenario")):
        c = sub.add_parser(name, help=text, allow_abbrev=False)
        src = c.add_mutually_exclusive_group(required=True)
        src.add_argument("--preset", choices=PRESETS, help=f"built-in preset ({', '.join(PRESETS)})")
        src.add_argument("--config", type=Path, help="TOML configuration file")
        c.add_argument("--json", action="store_true", help="print one JSON object")
        c.add_argument("--out", type=Path, help="directory for JSON and PNG outputs (created)")
        c.add_argument(
            "--design",
            choices=("nominal", "robust"),
            help="robust: gains chosen for the [uncertainty] box and [disturbance] current (config: [design] robust)",
        )
        if name == "simulate":
            c.add_argument(
                "--start",
                choices=("shaped", "paper"),
                help="shaped: the reference blends from the actual start (default); paper: raw reference",
            )
            numeric(c, "--horizon", float, 1e-6, 1e5, help="simulated time in s (default: the config's)")
            NUMERIC_OPTIONS.update(("--current", "--thrust-limit"))
            c.add_argument(
                "--current",
                type=vector(2, "m/s"),
                metavar="CX,CY",
                help="constant current, inertial frame, m/s (e.g. --current 0.1,0)",
            )
            c.add_argument(
                "--thrust-limit",
                type=vector(3, "N, N, N m"),
                metavar="FX,FY,M",
                help="thrust limits |tau_x|, |tau_y| (N) and |tau_psi| (N m)",
            )
        if name == "certify":
            c.add_argument("--method", choices=GAIN_METHODS, help="gain method")
            c.add_argument(
                "--refine-jacobi",
                action="store_true",
                help="tighten the Jacobi sigma bound by branch-and-bound (N <= 3, ~25 s)",
            )

    sub.add_parser("schema", help="print the JSON Schema of the TOML configuration", allow_abbrev=False)
    i = sub.add_parser("init", help="write an annotated starting configuration", allow_abbrev=False)
    i.add_argument("--out", type=Path, help="file to write (default: print to stdout)")
    i.add_argument("--preset", choices=PRESETS, default=PRESETS[0], help=f"starting point (default {PRESETS[0]})")
    i.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    _campaign_parser(sub)
    for p in (d, *(sub.choices[k] for k in ("certify", "simulate", "schema", "init", "campaign"))):
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    return parser


def _cmd_design(args: argparse.Namespace) -> int:
    from auv_hinf.design.crosscheck import crosscheck

    report = crosscheck(args.lam, args.gamma, args.n, args.k1)
    data = report.to_dict()
    if args.json:
        print(_dump(data))
        return _verdict(report.ok, f"cross-check disagrees (max relative difference {report.max_rel_diff:.3g})")
    a = data["alpha"]
    print(f"lambda = {report.lam:g} 1/s, gamma = {report.gamma:g}, n = {report.n}")
    print(f"gamma_min = {report.conditions['gamma_min']:.6g}  regime: {report.conditions['regime']} 1/sqrt2")
    for key in ("paper", "stabilizing", "minimal", "care", "scipy_care", "lmi", "lmi_minimal"):
        val = a.get(key)
        print(f"  alpha[{key:<11}] = " + ("n/a" if val is None else f"{val:.9g}"))
    for flag in report.paper_flags:
        print(f"  paper: {flag}")
    h = data["closed_loop_hinf"]
    print(f"||T||_inf exact {h['exact']}, python-control {h['python_control']}, LMI {h['lmi']}")
    print(f"max relative difference {report.max_rel_diff:.3g}: {'consistent' if report.ok else 'DISAGREES'}")
    for c in report.checks:
        if not c.ok:
            print(f"  FAIL {c.name}: {c.value!r} vs {c.reference!r} (rel {c.rel_diff:.3g} > {c.tol:g})")
    return _verdict(report.ok, f"cross-check disagrees (max relative difference {report.max_rel_diff:.3g})")


def _verdict(ok: bool, reason: str) -> int:
    """Exit code of a verdict; a negative one also gets its reason as one line on stderr."""
    if ok:
        return EXIT_OK
    print(f"{PROG}: not certified: {' '.join(reason.split())}", file=sys.stderr)
    return EXIT_NEGATIVE


def _cmd_certify(args: argparse.Namespace) -> int:
    from auv_hinf.workflow.certificate import certify

    _prepare_out(args.out)
    cfg = _load(args)
    if args.method:
        cfg = cfg.with_method(args.method)
    if args.design:
        cfg = replace(cfg, robust=args.design == "robust")
    cert = certify(cfg, refine_jacobi=args.refine_jacobi)
    data = cert.to_dict()
    if args.out:
        from auv_hinf.plots import save_sigma_heatmap

        cert.save(args.out / "certificate.json")  # the file Certificate.load reads
        save_sigma_heatmap(cfg, cert, args.out / "sigma_heatmap.png")
    print(_dump(data) if args.json else cert.summary())
    return _verdict(cert.certified, "; ".join(cert.reasons) or "no reason given")


def _cmd_simulate(args: argparse.Namespace) -> int:
    from auv_hinf.simulation.engine import simulate
    from auv_hinf.workflow.run_plan import plan_run, run_report

    _prepare_out(args.out)
    cfg = _load(args)
    overrides = {k: v for k, v in (("current", args.current), ("thrust_limit", args.thrust_limit)) if v is not None}
    if overrides:
        cfg = replace(cfg, simulation=replace(cfg.simulation, **overrides))
    if args.design:
        cfg = replace(cfg, robust=args.design == "robust")
    try:
        plan = plan_run(cfg, start=args.start, horizon=args.horizon)
    except DesignError as exc:
        raise Negative(f"no gain to simulate with: {exc}") from None
    result = simulate(plan.scenario)
    summary = run_report(plan, result)
    if args.out:
        from auv_hinf.plots import save_simulation_plots

        (args.out / "summary.json").write_text(_dump(summary))
        result.save_npz(args.out / "trajectory.npz")
        save_simulation_plots(result, args.out)
    if args.json:
        print(_dump(summary))
    else:
        for key, val in summary.items():
            print(f"{key:>24}: {_short(val)}")
    if plan.certificate is None:
        return _verdict(False, "; ".join(plan.notes))
    if not summary["stayed_in_envelope"]:
        why = f"left the certified envelope at t = {summary['first_exit_time']:.4g} s"
        if not plan.covered:
            why += f" (the certificate does not cover this run: {'; '.join(plan.notes)})"
        return _verdict(False, why)
    return EXIT_OK


def _short(value: Any) -> str:
    """A value printed with 4-6 significant digits (floats inside dicts and lists too)."""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_short(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    return str(value)


def _cmd_schema(args: argparse.Namespace) -> int:
    from auv_hinf.config.schema import json_schema

    print(json.dumps(json_schema(), indent=2))
    return EXIT_OK


def _cmd_init(args: argparse.Namespace) -> int:
    from auv_hinf.config.presets import annotated_toml, preset_config

    out: Path | None = args.out
    if out is not None and out.exists() and not args.force:
        raise BadInput(f"{str(out)!r} exists; use --force to overwrite it")
    text = annotated_toml(preset_config(args.preset))
    if out is None:
        print(text, end="")
        return EXIT_OK
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise BadInput(f"cannot write {str(out)!r}: {exc.strerror or exc}") from None
    print(f"wrote {out} (from preset {args.preset}); check it with: {PROG} certify --config {out}")
    return EXIT_OK


def _campaign_parser(sub: Any) -> None:
    """The ``campaign`` sub-command's arguments."""
    c = sub.add_parser("campaign", help="Monte Carlo runs from inside the certified start region", allow_abbrev=False)
    src = c.add_mutually_exclusive_group(required=True)
    src.add_argument("--preset", choices=PRESETS, help=f"built-in preset ({', '.join(PRESETS)})")
    src.add_argument("--config", type=Path, help="TOML configuration file")
    numeric(c, "--runs", int, 1, 10**7, required=True, help="number of runs K")
    numeric(c, "--seed", int, 0, 2**63 - 1, default=0, help="root seed (default 0)")
    ex = c.add_mutually_exclusive_group()
    numeric(ex, "--workers", int, 1, 1024, help="local Dask cluster of W single-threaded worker processes")
    ex.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. tcp://host:8786")
    numeric(
        c, "--chunk", int, 1, 10**6, help=f"scenarios per batch (default: up to {MAX_CHUNK}, fewer if memory-bound)"
    )
    numeric(c, "--horizon", float, 1e-6, 1e5, help="simulated time in s (default: the config's)")
    c.add_argument("--out", type=Path, required=True, help="directory for runs.parquet, summary.json, PNGs")
    c.add_argument("--json", action="store_true", help="print the summary as one JSON object")


def _cmd_campaign(args: argparse.Namespace) -> int:
    from auv_hinf.campaign.report import write_outputs
    from auv_hinf.campaign.runner import dask_client, run_campaign

    _prepare_out(args.out)
    cfg = _load(args)
    with dask_client(args.workers, args.scheduler) as client:
        try:
            camp = run_campaign(
                cfg, args.runs, seed=args.seed, chunk=args.chunk, horizon=args.horizon, client=client, progress=True
            )
        except DesignError as exc:
            raise Negative(f"no certified start region to sample from: {exc}") from None
    summary = write_outputs(camp, args.out)
    if args.json:
        print(_dump(summary))
    else:
        for key in ("config", "runs", "executor", "counts", "fraction_inside", "worst_ratio", "throughput", "notes"):
            print(f"{key:>16}: {_short(summary[key])}")
    c = summary["counts"]
    return _verdict(
        summary["ok"],
        f"{c['outside_bounds']} of {c['certificate_applies']} covered runs outside the "
        f"certified bounds, {c['left_envelope']} of {c['runs']} runs left the envelope",
    )


_COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "design": _cmd_design,
    "certify": _cmd_certify,
    "simulate": _cmd_simulate,
    "schema": _cmd_schema,
    "init": _cmd_init,
    "campaign": _cmd_campaign,
}


def _report(kind: str, exc: BaseException) -> None:
    """Print ``exc`` as one line per problem on stderr."""
    lines = [line for line in str(exc).splitlines() if line.strip()] or [type(exc).__name__]
    for line in lines:
        print(f"{PROG}: {kind}: {line}", file=sys.stderr)


def _classify(exc: BaseException) -> tuple[int, str]:
    """Exit code and label of an exception that reached the boundary."""
    if isinstance(exc, (UsageError, BadInput)):
        return EXIT_BAD_INPUT, "error"
    if isinstance(exc, Negative):
        return EXIT_NEGATIVE, "not certified"
    if isinstance(exc, SolverError) or type(exc).__name__ == "SolverError":
        return EXIT_NEGATIVE, "solver failure"
    if isinstance(exc, AuvHinfError) and isinstance(exc, ValueError):
        return EXIT_BAD_INPUT, "error"  # parameter, formation, envelope, design or config input
    if isinstance(exc, OSError):
        return EXIT_BAD_INPUT, "error"
    if isinstance(exc, ArithmeticError):  # overflow or division by zero from an extreme input value
        return EXIT_BAD_INPUT, "error: numbers out of range"
    return EXIT_NEGATIVE, "internal error"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code instead of calling ``sys.exit``.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).
    """
    args_list = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args_list
    parser = build_parser()
    try:
        try:
            args = parser.parse_args(join_numbers(args_list))
        except SystemExit as exc:  # --help and --version
            return exc.code if isinstance(exc.code, int) else EXIT_OK
        if args.command is None:
            parser.print_help()
            return EXIT_OK
        return _COMMANDS[args.command](args)
    except Exception as exc:  # the one error boundary: every failure becomes an exit code
        code, kind = _classify(exc)
        if debug and not isinstance(exc, UsageError):
            raise
        if kind == "internal error":
            first = (str(exc).splitlines() or [""])[0]
            print(
                f"{PROG}: internal error: {type(exc).__name__}: {first} (rerun with --debug for the traceback)",
                file=sys.stderr,
            )
        else:
            _report(kind, exc)
        return code


if __name__ == "__main__":
    sys.exit(main())
