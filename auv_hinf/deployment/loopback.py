"""The loopback fleet: N simulated vehicles that speak ArduSub's MAVLink over UDP, for offline runs and tests.

Each vehicle is the package's 3-DOF model (:func:`~auv_hinf.models.vehicle.plant_derivative`:
water-relative body velocities, ``p' = R(psi) [u, v] + c`` with a constant current ``c``),
integrated by RK4 every :data:`SIM_STEP` in real time. It

* holds its start state until its first MANUAL_CONTROL (a vehicle put on its slot by a pilot);
  then it moves under the force that command makes through the same
  :class:`~auv_hinf.deployment.ardusub.ArduSubMapping` the controller inverts, held until the next
  command, and goes neutral :data:`PILOT_TIMEOUT` after the last (ArduSub's pilot-input failsafe);
* sends HEARTBEAT (1 Hz; a submarine in ``mode``, armed), NAMED_VALUE_FLOAT "PilotGain" and
  SYSTEM_TIME (1 Hz), LOCAL_POSITION_NED and ATTITUDE (``rate`` Hz, changed by
  MAV_CMD_SET_MESSAGE_INTERVAL) and, with ``odometry``, ODOMETRY; velocities over ground;
* answers TIMESYNC as ArduPilot does (``tc1`` its boot clock in ns), unless ``timesync`` is off;
* accepts MANUAL_CONTROL only from system 255 addressed to it;
* injects per vehicle a one-way latency in each direction, a uniform jitter on top, the loss of
  navigation messages (LOCAL_POSITION_NED, ATTITUDE, ODOMETRY; heartbeats and replies get through)
  and the loss of commands.

``auv-hinf fleet-sim`` runs it from a configuration (the vehicle model, the fleet size and the
start on the slots of the raw mission); its first line on stdout is
``{"ready": true, "endpoints": [...], "pid": ...}`` with the bound connection strings.
"""

from __future__ import annotations

import heapq
import math
import os
import random
import select
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pymavlink import mavutil

from auv_hinf._typing import FloatArray
from auv_hinf.certificate.design_point import design_point, slot_states
from auv_hinf.config.settings import FormationConfig
from auv_hinf.deployment.ardusub import MODE_MANUAL, ArduSubMapping
from auv_hinf.deployment.link import GCS_SYSTEM_ID, mavlink
from auv_hinf.exceptions import LinkError, ParameterError
from auv_hinf.models.vehicle import VehicleParams, plant_derivative

#: Integration step of the vehicles (s): 40 steps per 0.2 s, well inside RK4's accuracy at the
#: BlueROV2's fastest time constant (m33 / d33 at the envelope's yaw rate, about 2 s).
SIM_STEP = 0.005
#: ArduSub's FS_PILOT_TIMEOUT default (s): no MANUAL_CONTROL for this long and the vehicle goes neutral.
PILOT_TIMEOUT = 3.0
#: Default navigation rate (Hz), as the link asks for.
DEFAULT_RATE = 50.0
#: Longest ``select`` wait of the loop (s): the physics never falls further behind than this.
MAX_WAIT = 0.05


@dataclass(frozen=True)
class LinkFaults:
    """What the loopback injects on one vehicle's link.

    Attributes
    ----------
    latency : float
        One-way latency in each direction (s).
    jitter : float
        Extra latency, uniform in ``[0, jitter]`` (s).
    loss : float
        Probability that a navigation message is lost.
    command_loss : float
        Probability that a MANUAL_CONTROL is lost.
    """

    latency: float = 0.0
    jitter: float = 0.0
    loss: float = 0.0
    command_loss: float = 0.0

    def __post_init__(self) -> None:
        for name in ("latency", "jitter"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0.0):
                raise ParameterError(f"{name} must be a finite number >= 0 s, got {getattr(self, name)!r}")
        for name in ("loss", "command_loss"):
            p = float(getattr(self, name))
            if not 0.0 <= p <= 1.0:
                raise ParameterError(f"{name} must be a probability in [0, 1], got {getattr(self, name)!r}")


@dataclass
class SimVehicle:
    """One simulated vehicle and its connection.

    Attributes
    ----------
    index, sysid : int
        Its place in the fleet and its MAVLink system id.
    url : str
        Its bound connection string.
    conn : Any
        The pymavlink connection.
    faults : LinkFaults
        What its link injects.
    force : ndarray, shape (3,)
        The force it makes (N, N, N m).
    commanded : bool
        A MANUAL_CONTROL has arrived (it no longer holds its start).
    last_command_ns : int or None
        When the last one arrived (its clock, ns).
    commands : list of list of float
        ``[time, x, y, z, r]`` of every MANUAL_CONTROL received (s since its boot).
    failsafe : bool
        It went neutral for want of commands.
    intervals : dict of int to float
        Stream intervals by message id (s).
    next_due : dict of int to int
        When each stream is next due (ns).
    """

    index: int
    sysid: int
    url: str
    conn: Any
    faults: LinkFaults
    force: FloatArray = field(default_factory=lambda: np.zeros(3))
    commanded: bool = False
    last_command_ns: int | None = None
    commands: list[list[float]] = field(default_factory=list)
    failsafe: bool = False
    intervals: dict[int, float] = field(default_factory=dict)
    next_due: dict[int, int] = field(default_factory=dict)


class LoopbackFleet:
    """The loopback fleet (see the module docstring).

    Parameters
    ----------
    plant : VehicleParams
        The vehicles' model.
    starts : ndarray, shape (N, 6)
        Start states ``[x, y, psi, u, v, r]``, ``u, v`` relative to the water.
    listen : list of str
        One pymavlink connection string per vehicle: ``udpin:HOST:PORT`` (the vehicle listens;
        port 0 picks a free one) or ``udpout:HOST:PORT`` (it sends to a controller listening there).
    mapping : ArduSubMapping
        How the vehicles turn MANUAL_CONTROL into force.
    faults : list of LinkFaults
        One per vehicle.
    current : tuple of float
        Constant current (m/s, inertial).
    rate : float
        Navigation rate until a controller asks for another (Hz).
    odometry : bool
        Also send ODOMETRY.
    timesync : bool
        Answer TIMESYNC.
    mode : int
        The custom_mode reported (19, MANUAL).
    sysid : int
        System id of vehicle 0 (vehicle ``i`` has ``sysid + i``).
    seed : int
        Seed of the jitter and the losses.

    Raises
    ------
    ParameterError
        If the sizes disagree or a value is out of range.
    LinkError
        If a connection string cannot be opened.
    """

    def __init__(
        self,
        plant: VehicleParams,
        starts: FloatArray,
        listen: list[str],
        mapping: ArduSubMapping,
        faults: list[LinkFaults],
        *,
        current: tuple[float, float] = (0.0, 0.0),
        rate: float = DEFAULT_RATE,
        odometry: bool = False,
        timesync: bool = True,
        mode: int = MODE_MANUAL,
        sysid: int = 1,
        seed: int = 0,
    ) -> None:
        n = len(listen)
        s = np.asarray(starts, dtype=float)
        if n < 1 or s.shape != (n, 6) or len(faults) != n or not np.all(np.isfinite(s)):
            raise ParameterError(
                f"a loopback fleet needs one connection, start state (6) and fault set per vehicle; got {n} "
                f"connection(s), starts of shape {s.shape} and {len(faults)} fault set(s)"
            )
        if not (math.isfinite(rate) and rate > 0.0):
            raise ParameterError(f"the navigation rate must be > 0 Hz, got {rate!r}")
        self.plant, self.mapping, self.state = plant, mapping, s.copy()
        self.current = np.asarray(current, dtype=float)
        self.rate, self.odometry, self.timesync, self.mode = float(rate), bool(odometry), bool(timesync), int(mode)
        self.rng = random.Random(seed)
        self.boot_ns = time.monotonic_ns()
        self.sim_ns = self.boot_ns
        self.vehicles: list[SimVehicle] = []
        for i, url in enumerate(listen):
            try:
                conn = mavutil.mavlink_connection(
                    url, source_system=sysid + i, source_component=1, dialect="ardupilotmega"
                )
            except Exception as exc:  # pymavlink raises assorted OSError and ValueError types
                raise LinkError(f"loopback vehicle {i + 1}: cannot open {url!r}: {exc}") from None
            bound = url
            if url.startswith("udpin:"):
                host, port = conn.port.getsockname()[:2]
                bound = f"udpin:{host}:{port}"
            veh = SimVehicle(i, sysid + i, bound, conn, faults[i])
            for mid in (mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mavlink.MAVLINK_MSG_ID_ATTITUDE):
                veh.intervals[mid] = 1.0 / self.rate
            if self.odometry:
                veh.intervals[mavlink.MAVLINK_MSG_ID_ODOMETRY] = 1.0 / self.rate
            for mid in (
                mavlink.MAVLINK_MSG_ID_HEARTBEAT,
                mavlink.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT,
                mavlink.MAVLINK_MSG_ID_SYSTEM_TIME,
            ):
                veh.intervals[mid] = 1.0
            self.vehicles.append(veh)
        self.outgoing: list[tuple[int, int, int, bytes]] = []  # (due ns, sequence, vehicle, bytes)
        self.incoming: list[tuple[int, int, int, Any]] = []  # (due ns, sequence, vehicle, message)
        self._seq = 0
        self.stopped = False

    @property
    def endpoints(self) -> list[str]:
        """The bound connection strings, one per vehicle."""
        return [v.url for v in self.vehicles]

    # ---- helpers -------------------------------------------------------------------------------
    def _boot_ms(self, t_ns: int) -> int:
        return (t_ns - self.boot_ns) // 1_000_000

    def _delay_ns(self, v: SimVehicle) -> int:
        return int((v.faults.latency + self.rng.uniform(0.0, v.faults.jitter)) * 1e9)

    def _queue(self, v: SimVehicle, msg: Any, t_ns: int, lossy: bool) -> None:
        buf = msg.pack(v.conn.mav)
        v.conn.mav.seq = (v.conn.mav.seq + 1) % 256
        if lossy and self.rng.random() < v.faults.loss:
            return
        self._seq += 1
        heapq.heappush(self.outgoing, (t_ns + self._delay_ns(v), self._seq, v.index, buf))

    def _telemetry(self, v: SimVehicle, mid: int, t_ns: int) -> None:
        mav, s = v.conn.mav, self.state[v.index]
        psi = (s[2] + math.pi) % (2.0 * math.pi) - math.pi
        c, sn = math.cos(s[2]), math.sin(s[2])
        vn = c * s[3] - sn * s[4] + self.current[0]
        ve = sn * s[3] + c * s[4] + self.current[1]
        boot = self._boot_ms(t_ns)
        if mid == mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED:
            self._queue(v, mav.local_position_ned_encode(boot, s[0], s[1], 0.0, vn, ve, 0.0), t_ns, True)
        elif mid == mavlink.MAVLINK_MSG_ID_ATTITUDE:
            self._queue(v, mav.attitude_encode(boot, 0.0, 0.0, psi, 0.0, 0.0, s[5]), t_ns, True)
        elif mid == mavlink.MAVLINK_MSG_ID_ODOMETRY:
            q = [math.cos(psi / 2), 0.0, 0.0, math.sin(psi / 2)]
            ub, vb = c * vn + sn * ve, -sn * vn + c * ve
            cov = [math.nan] * 21
            msg = mav.odometry_encode(
                (t_ns - self.boot_ns) // 1000,
                mavlink.MAV_FRAME_LOCAL_NED,
                mavlink.MAV_FRAME_BODY_FRD,
                s[0],
                s[1],
                0.0,
                q,
                ub,
                vb,
                0.0,
                0.0,
                0.0,
                s[5],
                cov,
                cov,
            )
            self._queue(v, msg, t_ns, True)
        elif mid == mavlink.MAVLINK_MSG_ID_HEARTBEAT:
            armed = 0 if v.failsafe else mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | armed
            beat = mav.heartbeat_encode(
                mavlink.MAV_TYPE_SUBMARINE,
                mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                base,
                self.mode,
                mavlink.MAV_STATE_ACTIVE,
            )
            self._queue(v, beat, t_ns, False)
        elif mid == mavlink.MAVLINK_MSG_ID_SYSTEM_TIME:
            unix_us = (time.time_ns() + (t_ns - time.monotonic_ns())) // 1000
            self._queue(v, mav.system_time_encode(unix_us, boot), t_ns, False)
        elif mid == mavlink.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT:
            self._queue(v, mav.named_value_float_encode(boot, b"PilotGain", float(self.mapping.gain)), t_ns, False)

    def _handle(self, v: SimVehicle, msg: Any, t_ns: int) -> None:
        kind = msg.get_type()
        if kind == "MANUAL_CONTROL":
            if msg.get_srcSystem() != GCS_SYSTEM_ID or msg.target != v.sysid:
                return  # ArduSub: only from SYSID_MYGCS, only addressed to SYSID_THISMAV
            v.force = self.mapping.manual_control_to_forces(msg.x, msg.y, msg.r)
            v.commanded, v.failsafe, v.last_command_ns = True, False, t_ns
            v.commands.append([round((t_ns - self.boot_ns) * 1e-9, 6), msg.x, msg.y, msg.z, msg.r])
        elif kind == "TIMESYNC" and msg.tc1 == 0 and self.timesync:
            self._queue(v, v.conn.mav.timesync_encode(t_ns - self.boot_ns, msg.ts1), t_ns, False)
        elif kind == "COMMAND_LONG" and msg.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            mid, interval_us = int(msg.param1), float(msg.param2)
            if mid in v.intervals and interval_us > 0:
                v.intervals[mid] = interval_us * 1e-6
            ack = v.conn.mav.command_ack_encode(msg.command, mavlink.MAV_RESULT_ACCEPTED)
            self._queue(v, ack, t_ns, False)

    def _physics(self, t_ns: int) -> None:
        """Integrate up to ``t_ns`` in steps of :data:`SIM_STEP` (RK4), holding uncommanded vehicles."""
        step_ns = round(SIM_STEP * 1e9)
        while self.sim_ns + step_ns <= t_ns:
            for v in self.vehicles:
                late = v.last_command_ns is not None and (self.sim_ns - v.last_command_ns) * 1e-9 > PILOT_TIMEOUT
                if late and not v.failsafe:
                    v.failsafe, v.force = True, np.zeros(3)
            force = np.stack([v.force for v in self.vehicles])
            moving = np.array([v.commanded for v in self.vehicles])[:, None]
            s, h = self.state, SIM_STEP
            k1 = self._derivative(s, force, moving)
            k2 = self._derivative(s + 0.5 * h * k1, force, moving)
            k3 = self._derivative(s + 0.5 * h * k2, force, moving)
            k4 = self._derivative(s + h * k3, force, moving)
            self.state = s + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            self.sim_ns += step_ns

    def _derivative(self, x: FloatArray, force: FloatArray, moving: FloatArray) -> FloatArray:
        """``d/dt`` of the fleet's states under ``force``; zero for the vehicles still held on their start."""
        d = plant_derivative(self.plant, self.current, x, force, (np.cos(x[:, 2]), np.sin(x[:, 2])))
        out: FloatArray = np.where(moving, d, 0.0)
        return out

    # ---- the loop ------------------------------------------------------------------------------
    def run(self, duration: float | None = None) -> None:
        """Serve the vehicles until :attr:`stopped` is set (by a signal handler) or ``duration`` s pass.

        Parameters
        ----------
        duration : float, optional
            How long to run (s); forever when ``None``.
        """
        fds = {v.conn.port.fileno(): v for v in self.vehicles}
        end_ns = None if duration is None else self.boot_ns + int(duration * 1e9)
        for v in self.vehicles:
            for mid in v.intervals:
                v.next_due[mid] = self.boot_ns
        while not self.stopped:
            t = time.monotonic_ns()
            if end_ns is not None and t >= end_ns:
                break
            wake = self.sim_ns + round(SIM_STEP * 1e9)
            for v in self.vehicles:
                wake = min(wake, *v.next_due.values())
            for q in (self.outgoing, self.incoming):
                if q:
                    wake = min(wake, q[0][0])
            try:
                ready, _, _ = select.select(list(fds), [], [], min(max(0.0, (wake - t) * 1e-9), MAX_WAIT))
            except InterruptedError:
                ready = []
            t = time.monotonic_ns()
            for fd in ready:
                self._receive(fds[fd], t)
            while self.incoming and self.incoming[0][0] <= t:
                due, _, i, msg = heapq.heappop(self.incoming)
                self._physics(due)
                self._handle(self.vehicles[i], msg, due)
            self._physics(t)
            for v in self.vehicles:
                for mid, due in list(v.next_due.items()):
                    if due <= t:
                        self._telemetry(v, mid, t)
                        period = int(v.intervals[mid] * 1e9)
                        v.next_due[mid] = max(due + period, t - period)
            while self.outgoing and self.outgoing[0][0] <= t:
                _, _, i, buf = heapq.heappop(self.outgoing)
                self.vehicles[i].conn.write(buf)

    def _receive(self, v: SimVehicle, t: int) -> None:
        while True:
            try:
                msg = v.conn.recv_msg()
            except OSError:
                msg = None
            if msg is None:
                return
            if msg.get_type() == "BAD_DATA":
                continue
            if msg.get_type() == "MANUAL_CONTROL" and self.rng.random() < v.faults.command_loss:
                continue
            self._seq += 1
            heapq.heappush(self.incoming, (t + self._delay_ns(v), self._seq, v.index, msg))

    def close(self) -> None:
        """Close every connection."""
        for v in self.vehicles:
            try:
                v.conn.close()
            except OSError:
                pass

    def report(self) -> dict[str, Any]:
        """What happened: every command each vehicle received, its final state, its faults (JSON-safe)."""
        return {
            "vehicles": [
                {
                    "index": v.index,
                    "url": v.url,
                    "sysid": v.sysid,
                    "latency": v.faults.latency,
                    "jitter": v.faults.jitter,
                    "loss": v.faults.loss,
                    "command_loss": v.faults.command_loss,
                    "commands": v.commands,
                    "final_state": self.state[v.index].tolist(),
                    "failsafe": v.failsafe,
                }
                for v in self.vehicles
            ],
            "current": self.current.tolist(),
            "pid": os.getpid(),
        }


def loopback_starts(cfg: FormationConfig, current: tuple[float, float] = (0.0, 0.0)) -> FloatArray:
    """Where the loopback vehicles start: ``[simulation] initial``, else on their slots of the raw mission.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    current : tuple of float
        The current the fleet runs in (m/s, inertial): on the slots the body velocities are relative
        to the water, so that the ground-velocity error is zero.

    Returns
    -------
    ndarray, shape (N, 6)
        ``[x, y, psi, u, v, r]`` per vehicle.
    """
    if cfg.simulation.initial is not None:
        return np.asarray(cfg.simulation.initial, dtype=float)
    return slot_states(design_point(cfg).fleet(), current)


__all__ = [
    "DEFAULT_RATE",
    "MAX_WAIT",
    "PILOT_TIMEOUT",
    "SIM_STEP",
    "LinkFaults",
    "LoopbackFleet",
    "SimVehicle",
    "loopback_starts",
]
