"""One MAVLink connection per vehicle: navigation in, MANUAL_CONTROL out, heartbeats and the vehicle's clock.

A :class:`VehicleLink` wraps a pymavlink connection string (``udpin:127.0.0.1:14550`` listens for a
vehicle that sends to us, ``udpout:192.168.2.2:14550`` sends to a vehicle that listens, ``tcp:...``,
a serial device). It

* decodes LOCAL_POSITION_NED (north and east position, NED velocity over ground) and ATTITUDE
  (heading, yaw rate) or, when the vehicle sends it, ODOMETRY, into the state
  ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s; ``u, v`` the body-frame velocity over
  ground), with the time each part was measured on the vehicle's clock;
* estimates that clock's offset from ours, and from it the age ``now - (stamp - offset)`` of a
  measurement, from the best source it has (logged as ``age_source``):

  - ``"timesync"``: TIMESYNC round trips (ArduPilot answers them), exact on a symmetric link and
    off by at most half the round trip otherwise (the shortest round trip is logged as ``rtt``);
  - ``"system_time"``: SYSTEM_TIME (the vehicle's boot time and UNIX time at one instant), exact
    when the two UNIX clocks agree (same host, or NTP);
  - ``"relative"``: the largest ``stamp - reception`` seen, a lower bound of the age that catches
    latency added during the run but not a latency present from the start;
* sends MANUAL_CONTROL from system 255 (ArduSub's SYSID_MYGCS) through an
  :class:`~auv_hinf.deployment.ardusub.ArduSubMapping`, a GCS HEARTBEAT (ArduSub's GCS failsafe
  waits 2.5 s for one), and asks for the navigation streams with MAV_CMD_SET_MESSAGE_INTERVAL;
* reads the HEARTBEAT's custom_mode and NAMED_VALUE_FLOAT "PilotGain" for the monitor.

The link never arms a vehicle or changes its mode. Importing this module selects MAVLink 2 and
the ArduPilot dialect in pymavlink.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pymavlink import mavutil

from auv_hinf._typing import FloatArray
from auv_hinf.deployment.ardusub import NEUTRAL, ArduSubMapping, ManualCommand
from auv_hinf.exceptions import LinkError

#: MAVLink 2 (MANUAL_CONTROL extensions, ODOMETRY): pymavlink reads ``MAVLINK20`` when a dialect is set,
#: so it is set here, and the dialect again, whatever imported pymavlink before.
os.environ.setdefault("MAVLINK20", "1")
mavutil.set_dialect("ardupilotmega")
#: The ArduPilot dialect's message classes and constants.
mavlink: Any = mavutil.mavlink

#: ArduSub's SYSID_MYGCS default: MANUAL_CONTROL is accepted only from this system id.
GCS_SYSTEM_ID = 255
#: MAV_COMP_ID_MISSIONPLANNER, the component id ground stations use.
GCS_COMPONENT_ID = 190
#: Navigation rate asked of every vehicle (Hz): ArduSub's largest stream rate (SRn_* up to 50 Hz).
#: At 50 Hz the newest message is at most 20 ms old at a step, inside a 50 ms delay budget.
TELEMETRY_RATE = 50.0
#: TIMESYNC round trips kept for the clock offset (the shortest is used).
TIMESYNC_WINDOW = 8
#: Pending TIMESYNC requests kept at most (older ones are dropped unanswered).
TIMESYNC_PENDING = 32


def now_ns() -> int:
    """The loop's clock: ``time.monotonic_ns()`` (ns)."""
    return time.monotonic_ns()


@dataclass(frozen=True)
class Stamped:
    """One decoded message.

    Attributes
    ----------
    values : tuple of float
        What it carries (its units in :meth:`VehicleLink.state`).
    stamp_ns : int
        When it was measured, on the vehicle's clock (ns since its boot).
    recv_ns : int
        When it arrived, on the loop's clock (ns).
    """

    values: tuple[float, ...]
    stamp_ns: int
    recv_ns: int


@dataclass
class ClockSync:
    """The vehicle clock's offset (``vehicle_ns - local_ns``) from TIMESYNC round trips.

    Attributes
    ----------
    samples : list of (int, int)
        ``(round trip, offset)`` of the latest round trips (ns).
    """

    samples: list[tuple[int, int]] = field(default_factory=list)

    def add(self, t0_ns: int, t3_ns: int, tc_ns: int) -> None:
        """Record a round trip sent at ``t0_ns``, answered with ``tc_ns`` and received at ``t3_ns``.

        Parameters
        ----------
        t0_ns, t3_ns : int
            Send and receive times on the loop's clock (ns).
        tc_ns : int
            The vehicle's clock when it answered (ns).
        """
        rtt = t3_ns - t0_ns
        if rtt >= 0:
            self.samples.append((rtt, tc_ns - (t0_ns + t3_ns) // 2))
            del self.samples[:-TIMESYNC_WINDOW]

    @property
    def ready(self) -> bool:
        """At least one round trip came back."""
        return bool(self.samples)

    @property
    def best(self) -> tuple[int, int]:
        """``(round trip, offset)`` of the shortest round trip kept (ns)."""
        return min(self.samples)


class VehicleLink:
    """MAVLink connection to one vehicle (see the module docstring).

    Parameters
    ----------
    url : str
        The pymavlink connection string.
    index : int
        The vehicle's index in the fleet (0-based), for messages.
    mapping : ArduSubMapping
        Force to MANUAL_CONTROL mapping.
    target_system : int or None
        The vehicle's system id (SYSID_THISMAV); ``None`` learns it from its first HEARTBEAT.
    telemetry_rate : float
        Rate asked for LOCAL_POSITION_NED, ATTITUDE and ODOMETRY (Hz).
    record : bool
        Keep the bytes of every MANUAL_CONTROL sent (:attr:`sent`).

    Raises
    ------
    LinkError
        If the connection string cannot be opened.
    """

    def __init__(
        self,
        url: str,
        index: int,
        mapping: ArduSubMapping,
        target_system: int | None = None,
        telemetry_rate: float = TELEMETRY_RATE,
        record: bool = False,
    ) -> None:
        self.url, self.index, self.mapping = url, int(index), mapping
        self.target_system = target_system
        self.telemetry_rate = float(telemetry_rate)
        self.record = record
        self.sent: list[bytes] = []
        try:
            self.conn: Any = mavutil.mavlink_connection(
                url,
                source_system=GCS_SYSTEM_ID,
                source_component=GCS_COMPONENT_ID,
                dialect="ardupilotmega",
                autoreconnect=False,
            )
        except Exception as exc:  # pymavlink raises assorted OSError and ValueError types
            raise LinkError(f"vehicle {index + 1}: cannot open {url!r}: {exc}") from None
        self.clock = ClockSync()
        self._pending: dict[int, int] = {}
        self.local_position: Stamped | None = None
        self.attitude: Stamped | None = None
        self.odometry: Stamped | None = None
        self.heartbeat_ns: int | None = None
        self.custom_mode = -1
        self.armed = False
        self.pilot_gain = math.nan
        self.nav_recv_ns: int | None = None
        self.messages = 0
        self.system_time_offset: int | None = None
        self.relative_offset: int | None = None

    # ---- plumbing ------------------------------------------------------------------------------
    def fileno(self) -> int:
        """The socket (or file) descriptor, for ``select``."""
        port = getattr(self.conn, "port", None)
        if port is not None and hasattr(port, "fileno"):
            return int(port.fileno())
        return int(self.conn.fd)

    def close(self) -> None:
        """Close the connection (a half-open one may refuse; nothing is left to do then)."""
        try:
            self.conn.close()
        except OSError:
            pass

    @property
    def target(self) -> int:
        """The vehicle's system id (1 until its HEARTBEAT says otherwise)."""
        return 1 if self.target_system is None else int(self.target_system)

    # ---- receive -------------------------------------------------------------------------------
    def poll(self) -> int:
        """Read every waiting message without blocking.

        Returns
        -------
        int
            How many were read.
        """
        count = 0
        while True:
            try:
                msg = self.conn.recv_msg()
            except (OSError, ConnectionError):
                break
            if msg is None:
                break
            count += 1
            self.handle(msg, now_ns())
        self.messages += count
        return count

    def handle(self, msg: Any, t_ns: int) -> None:
        """Take one decoded message received at ``t_ns`` (the loop's clock, ns).

        Parameters
        ----------
        msg : pymavlink message
            The message.
        t_ns : int
            When it arrived (ns).
        """
        kind = msg.get_type()
        if kind == "BAD_DATA":
            return
        if kind == "HEARTBEAT":
            if msg.type == mavlink.MAV_TYPE_GCS or msg.autopilot == mavlink.MAV_AUTOPILOT_INVALID:
                return
            if self.target_system is None:
                self.target_system = int(msg.get_srcSystem())
                self.request_streams()
            if msg.get_srcSystem() == self.target:
                self.heartbeat_ns = t_ns
                self.custom_mode = int(msg.custom_mode)
                self.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            return
        if self.target_system is not None and msg.get_srcSystem() != self.target_system:
            return
        if kind == "LOCAL_POSITION_NED":
            self.local_position = Stamped((msg.x, msg.y, msg.vx, msg.vy), int(msg.time_boot_ms) * 1_000_000, t_ns)
            self._navigation(self.local_position)
        elif kind == "ATTITUDE":
            self.attitude = Stamped((msg.yaw, msg.yawspeed), int(msg.time_boot_ms) * 1_000_000, t_ns)
            self._navigation(self.attitude)
        elif kind == "ODOMETRY":
            self.odometry = Stamped(_odometry_state(msg), int(msg.time_usec) * 1000, t_ns)
            self._navigation(self.odometry)
        elif kind == "SYSTEM_TIME" and msg.time_unix_usec > 0:
            mono_minus_unix = time.monotonic_ns() - time.time_ns()
            unix_ns = int(msg.time_unix_usec) * 1000
            self.system_time_offset = int(msg.time_boot_ms) * 1_000_000 - (unix_ns + mono_minus_unix)
        elif kind == "TIMESYNC" and msg.tc1 != 0 and msg.ts1 in self._pending:
            self.clock.add(self._pending.pop(msg.ts1), t_ns, int(msg.tc1))
        elif kind == "NAMED_VALUE_FLOAT":
            name = msg.name if isinstance(msg.name, str) else msg.name.decode(errors="replace")
            if name.rstrip("\x00") == "PilotGain":
                self.pilot_gain = float(msg.value)

    def _navigation(self, item: Stamped) -> None:
        self.nav_recv_ns = item.recv_ns
        lb = item.stamp_ns - item.recv_ns
        self.relative_offset = lb if self.relative_offset is None else max(self.relative_offset, lb)

    # ---- state ---------------------------------------------------------------------------------
    def _age(self, item: Stamped, t_ns: int) -> tuple[float, str]:
        if self.clock.ready:
            offset, source = self.clock.best[1], "timesync"
        elif self.system_time_offset is not None:
            offset, source = self.system_time_offset, "system_time"
        elif self.relative_offset is not None:
            offset, source = self.relative_offset, "relative"
        else:
            return (t_ns - item.recv_ns) * 1e-9, "receive"
        return (t_ns - (item.stamp_ns - offset)) * 1e-9, source

    @property
    def has_navigation(self) -> bool:
        """A position and a heading have arrived."""
        return self.odometry is not None or (self.local_position is not None and self.attitude is not None)

    def state(self, t_ns: int) -> tuple[FloatArray, float, str]:
        """The newest state, its age at ``t_ns`` and where the age comes from.

        ODOMETRY is used when it is newer than LOCAL_POSITION_NED, else LOCAL_POSITION_NED with
        ATTITUDE, whose age is the older one's.

        Parameters
        ----------
        t_ns : int
            The loop's clock (ns).

        Returns
        -------
        tuple
            ``[x, y, psi, u, v, r]`` (NaN before any navigation), the age (s, NaN before any)
            and its source (``"timesync"``, ``"system_time"``, ``"relative"``, ``"receive"`` or ``"none"``).
        """
        odo, lp, att = self.odometry, self.local_position, self.attitude
        if odo is not None and (lp is None or odo.recv_ns >= lp.recv_ns):
            age, source = self._age(odo, t_ns)
            return np.asarray(odo.values, dtype=float), age, source
        if lp is None or att is None:
            return np.full(6, np.nan), math.nan, "none"
        x, y, vx, vy = lp.values
        psi, r = att.values
        c, s = math.cos(psi), math.sin(psi)
        state = np.array([x, y, psi, c * vx + s * vy, -s * vx + c * vy, r])
        a1, source = self._age(lp, t_ns)
        a2, _ = self._age(att, t_ns)
        return state, max(a1, a2), source

    def gaps(self, t_ns: int) -> tuple[float, float]:
        """Time since the newest navigation message and since the newest HEARTBEAT (s; inf if never).

        Parameters
        ----------
        t_ns : int
            The loop's clock (ns).

        Returns
        -------
        tuple of float
            ``(navigation gap, heartbeat gap)``.
        """
        nav = math.inf if self.nav_recv_ns is None else (t_ns - self.nav_recv_ns) * 1e-9
        beat = math.inf if self.heartbeat_ns is None else (t_ns - self.heartbeat_ns) * 1e-9
        return nav, beat

    @property
    def rtt(self) -> float:
        """Shortest recent TIMESYNC round trip (s; NaN before the first)."""
        return self.clock.best[0] * 1e-9 if self.clock.ready else math.nan

    # ---- send ----------------------------------------------------------------------------------
    def _send(self, msg: Any) -> None:
        try:
            self.conn.mav.send(msg)
        except OSError as exc:
            raise LinkError(f"vehicle {self.index + 1} ({self.url}): send failed: {exc}") from None

    def send_heartbeat(self) -> None:
        """A GCS HEARTBEAT (type GCS, autopilot INVALID, active)."""
        self._send(
            self.conn.mav.heartbeat_encode(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE
            )
        )

    def send_timesync(self) -> None:
        """A TIMESYNC request (``tc1 = 0``, ``ts1`` the loop's clock in ns)."""
        ts1 = now_ns()
        self._pending[ts1] = ts1
        for old in sorted(self._pending)[:-TIMESYNC_PENDING]:
            del self._pending[old]
        self._send(self.conn.mav.timesync_encode(0, ts1))

    def request_streams(self) -> None:
        """MAV_CMD_SET_MESSAGE_INTERVAL: navigation at :attr:`telemetry_rate`, SYSTEM_TIME at 1 Hz.

        Also the older REQUEST_DATA_STREAM of the POSITION and EXTRA1 streams (ArduSub's
        ``SRn_POSITION`` and ``SRn_EXTRA1``, which carry LOCAL_POSITION_NED and ATTITUDE), for
        firmware and emulators that only know that one.
        """
        hz = max(1, round(self.telemetry_rate))
        for stream in (mavlink.MAV_DATA_STREAM_POSITION, mavlink.MAV_DATA_STREAM_EXTRA1):
            self._send(self.conn.mav.request_data_stream_encode(self.target, 1, stream, hz, 1))
        interval_us = 1e6 / self.telemetry_rate
        for msg_id, us in (
            (mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, interval_us),
            (mavlink.MAVLINK_MSG_ID_ATTITUDE, interval_us),
            (mavlink.MAVLINK_MSG_ID_ODOMETRY, interval_us),
            (mavlink.MAVLINK_MSG_ID_SYSTEM_TIME, 1e6),
        ):
            self._send(
                self.conn.mav.command_long_encode(
                    self.target, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, us, 0, 0, 0, 0, 0
                )
            )

    def send_command(self, cmd: ManualCommand) -> None:
        """MANUAL_CONTROL with the command's sticks and no buttons, to the vehicle's system id.

        Parameters
        ----------
        cmd : ManualCommand
            The sticks.
        """
        msg = self.conn.mav.manual_control_encode(self.target, cmd.x, cmd.y, cmd.z, cmd.r, 0)
        self._send(msg)
        if self.record:
            self.sent.append(bytes(msg.get_msgbuf()))

    def send_neutral(self) -> None:
        """The neutral MANUAL_CONTROL (x = y = r = 0, z = 500)."""
        self.send_command(NEUTRAL)


def _odometry_state(msg: Any) -> tuple[float, ...]:
    """``[x, y, psi, u, v, r]`` of an ODOMETRY message (velocity in the body or the local frame)."""
    q0, q1, q2, q3 = msg.q
    yaw = math.atan2(2.0 * (q0 * q3 + q1 * q2), 1.0 - 2.0 * (q2 * q2 + q3 * q3))
    if msg.child_frame_id in (mavlink.MAV_FRAME_BODY_FRD, mavlink.MAV_FRAME_BODY_NED):
        u, v = msg.vx, msg.vy
    else:  # the velocity is in the local (NED) frame
        c, s = math.cos(yaw), math.sin(yaw)
        u, v = c * msg.vx + s * msg.vy, -s * msg.vx + c * msg.vy
    return (float(msg.x), float(msg.y), yaw, float(u), float(v), float(msg.yawspeed))


__all__ = [
    "GCS_COMPONENT_ID",
    "GCS_SYSTEM_ID",
    "TELEMETRY_RATE",
    "TIMESYNC_PENDING",
    "TIMESYNC_WINDOW",
    "ClockSync",
    "Stamped",
    "VehicleLink",
    "mavlink",
    "now_ns",
]
