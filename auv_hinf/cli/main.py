"""Command-line interface ``auv-hinf``.

Exit codes: 0 success (consistent / certified / simulated / written / a run covered or stopped
by Ctrl-C); 1 a negative verdict (cross-check disagrees, not certified, no gain, a run the
certificate did not cover) or a solver, link or internal failure; 2 bad input (arguments,
configuration, unusable ``--out``); 130 Ctrl-C (SIGINT) elsewhere, after ``campaign`` and
``simulate`` have written what finished (``interrupted after K of M runs; results so far in
...``). Every failure is reported as one line per problem on stderr and never as a traceback,
unless ``--debug`` is given, which re-raises.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from typing import Any

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover - Python 3.10
    pass

from threadpoolctl import threadpool_limits

from auv_hinf._typing import GAIN_METHODS
from auv_hinf._version import __version__
from auv_hinf.cli.args import (
    ACTIONS,
    DESIGN_MAX_N,
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_NEGATIVE,
    EXIT_OK,
    NUMERIC_OPTIONS,
    PROG,
    BadInput,
    Negative,
    Parser,
    Stopped,
    UsageError,
    join_numbers,
    numeric,
    path,
    per_vehicle,
    vector,
)
from auv_hinf.config.presets import PRESETS
from auv_hinf.config.schema import GAMMA_RANGE, MAX_DESIGN_RATE
from auv_hinf.exceptions import AuvHinfError, LinkError, SolverError
from auv_hinf.law.gains import DEFAULT_K1


def build_parser() -> argparse.ArgumentParser:
    """The ``auv-hinf`` argument parser."""
    parser = Parser(prog=PROG, description="Certified H-infinity formation control for AUV fleets", allow_abbrev=False)
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("--debug", action="store_true", help="re-raise errors with their traceback")
    sub = parser.add_subparsers(dest="command", parser_class=Parser)

    d = sub.add_parser("design", help="Theorem 1 gains three ways, cross-checked four ways", allow_abbrev=False)
    numeric(d, "--lam", float, -MAX_DESIGN_RATE, 0.0, strict="hi", required=True, help="nominal lambda < 0 (1/s)")
    numeric(d, "--gamma", float, *GAMMA_RANGE, required=True, help="H-infinity bound gamma > 0 (s)")
    numeric(d, "--n", int, 2, DESIGN_MAX_N, default=3, help=f"number of vehicles, 2..{DESIGN_MAX_N} (default 3)")
    numeric(
        d,
        "--k1",
        float,
        0.0,
        MAX_DESIGN_RATE,
        strict="lo",
        default=DEFAULT_K1,
        help=f"Theorem 2 position gain (1/s^2), default {DEFAULT_K1:g}",
    )
    d.add_argument("--json", action="store_true", help="print one JSON object")

    for name, text in (("certify", "certify a formation design"), ("simulate", "simulate a scenario")):
        c = sub.add_parser(name, help=text, allow_abbrev=False)
        src = c.add_mutually_exclusive_group(required=True)
        src.add_argument("--preset", choices=PRESETS, help=f"built-in preset ({', '.join(PRESETS)})")
        src.add_argument("--config", type=path, help="TOML configuration file")
        c.add_argument("--json", action="store_true", help="print one JSON object")
        c.add_argument("--out", type=path, help="directory for JSON and PNG outputs (created)")
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
            NUMERIC_OPTIONS.update(("--current",))
            c.add_argument(
                "--current",
                type=vector(2, "m/s"),
                metavar="CX,CY",
                help="constant current, inertial frame, m/s (e.g. --current 0.1,0)",
            )
            c.add_argument(
                "--save",
                type=path,
                metavar="FILE.parquet",
                help="also write every vehicle's state every 0.1 s to this Parquet file (its folder is created), "
                "streamed in row groups (memory O(N) at any N; one more integration of the run)",
            )
            c.add_argument(
                "--uncertified",
                action="store_true",
                help="simulate even when no certificate covers the gains (the run is then reported as not covered)",
            )
            c.add_argument(
                "--six-dof",
                action="store_true",
                help="[guidance] fleets of REMUS 100: run the cascade on the 6-DOF model, depth held at 5 m",
            )
        NUMERIC_OPTIONS.add("--actuators")
        c.add_argument(
            "--actuators",
            type=vector(3, "N, N, N m", positive=True),
            metavar="FX,FY,M",
            help="actuator limits |tau_x|, |tau_y| (N) and |tau_psi| (N m); overrides [actuators]",
        )
        if name == "certify":
            c.add_argument("--method", choices=GAIN_METHODS, help="gain method")
            c.add_argument(
                "--refine-jacobi",
                action="store_true",
                help="tighten the Jacobi sigma bound by branch-and-bound (N <= 3, ~25 s)",
            )

    sc = sub.add_parser(
        "schema", help="print the JSON Schema of the TOML configuration (or of certificate files)", allow_abbrev=False
    )
    sc.add_argument(
        "--certificate", action="store_true", help="the schema of the files certify --out and Certificate.save write"
    )
    i = sub.add_parser("init", help="write an annotated starting configuration", allow_abbrev=False)
    i.add_argument("--out", type=path, help="file to write (default: print to stdout)")
    i.add_argument("--preset", choices=PRESETS, default=PRESETS[0], help=f"starting point (default {PRESETS[0]})")
    i.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    _campaign_parser(sub)
    _deployment_parsers(sub)
    commands = ("certify", "simulate", "schema", "init", "campaign", "run", "fleet-sim", "replay")
    for p in (d, *(sub.choices[k] for k in commands)):
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    return parser


def _campaign_parser(sub: Any) -> None:
    """The ``campaign`` sub-command's arguments."""
    c = sub.add_parser("campaign", help="Monte Carlo runs from inside the certified start region", allow_abbrev=False)
    src = c.add_mutually_exclusive_group(required=True)
    src.add_argument("--preset", choices=PRESETS, help=f"built-in preset ({', '.join(PRESETS)})")
    src.add_argument("--config", type=path, help="TOML configuration file")
    numeric(c, "--runs", int, 1, 10**7, required=True, help="number of runs K")
    numeric(c, "--seed", int, 0, 2**63 - 1, default=0, help="root seed (default 0)")
    ex = c.add_mutually_exclusive_group()
    numeric(ex, "--workers", int, 1, 1024, help="local Dask cluster of W single-threaded worker processes")
    ex.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. tcp://host:8786")
    numeric(
        c,
        "--chunk",
        int,
        1,
        10**6,
        help="scenarios per batch (default: as many as the memory budget allows)",
    )
    numeric(c, "--horizon", float, 1e-6, 1e5, help="simulated time in s (default: the config's)")
    c.add_argument("--out", type=path, required=True, help="directory for runs.parquet, summary.json, PNGs")
    c.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    c.add_argument(
        "--uncertified",
        action="store_true",
        help="run even when no certificate covers the gains (no run is then covered by a certificate)",
    )


def _source(c: argparse.ArgumentParser, certificate: bool = True) -> None:
    """``--preset`` or ``--config`` (or ``--certificate``), exactly one."""
    src = c.add_mutually_exclusive_group(required=True)
    src.add_argument("--preset", choices=PRESETS, help=f"built-in preset ({', '.join(PRESETS)})")
    src.add_argument("--config", type=path, help="TOML configuration file")
    if certificate:
        src.add_argument(
            "--certificate", type=path, help="a certificate file written by certify --out (not certified again)"
        )


def _deployment_parsers(sub: Any) -> None:
    """The ``run``, ``fleet-sim`` and ``replay`` sub-commands' arguments."""
    r = sub.add_parser(
        "run", help="run the certified law on MAVLink vehicles under the runtime monitor", allow_abbrev=False
    )
    _source(r)
    r.add_argument("--connect", action="append", metavar="URL", help="pymavlink connection string, one per vehicle")
    numeric(r, "--duration", float, 1e-3, 1e7, required=True, help="length of the run in s")
    r.add_argument(
        "--log", type=path, required=True, metavar="FILE.parquet", help="the run log (its folder is created)"
    )
    r.add_argument("--json", action="store_true", help="print the run's summary as one JSON object")
    r.add_argument("--on-violation", choices=ACTIONS, help="action on every violated assumption (default: see docs)")
    r.add_argument(
        "--action", action="append", default=[], metavar="NAME=ACTION", help="action on one assumption, e.g. delay=hold"
    )
    numeric(r, "--gain", float, 0.1, 1.0, help="the vehicles' ArduSub pilot gain (default: [deploy] pilot_gain)")
    numeric(r, "--voltage", float, 12.0, 20.0, help="thruster supply voltage in V (default: [deploy] voltage)")
    numeric(r, "--rate", float, 0.1, 50.0, help="navigation rate to ask for, Hz (default: [deploy] telemetry_rate)")
    numeric(r, "--command-latency", float, 0.0, 60.0, help="delay share of the command's way, s ([deploy])")
    numeric(r, "--wait", float, 0.1, 600.0, default=5.0, help="how long to wait for every vehicle, s (default 5)")
    r.add_argument("--uncertified", action="store_true", help="run even when the certificate does not hold")
    r.add_argument("--realtime", action="store_true", help="ask for real-time scheduling of the loop (Linux)")

    f = sub.add_parser("fleet-sim", help="simulated vehicles speaking ArduSub's MAVLink on UDP", allow_abbrev=False)
    _source(f)
    f.add_argument("--listen", action="append", required=True, metavar="URL", help="one connection string per vehicle")
    for flag, text in (
        ("--latency", "one-way latency each way, s"),
        ("--jitter", "uniform extra latency, s"),
        ("--loss", "navigation message loss probability"),
        ("--command-loss", "MANUAL_CONTROL loss probability"),
    ):
        f.add_argument(
            flag, type=per_vehicle, default=(0.0,), metavar="X[,X...]", help=f"{text}: one, or one per vehicle"
        )
    NUMERIC_OPTIONS.update(("--current", "--latency", "--jitter", "--loss", "--command-loss"))
    f.add_argument("--current", type=vector(2, "m/s"), default=(0.0, 0.0), metavar="CX,CY", help="current, m/s")
    numeric(f, "--rate", float, 0.1, 1000.0, default=50.0, help="navigation rate until asked otherwise, Hz")
    f.add_argument("--odometry", action="store_true", help="also send ODOMETRY")
    f.add_argument("--no-timesync", action="store_true", help="do not answer TIMESYNC")
    numeric(f, "--gain", float, 0.1, 1.0, default=1.0, help="the vehicles' pilot gain (default 1)")
    numeric(f, "--voltage", float, 12.0, 20.0, default=16.0, help="thruster supply voltage, V (default 16)")
    numeric(f, "--mode", int, 0, 255, default=19, help="custom_mode reported (default 19, MANUAL)")
    numeric(f, "--sysid", int, 1, 250, default=1, help="system id of vehicle 0 (default 1)")
    numeric(f, "--seed", int, 0, 2**63 - 1, default=0, help="seed of the jitter and the losses")
    numeric(f, "--duration", float, 1e-3, 1e7, help="exit after this many s (default: on SIGINT or SIGTERM)")
    f.add_argument("--report", type=path, metavar="FILE.json", help="write what the vehicles received on exit")
    f.add_argument("--realtime", action="store_true", help="ask for real-time scheduling of the vehicles (Linux)")

    p = sub.add_parser("replay", help="re-evaluate a run log against the certificate's assumptions", allow_abbrev=False)
    p.add_argument("log", type=path, help="a Parquet log of run, or a CSV log in the documented format")
    _source(p)
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.add_argument("--plot", type=path, metavar="FILE.png", help="plot the errors and ages against the bounds")


def _report(kind: str, exc: BaseException) -> None:
    """Print ``exc`` as one line per problem on stderr (``kind`` empty: the line alone)."""
    lines = [line for line in str(exc).splitlines() if line.strip()] or [type(exc).__name__]
    for line in lines:
        print(f"{PROG}: {kind}: {line}" if kind else f"{PROG}: {line}", file=sys.stderr)


def _classify(exc: BaseException) -> tuple[int, str]:
    """Exit code and label of an exception that reached the boundary."""
    if isinstance(exc, (UsageError, BadInput)):
        return EXIT_BAD_INPUT, "error"
    if isinstance(exc, Negative):
        return EXIT_NEGATIVE, "not certified"
    if isinstance(exc, Stopped):
        return EXIT_INTERRUPTED, ""
    if isinstance(exc, SolverError) or type(exc).__name__ == "SolverError":
        return EXIT_NEGATIVE, "solver failure"
    if isinstance(exc, LinkError):
        return EXIT_NEGATIVE, "link failure"
    if isinstance(exc, AuvHinfError) and isinstance(exc, ValueError):
        return EXIT_BAD_INPUT, "error"  # parameter, formation, envelope, design or config input
    if isinstance(exc, OSError):
        return EXIT_BAD_INPUT, "error"
    if isinstance(exc, ArithmeticError):  # overflow or division by zero from an extreme input value
        return EXIT_BAD_INPUT, "error: a value is too large or too small to compute with (check the magnitudes given)"
    return EXIT_INTERNAL, "internal error"


#: BLAS threads of a command (see :func:`main`).
BLAS_THREADS = 1


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
        # the certificates multiply many small matrices: several BLAS threads per process only
        # contend for the cores (a 3x3 exponential took 15 ms instead of 11 us on a loaded 2-core
        # machine); the Dask workers of a campaign are processes of their own
        # the commands import the certificates (python-control, SciPy, Matplotlib: about 2.5 s),
        # which --help, --version and a bad argument do not need
        from auv_hinf.cli.commands import COMMANDS

        with threadpool_limits(limits=BLAS_THREADS, user_api="blas"):
            return COMMANDS[args.command](args)
    except KeyboardInterrupt:  # Ctrl-C before anything finished: one line, no traceback
        if debug:
            raise
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # the reader went away (`auv-hinf ... | head`): stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_OK
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
        if "--json" in args_list:
            # every failure is still an answer: a reader of --json gets one JSON object on stdout (a
            # negative answer, bad input, an internal error), beside the same line on stderr
            message = [line for line in str(exc).splitlines() if line.strip()] or [type(exc).__name__]
            print(json.dumps({"ok": False, "error": kind, "message": "; ".join(message), "exit_code": code}))
        return code


if __name__ == "__main__":
    sys.exit(main())


__all__ = ["build_parser", "main"]
