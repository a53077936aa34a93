"""Replay: the certificate's assumptions re-evaluated on a run log, and compared with the run's own verdicts.

:func:`replay` runs the monitor (:class:`~auv_hinf.deployment.monitor.Monitor`) over the steps of a
log (:func:`~auv_hinf.deployment.log.read_log`: a Parquet log of ``auv-hinf run``, or a CSV log of a
real vehicle in the documented format) with the assumptions of a certificate. The desired motion
is the certificate's (at each measurement's time), never a column of the log. For a run log it
compares every step's violations with the logged ones: the monitor is deterministic in its inputs,
so a run's own log reproduces its verdicts exactly. A check whose columns a CSV log lacks is
skipped and listed under ``unchecked``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from auv_hinf._typing import FloatArray
from auv_hinf.deployment.log import ACHIEVED_COLUMNS, LAW_COLUMNS, STATE_COLUMNS, LogData
from auv_hinf.deployment.monitor import Monitor, StepInput, Violation
from auv_hinf.deployment.runtime import Assumptions, RuntimeLaw
from auv_hinf.exceptions import LogError

#: Tolerance of a replayed value against the logged one: both are the same float64 operations on
#: the same logged numbers, and JSON keeps every digit, so they agree to round-off.
VALUE_TOLERANCE = 1e-9
#: Violations kept in the result, and mismatches.
RESULT_VIOLATIONS, RESULT_MISMATCHES = 10_000, 100
#: The checks about the loop's timing, which a certificate of the continuous law (no sample time) does
#: not make: listed under ``unchecked`` when such a certificate replays a log (a simulated run).
TIMING_CHECKS = ("period", "lag", "delay", "stale")
#: The checks a log may lack the columns of, and those columns.
OPTIONAL_CHECKS = (
    ("delay", ("age",)),
    ("stale", ("nav_gap",)),
    ("heartbeat", ("heartbeat_gap",)),
    ("mode", ("mode",)),
    ("pilot_gain", ("gain",)),
    ("deliverable", ("saturated",)),
    ("current", ACHIEVED_COLUMNS),
)


@dataclass(frozen=True)
class ReplayResult:
    """What a replay found.

    Attributes
    ----------
    summary : dict
        ``steps``, ``covered``, ``violations`` (``[{time, vehicle, assumption, value, bound}]``),
        ``violation_count``, ``max_age``, ``max_period`` (s), ``reproduced`` (the run's own verdicts,
        ``None`` for a log without them), ``mismatches``, ``unchecked``, ``assumptions_match``
        (the log's stored assumptions are the certificate's; ``None`` without) and ``certified``.
    times : ndarray, shape (K,)
        The steps' times (s).
    errors : ndarray, shape (K, N, 4)
        Measured ``|e|, |e'|, |e_psi|, |e_r|`` per step and vehicle (m, m/s, rad, rad/s).
    ages : ndarray, shape (K, N)
        Measurement ages (s; NaN when the log has none).
    allowed : ndarray, shape (4,) or None
        The certified error bounds plus the noise, per channel (the velocity's without the
        heading-noise term); ``None`` without bounds.
    """

    summary: dict[str, Any]
    times: FloatArray
    errors: FloatArray
    ages: FloatArray
    allowed: FloatArray | None


def _column(g: pd.DataFrame, name: str, default: float) -> FloatArray:
    out: FloatArray = g[name].to_numpy(dtype=float) if name in g else np.full(len(g), default)
    return out


def _logged(g: pd.DataFrame) -> list[tuple[int, str, float | None]]:
    """The violations a run log holds for one step: ``(vehicle, assumption, value)``."""
    out = [(-1, d["assumption"], d["value"]) for d in json.loads(g["fleet_violations"].iloc[0])]
    for vehicle, text in zip(g["vehicle"], g["violations"]):
        out += [(int(vehicle), d["assumption"], d["value"]) for d in json.loads(text)]
    return sorted(out, key=lambda x: (x[0], x[1]))


def _same(logged: list[tuple[int, str, float | None]], found: list[Violation]) -> bool:
    got = sorted(((v.vehicle, v.assumption, v.to_dict()["value"]) for v in found), key=lambda x: (x[0], x[1]))
    if [x[:2] for x in logged] != [x[:2] for x in got]:
        return False
    for (_, _, a), (_, _, b) in zip(logged, got):
        if (a is None) != (b is None) or (a is not None and b is not None and abs(a - b) > VALUE_TOLERANCE):
            return False
    return True


def replay(data: LogData, law: RuntimeLaw) -> ReplayResult:
    """Re-evaluate ``law``'s assumptions on every step of ``data``.

    Parameters
    ----------
    data : LogData
        The log.
    law : RuntimeLaw
        The certified law of the run (:meth:`RuntimeLaw.from_certificate`): its assumptions, its
        desired motion and its command. The pilot gain is the log's mapping's when it has one.

    Returns
    -------
    ReplayResult
        The verdicts, and the measured errors for plotting.
    """
    frame, n = data.frame, law.n
    stored = data.meta_json("assumptions")
    mapping = data.meta_json("mapping")
    assumptions = law.assumptions
    if assumptions.pilot_gain is None and mapping is not None:
        assumptions = replace(assumptions, pilot_gain=float(mapping["gain"]))
    law = replace(law, assumptions=assumptions)
    monitor = Monitor(assumptions, n, law.law.params)
    has_log = {"violations", "fleet_violations"} <= set(frame.columns) and data.is_run_log
    unchecked = [name for name, cols in OPTIONAL_CHECKS if not all(c in frame.columns for c in cols)]
    if not assumptions.timed:  # the continuous law's certificate has no timing to check (Monitor)
        unchecked += [name for name in TIMING_CHECKS if name not in unchecked]
    found_all: list[dict[str, Any]] = []
    count, mismatches = 0, list[dict[str, Any]]()
    times: list[float] = []
    errors: list[FloatArray] = []
    ages_all: list[FloatArray] = []
    prev_time, max_age, max_period = math.nan, 0.0, 0.0
    for step, g in frame.groupby("step", sort=True):
        if len(g) != n:
            raise LogError(
                f"step {step} of the log has {len(g)} rows, for a fleet of {n} vehicles: the log is not of this "
                "configuration's fleet"
            )
        t = float(g["time"].iloc[0])
        period = float(g["period"].iloc[0]) if "period" in g else t - prev_time
        prev_time = t
        states = g[list(STATE_COLUMNS)].to_numpy(dtype=float)
        ages = _column(g, "age", math.nan)
        if "measured_at" in g:
            measured_at = g["measured_at"].to_numpy(dtype=float)
        else:
            measured_at = np.maximum(t - np.maximum(np.nan_to_num(ages, nan=0.0), 0.0), 0.0)
        if all(c in g for c in LAW_COLUMNS):
            commanded = g[list(LAW_COLUMNS)].to_numpy(dtype=float)
        else:
            commanded = law.commanded(measured_at, states)
        m = law.motion(measured_at)
        reference = np.column_stack([m.p, m.psi, m.v, m.r])
        saturated = g["saturated"].to_numpy(dtype=bool) if "saturated" in g else np.zeros(n, dtype=bool)
        inp = StepInput(
            t,
            period,
            states,
            ages,
            _column(g, "nav_gap", 0.0),
            _column(g, "heartbeat_gap", 0.0),
            commanded,
            saturated,
            reference,
            g["mode"].to_numpy(dtype=np.int64) if "mode" in g else None,
            _column(g, "gain", math.nan),
        )
        found = monitor.check(inp)
        made = (
            g[list(ACHIEVED_COLUMNS)].to_numpy(dtype=float) if "current" not in unchecked else np.full((n, 3), np.nan)
        )
        monitor.made(made)
        count += len(found)
        found_all += [v.to_dict() for v in found[: max(RESULT_VIOLATIONS - len(found_all), 0)]]
        if has_log and not _same(_logged(g), found) and len(mismatches) < RESULT_MISMATCHES:
            mismatches.append(
                {"step": int(step), "time": t, "logged": _logged(g), "replayed": [v.to_dict() for v in found]}
            )
        times.append(t)
        errors.append(law.errors(measured_at, states))
        ages_all.append(ages)
        if np.any(np.isfinite(ages)):
            max_age = max(max_age, float(np.nanmax(ages)))
        if math.isfinite(period):
            max_period = max(max_period, period)
    b, noise = assumptions.error_bounds, assumptions.noise
    allowed = (
        None
        if b is None
        else np.array(
            [
                b.position + noise.position,
                b.velocity + noise.velocity,
                b.heading + noise.heading,
                b.yaw_rate + noise.yaw_rate,
            ]
        )
    )
    summary = {
        "steps": len(times),
        "covered": count == 0 and assumptions.certified and bool(times),
        "violations": found_all,
        "violation_count": count,
        "max_age": max_age,
        "max_period": max_period,
        "reproduced": (not mismatches) if has_log else None,
        "mismatches": mismatches,
        "unchecked": unchecked,
        "assumptions_match": None if stored is None else _matches(stored, assumptions),
        "certified": assumptions.certified,
    }
    return ReplayResult(summary, np.asarray(times), np.asarray(errors), np.asarray(ages_all), allowed)


def _matches(stored: dict[str, Any], assumptions: Assumptions) -> bool:
    """The log's stored assumptions are ``assumptions`` (the ones replay checks)."""
    try:
        return Assumptions.from_dict(stored) == assumptions
    except ValueError:
        return False


__all__ = ["OPTIONAL_CHECKS", "RESULT_MISMATCHES", "RESULT_VIOLATIONS", "VALUE_TOLERANCE", "ReplayResult", "replay"]
