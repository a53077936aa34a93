"""The fixed-rate loop that runs a certified law on MAVLink vehicles under the runtime monitor.

:func:`run` first waits until every vehicle has sent a HEARTBEAT, a position and a heading, and
answered a TIMESYNC (:func:`wait_for_vehicles`). Then, at ``t_k = t_0 + k h`` with ``h`` the certified
sample time, one step:

1. reads each vehicle's newest state and its age (:meth:`~auv_hinf.deployment.link.VehicleLink.state`);
2. steps the certified law on each measurement at the instant it was taken, ``max(t_k - age, 0)``
   (:class:`~auv_hinf.deployment.runtime.RuntimeLaw`, the convention of the sampled simulation);
3. checks the certificate's assumptions (:class:`~auv_hinf.deployment.monitor.Monitor`) and takes
   the most severe configured action: ``warn`` logs; ``hold`` switches, for the rest of the run,
   to the same gains holding every vehicle where it is (:meth:`RuntimeLaw.holding`); ``stop``
   sends neutral to every vehicle and ends the run;
4. encodes the forces as MANUAL_CONTROL (:class:`~auv_hinf.deployment.ardusub.ArduSubMapping`) and
   sends them;
5. logs one row per vehicle (:class:`~auv_hinf.deployment.log.RunLog`);
6. once a second, sends a HEARTBEAT and a TIMESYNC to each vehicle.

Between the steps the loop waits in ``select`` on every vehicle's socket and reads each message as it
arrives, so that messages are time-stamped on arrival. A step that overruns by more than a period
skips the missed ticks and keeps the phase (the monitor's ``period`` check reports it). Every exit
(the duration, Ctrl-C, SIGTERM or SIGHUP, or ``stop_event``, a ``stop`` action, an exception) sends a
neutral command to every vehicle :data:`NEUTRAL_REPEATS` times, :data:`NEUTRAL_SPACING` apart (UDP may
drop one). A fleet whose first measurement is outside the certified bounds (the invariant checks of
:data:`START_ASSUMPTIONS`) gets neutral only, whatever the configured actions: the certificate does not
cover a start there, and the law could ask for full force.
The run is **covered** when the certificate holds and no assumption was violated at any step.
"""

from __future__ import annotations

import json
import math
import select
import signal
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.deployment.ardusub import NEUTRAL, ManualCommand
from auv_hinf.deployment.link import VehicleLink, now_ns
from auv_hinf.deployment.log import RunLog
from auv_hinf.deployment.monitor import (
    ASSUMPTIONS,
    Action,
    Monitor,
    MonitorConfig,
    StepInput,
    Violation,
    violations_json,
)
from auv_hinf.deployment.priority import realtime_priority
from auv_hinf.deployment.runtime import RuntimeLaw
from auv_hinf.exceptions import LinkError, ParameterError
from auv_hinf.law.formation_law import saturate

#: Interval of the HEARTBEAT and TIMESYNC to every vehicle (s): ArduSub's GCS failsafe waits 2.5 s.
HEARTBEAT_INTERVAL = 1.0
#: Neutral commands sent at every exit, and their spacing (s).
NEUTRAL_REPEATS, NEUTRAL_SPACING = 3, 0.02
#: While waiting for the vehicles: how often they are pinged (s), and how long a vehicle that does not
#: answer TIMESYNC is given before its SYSTEM_TIME is used for the ages instead (s).
WAIT_PING, WAIT_SYSTEM_TIME = 0.2, 1.0
#: Violations kept in the summary (every one is in the log).
SUMMARY_VIOLATIONS = 10_000
#: The signals that end a run as Ctrl-C does (neutral sent, summary, log closed): SIGINT, SIGTERM (what
#: ``timeout``, systemd and docker send) and SIGHUP (a closed terminal), where the platform has them.
STOP_SIGNALS: tuple[int, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)
#: The assumptions whose violation at the first step refuses the run before any command but neutral
#: is sent: a fleet that starts outside the certified bounds is not covered by the certificate from
#: there, and the law may command full force towards the mission.
START_ASSUMPTIONS = tuple(name for name in ASSUMPTIONS if name.startswith("invariant_"))


@dataclass
class RunStats:
    """Running figures of a run.

    Attributes
    ----------
    steps : int
        Steps taken.
    periods : list of float
        Every period between steps (s).
    max_age : float
        Largest measurement age (s).
    violations : list of dict
        The first :data:`SUMMARY_VIOLATIONS` violation records.
    violation_count : int
        Every violation.
    action : Action or None
        The most severe action taken.
    start_refused : bool
        The first step's measurement was outside the certified bounds: only neutral was sent.
    """

    steps: int = 0
    periods: list[float] = field(default_factory=list)
    max_age: float = 0.0
    violations: list[dict[str, Any]] = field(default_factory=list)
    violation_count: int = 0
    action: Action | None = None
    start_refused: bool = False

    def record(self, found: list[Violation], action: Action | None) -> None:
        """Count one step's violations and action.

        Parameters
        ----------
        found : list of Violation
            The step's violations.
        action : Action or None
            The action taken.
        """
        self.violation_count += len(found)
        room = SUMMARY_VIOLATIONS - len(self.violations)
        self.violations += [v.to_dict() for v in found[: max(room, 0)]]
        if action is not None and (self.action is None or action.severity > self.action.severity):
            self.action = action


def wait_for_vehicles(links: list[VehicleLink], timeout: float, stop: threading.Event) -> None:
    """Ping every vehicle until each has sent a HEARTBEAT and navigation, and its clock is known.

    A vehicle that does not answer TIMESYNC is accepted after :data:`WAIT_SYSTEM_TIME` with a
    SYSTEM_TIME, or else with its reception times (a lower bound of the ages).

    Parameters
    ----------
    links : list of VehicleLink
        The vehicles.
    timeout : float
        How long to wait (s).
    stop : threading.Event
        Ends the wait early (Ctrl-C).

    Raises
    ------
    LinkError
        If a vehicle sends no HEARTBEAT or no navigation within ``timeout``; the message names it.
    """
    fds = {ln.fileno(): ln for ln in links}
    start = time.monotonic()
    last_ping = -math.inf
    while not stop.is_set():
        now = time.monotonic()
        if now - last_ping >= WAIT_PING:
            for ln in links:
                ln.send_heartbeat()
                if now - start < 1.0 or not ln.has_navigation:
                    ln.request_streams()
                ln.send_timesync()
            last_ping = now
        ready, _, _ = select.select(list(fds), [], [], 0.05)
        for fd in ready:
            fds[fd].poll()
        waited = now - start
        clocks = all(ln.clock.ready or waited > WAIT_SYSTEM_TIME for ln in links)
        if clocks and all(ln.has_navigation and ln.heartbeat_ns is not None for ln in links):
            return
        if waited > timeout:
            missing = []
            for ln in links:
                gone = [
                    w
                    for w, ok in (("HEARTBEAT", ln.heartbeat_ns is not None), ("navigation", ln.has_navigation))
                    if not ok
                ]
                if gone:
                    missing.append(f"vehicle {ln.index + 1} ({ln.url}): no {' and no '.join(gone)}")
            raise LinkError(
                f"no answer within {timeout:g} s: {'; '.join(missing)} "
                "(navigation is LOCAL_POSITION_NED with ATTITUDE, or ODOMETRY)"
            )
    return


def _send_neutral(links: list[VehicleLink]) -> None:
    """Neutral to every vehicle, :data:`NEUTRAL_REPEATS` times."""
    for k in range(NEUTRAL_REPEATS):
        for ln in links:
            try:
                ln.send_neutral()
            except LinkError:
                pass  # a vehicle that cannot be reached cannot be told either; the others still are
        if k + 1 < NEUTRAL_REPEATS:
            time.sleep(NEUTRAL_SPACING)


def _reference_rows(law: RuntimeLaw, measured_at: FloatArray) -> FloatArray:
    """The desired motion ``[x, y, psi, vx, vy, r]`` of every vehicle at its measurement time, ``(N, 6)``."""
    m = law.motion(measured_at)
    return np.column_stack([m.p, m.psi, m.v, m.r])


def run(
    law: RuntimeLaw,
    links: list[VehicleLink],
    duration: float,
    log_path: str | Path,
    *,
    config: MonitorConfig | None = None,
    wait_timeout: float = 5.0,
    stop_event: threading.Event | None = None,
    install_sigint: bool = True,
    metadata: dict[str, str] | None = None,
    realtime: bool = False,
) -> dict[str, Any]:
    """Run ``law`` on ``links`` for ``duration`` s at its certified sample time, logging to ``log_path``.

    Parameters
    ----------
    law : RuntimeLaw
        The certified law; its ``sample_time`` must be positive.
    links : list of VehicleLink
        One per vehicle, in the law's vehicle order; they share one mapping.
    duration : float
        Length of the run (s, > 0).
    log_path : str or Path
        The Parquet log (its folder must exist); written once every vehicle has answered, so a run
        that never starts leaves an earlier file there as it was.
    config : MonitorConfig, optional
        The action of each assumption (default: :class:`MonitorConfig`'s).
    wait_timeout : float
        How long to wait for every vehicle before the first step (s).
    stop_event : threading.Event, optional
        Set it to stop the loop as Ctrl-C does.
    install_sigint : bool
        Stop on SIGINT, SIGTERM and SIGHUP during the run (:data:`STOP_SIGNALS`; main thread only).
    metadata : dict of str to str, optional
        More key-value metadata for the log.
    realtime : bool
        Run the steps at real-time priority (:func:`~auv_hinf.deployment.priority.realtime_priority`),
        restored afterwards.

    Returns
    -------
    dict
        ``steps``, ``covered``, ``violations`` (``[{time, vehicle, assumption, value, bound}]``),
        ``max_age``, ``max_period`` (s), ``mean_period``, ``std_period`` (s), ``violation_count``,
        ``certified``, ``stopped_by`` (``"duration"``, ``"sigint"``, ``"sigterm"``, ``"sighup"``,
        ``"stop_event"``, ``"monitor"`` or ``"start"``: the first measurement outside the certified
        bounds), ``action``, ``priority`` (what the scheduler granted) and ``log``.

    Raises
    ------
    ParameterError
        For a law without a sample time, a fleet that does not match the law, or a bad duration.
    LinkError
        If a vehicle does not answer before the first step, or a send fails.
    """
    n = len(links)
    if law.sample_time <= 0.0:
        raise ParameterError(
            "the certificate declares no sample time: a fixed-rate loop is not what it certifies "
            "(declare [implementation] sample_time and delay, and certify them)"
        )
    if n != law.n:
        raise ParameterError(f"the law is for {law.n} vehicles, got {n} connection(s)")
    if not (math.isfinite(duration) and duration > 0.0):
        raise ParameterError(f"duration must be > 0 s, got {duration!r}")
    mapping = links[0].mapping
    assumptions = law.assumptions
    if assumptions.pilot_gain is None:
        assumptions = replace(assumptions, pilot_gain=mapping.gain)
    law = replace(law, assumptions=assumptions)
    cfg = config or MonitorConfig()
    monitor = Monitor(assumptions, n, law.law.params)
    stop = stop_event or threading.Event()
    meta = {
        "assumptions": json.dumps(assumptions.to_dict()),
        "monitor": json.dumps(cfg.to_dict()),
        "mapping": json.dumps(mapping.to_dict()),
        "urls": json.dumps([ln.url for ln in links]),
        "n_vehicles": str(n),
        **(metadata or {}),
    }
    old_handlers: dict[int, Any] = {}
    received: list[str] = []
    if install_sigint and threading.current_thread() is threading.main_thread():

        def _interrupt(signum: int, frame: FrameType | None) -> None:
            received.append(signal.Signals(signum).name.lower())
            stop.set()

        # a supervisor (timeout, systemd, docker) stops a process with SIGTERM, a closed terminal with
        # SIGHUP: each ends the run as Ctrl-C does, with neutral sent and the log closed
        for sig in STOP_SIGNALS:
            old_handlers[sig] = signal.signal(sig, _interrupt)
    stats = RunStats()
    stopped_by, priority = "duration", "normal"
    log: RunLog | None = None
    try:
        wait_for_vehicles(links, wait_timeout, stop)
        log = RunLog(log_path, meta)  # after the link is up: a run that never starts keeps an earlier log
        with realtime_priority(realtime) as priority:
            stopped_by = _loop(law, links, duration, cfg, monitor, log, stats, stop)
        if stopped_by == "interrupted":
            stopped_by = (received[0] if received else "sigint") if stop_event is None else "stop_event"
    finally:
        _send_neutral(links)
        for sig, old in old_handlers.items():
            signal.signal(sig, old)
        if log is not None:
            log.close()
    periods = np.asarray(stats.periods)
    return {
        "steps": stats.steps,
        "covered": stats.violation_count == 0 and assumptions.certified and stats.steps > 0,
        "violations": stats.violations,
        "max_age": stats.max_age,
        "max_period": float(periods.max()) if periods.size else math.nan,
        "mean_period": float(periods.mean()) if periods.size else math.nan,
        "std_period": float(periods.std()) if periods.size else math.nan,
        "violation_count": stats.violation_count,
        "certified": assumptions.certified,
        "stopped_by": stopped_by,
        "action": None if stats.action is None else stats.action.value,
        "priority": priority,
        "log": str(log_path),
    }


def _loop(
    law: RuntimeLaw,
    links: list[VehicleLink],
    duration: float,
    cfg: MonitorConfig,
    monitor: Monitor,
    log: RunLog,
    stats: RunStats,
    stop: threading.Event,
) -> str:
    """The steps of :func:`run`; returns why it ended (``"duration"``, ``"interrupted"`` or ``"monitor"``)."""
    n = len(links)
    mapping = links[0].mapping
    fds = {ln.fileno(): ln for ln in links}
    period_ns = round(law.sample_time * 1e9)
    t0 = now_ns()
    next_tick, last_tick, last_ping, k = t0, None, t0, 0
    active = law
    while True:
        while True:  # wait for the tick, reading messages as they come
            t = now_ns()
            if t >= next_tick or stop.is_set():
                break
            ready, _, _ = select.select(list(fds), [], [], (next_tick - t) * 1e-9)
            for fd in ready:
                fds[fd].poll()
        if stop.is_set():
            return "interrupted"
        tick = now_ns()
        for ln in links:
            ln.poll()
        t_s = (tick - t0) * 1e-9
        if t_s > duration + 1e-9:
            return "duration"
        period = math.nan if last_tick is None else (tick - last_tick) * 1e-9
        last_tick = tick
        states, ages, sources = np.full((n, 6), np.nan), np.full(n, np.nan), []
        nav_gap, beat_gap = np.full(n, np.inf), np.full(n, np.inf)
        for i, ln in enumerate(links):
            states[i], ages[i], source = ln.state(tick)
            nav_gap[i], beat_gap[i] = ln.gaps(tick)
            sources.append(source)
        if not np.all(np.isfinite(states)):
            raise LinkError("a vehicle's navigation became unavailable")  # cannot happen after the wait
        measured_at = np.maximum(t_s - np.maximum(np.nan_to_num(ages, nan=0.0), 0.0), 0.0)
        commanded = law.commanded(measured_at, states)
        reference = _reference_rows(law, measured_at)
        if active.name == "certified":
            sent = saturate(commanded, law.law.actuators, states[..., 3])[0]
        else:
            sent = active.step(measured_at, states)
        cmds = [mapping.forces_to_manual_control(sent[i]) for i in range(n)]
        saturated = np.array([c.saturated for c in cmds])
        modes = np.array([ln.custom_mode for ln in links], dtype=np.int64)
        gains = np.array([ln.pilot_gain for ln in links])
        step = StepInput(t_s, period, states, ages, nav_gap, beat_gap, commanded, saturated, reference, modes, gains)
        found = monitor.check(step)
        action = cfg.most_severe(found)
        if k == 0 and any(v.assumption in START_ASSUMPTIONS for v in found):
            # the first measurement is outside the certified bounds: the law is not certified from
            # there, and it may ask for full force; nothing but neutral is sent
            action, stats.start_refused = Action.STOP, True
        stats.record(found, action)
        name = active.name
        if action is Action.STOP:
            name, sent, cmds = "neutral", np.zeros((n, 3)), [NEUTRAL] * n
        elif action is Action.HOLD and active.name == "certified":
            active = law.holding(states)
            name, sent = active.name, active.step(measured_at, states)
            cmds = [mapping.forces_to_manual_control(sent[i]) for i in range(n)]
        for i, ln in enumerate(links):
            ln.send_command(cmds[i])
        monitor.made(np.array([c.achieved for c in cmds]))
        _log_step(log, k, t_s, period, step, measured_at, sources, links, sent, cmds, name, action, found, monitor)
        stats.steps += 1
        if math.isfinite(period):
            stats.periods.append(period)
        if np.any(np.isfinite(ages)):
            stats.max_age = max(stats.max_age, float(np.nanmax(ages)))
        if name == "neutral":
            return "start" if stats.start_refused else "monitor"
        if (tick - last_ping) * 1e-9 >= HEARTBEAT_INTERVAL:
            for ln in links:
                ln.send_heartbeat()
                ln.send_timesync()
            last_ping = tick
        k += 1
        next_tick = t0 + k * period_ns
        late = now_ns() - next_tick
        if late > period_ns:  # overran by more than a period: skip the missed ticks, keep the phase
            k += late // period_ns
            next_tick = t0 + k * period_ns


def _log_step(
    log: RunLog,
    k: int,
    t_s: float,
    period: float,
    step: StepInput,
    measured_at: FloatArray,
    sources: list[str],
    links: list[VehicleLink],
    sent: FloatArray,
    cmds: list[ManualCommand],
    law_name: str,
    action: Action | None,
    found: list[Violation],
    monitor: Monitor,
) -> None:
    """One row per vehicle of step ``k`` (the columns of :data:`~auv_hinf.deployment.log.SCHEMA`)."""
    by_vehicle: dict[int, list[Violation]] = {}
    for v in found:
        by_vehicle.setdefault(v.vehicle, []).append(v)
    fleet = json.dumps(violations_json(by_vehicle.get(-1, [])))
    assert step.reference is not None and step.modes is not None and step.gains is not None
    for i, ln in enumerate(links):
        c = cmds[i]
        row: dict[str, Any] = {"step": k, "time": t_s, "period": period, "vehicle": i}
        row.update(zip(("x", "y", "psi", "u", "v", "r"), map(float, step.states[i])))
        row.update(
            {
                "age": float(step.ages[i]),
                "age_source": sources[i],
                "measured_at": float(measured_at[i]),
                "nav_gap": float(step.nav_gap[i]),
                "heartbeat_gap": float(step.heartbeat_gap[i]),
                "rtt": ln.rtt,
                "mode": int(step.modes[i]),
                "gain": float(step.gains[i]),
            }
        )
        row.update(zip(("ref_x", "ref_y", "ref_psi", "ref_vx", "ref_vy", "ref_r"), map(float, step.reference[i])))
        row.update(zip(("law_tau_x", "law_tau_y", "law_tau_psi"), map(float, step.commanded[i])))
        row.update(zip(("tau_x", "tau_y", "tau_psi"), map(float, sent[i])))
        row.update({"cmd_x": c.x, "cmd_y": c.y, "cmd_z": c.z, "cmd_r": c.r})
        row.update(zip(("ach_tau_x", "ach_tau_y", "ach_tau_psi"), map(float, c.achieved)))
        row.update(
            {
                "saturated": bool(step.saturated[i]),
                "law": law_name,
                "action": "" if action is None else action.value,
                "current": float(monitor.current_speed[i]),
                "violations": json.dumps(violations_json(by_vehicle.get(i, []))),
                "fleet_violations": fleet,
            }
        )
        log.add(row)
    log.end_step()


__all__ = [
    "HEARTBEAT_INTERVAL",
    "NEUTRAL_REPEATS",
    "NEUTRAL_SPACING",
    "SUMMARY_VIOLATIONS",
    "WAIT_PING",
    "WAIT_SYSTEM_TIME",
    "RunStats",
    "run",
    "wait_for_vehicles",
]
