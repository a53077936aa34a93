"""Command-line interface ``auv-hinf``.

Exit codes: 0 success (consistent / certified / simulated), 1 a negative verdict
(cross-check disagrees, not certified), 2 bad input (one line on stderr, no traceback).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any, Sequence

from . import __version__
from .exceptions import AuvHinfError, SolverError

EXIT_OK, EXIT_NEGATIVE, EXIT_BAD_INPUT = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one line and exit code 2."""

    def error(self, message: str) -> Any:
        raise _UsageError(message)


class _UsageError(Exception):
    pass


def _json_safe(obj: Any) -> Any:
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    return obj


def _dump(obj: Any) -> str:
    return json.dumps(_json_safe(obj), indent=2, sort_keys=False)


def build_parser() -> argparse.ArgumentParser:
    """The ``auv-hinf`` argument parser."""
    parser = _Parser(prog="auv-hinf", description="Certified H-infinity formation control for AUV fleets")
    parser.add_argument("--version", action="version", version=f"auv-hinf {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)

    d = sub.add_parser("design", help="Theorem 1 gains three ways, cross-checked four ways")
    d.add_argument("--lam", type=float, required=True, help="nominal lambda < 0 (1/s)")
    d.add_argument("--gamma", type=float, required=True, help="H-infinity bound gamma > 0")
    d.add_argument("--n", type=int, default=3, help="number of vehicles (full-size problems), default 3")
    d.add_argument("--k1", type=float, default=0.2, help="Theorem 2 position gain (1/s^2), default 0.2")
    d.add_argument("--json", action="store_true", help="print one JSON object")

    for name, text in (("certify", "certify a formation design"), ("simulate", "simulate a scenario")):
        c = sub.add_parser(name, help=text)
        src = c.add_mutually_exclusive_group(required=True)
        src.add_argument("--preset", help="built-in preset (paper-triangle, paper-hexagon)")
        src.add_argument("--config", type=Path, help="TOML configuration file")
        c.add_argument("--json", action="store_true", help="print one JSON object")
        c.add_argument("--out", type=Path, help="directory for JSON and PNG outputs")
        if name == "certify":
            c.add_argument("--method", choices=["paper", "stabilizing", "minimal"], help="gain method")
            c.add_argument("--refine-jacobi", action="store_true",
                           help="tighten the Jacobi sigma bound by branch-and-bound (N <= 3, ~25 s)")
    return parser


def _cmd_design(args: argparse.Namespace) -> int:
    from .crosscheck import crosscheck

    report = crosscheck(args.lam, args.gamma, args.n, args.k1)
    data = report.to_dict()
    if args.json:
        print(_dump(data))
    else:
        a = data["alpha"]
        print(f"lambda = {report.lam:g} 1/s, gamma = {report.gamma:g}, n = {report.n}")
        print(f"gamma_min = {report.conditions['gamma_min']:.6g}  regime: {report.conditions['regime']} 1/sqrt2")
        for key in ("paper", "stabilizing", "minimal", "care", "scipy_care", "lmi", "lmi_minimal"):
            val = a[key]
            print(f"  alpha[{key:<11}] = " + ("n/a" if val is None else f"{val:.9g}"))
        for flag in report.paper_flags:
            print(f"  paper: {flag}")
        h = data["closed_loop_hinf"]
        print(f"||T||_inf exact {h['exact']}, python-control {h['python_control']}, LMI {h['lmi']}")
        print(f"max relative difference {report.max_rel_diff:.3g}: {'consistent' if report.ok else 'DISAGREES'}")
        for c in report.checks:
            if not c.ok:
                print(f"  FAIL {c.name}: {c.value!r} vs {c.reference!r} (rel {c.rel_diff:.3g} > {c.tol:g})")
    return EXIT_OK if report.ok else EXIT_NEGATIVE


def _cmd_certify(args: argparse.Namespace) -> int:
    from .certificate import certify
    from .config import load_config, preset_config

    cfg = preset_config(args.preset) if args.preset else load_config(args.config)
    if args.method:
        cfg = cfg.with_method(args.method)
    cert = certify(cfg, refine_jacobi=args.refine_jacobi)
    data = cert.to_dict()
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "certificate.json").write_text(_dump(data))
        from .plots import save_sigma_heatmap

        save_sigma_heatmap(cfg, cert, args.out / "sigma_heatmap.png")
    print(_dump(data) if args.json else cert.summary())
    return EXIT_OK if cert.certified else EXIT_NEGATIVE


def _cmd_simulate(args: argparse.Namespace) -> int:
    from .config import load_config, preset_config
    from .scenarios import scenario_from_config
    from .simulation import simulate

    cfg = preset_config(args.preset) if args.preset else load_config(args.config)
    result = simulate(scenario_from_config(cfg))
    summary = result.summary()
    if args.out:
        from .plots import save_simulation_plots

        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "summary.json").write_text(_dump(summary))
        result.save_npz(args.out / "trajectory.npz")
        save_simulation_plots(result, args.out)
    if args.json:
        print(_dump(summary))
    else:
        for key, val in summary.items():
            print(f"{key:>24}: {val}")
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit code instead of calling ``sys.exit``."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return EXIT_OK
        handler = {"design": _cmd_design, "certify": _cmd_certify, "simulate": _cmd_simulate}[args.command]
        return handler(args)
    except _UsageError as exc:
        print(f"auv-hinf: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except SolverError as exc:
        print(f"auv-hinf: solver failure: {exc}", file=sys.stderr)
        return EXIT_NEGATIVE
    except (AuvHinfError, ValueError, OSError) as exc:
        print(f"auv-hinf: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
