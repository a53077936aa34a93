"""The run log: one Parquet row per step and vehicle, written while the loop runs, and read back.

:class:`RunLog` streams the rows of :data:`SCHEMA` to Parquet in row groups of
:data:`ROW_GROUP_STEPS` steps, written by a background thread so that a slow write (pyarrow's
first takes about 0.1 s) never delays a step. The file's metadata holds what replay needs
besides the rows: the format (:data:`LOG_FORMAT`), the assumptions, the monitor's actions, the
mapping and the connection strings. :func:`read_log` reads such a file, or a CSV log from a real
vehicle in the documented format (docs/deployment.md, :data:`CSV_REQUIRED`, :data:`CSV_OPTIONAL`).

Columns (units as in :mod:`auv_hinf.deployment.runtime`):

* ``step, time, period, vehicle``: the step, its time and the time since the previous step (s);
* ``x, y, psi, u, v, r``: the measured state; ``age`` (s) and ``age_source`` (how the age was
  known), ``measured_at = time - age`` (s), ``nav_gap, heartbeat_gap`` (s), ``rtt`` (s, the
  shortest TIMESYNC round trip), ``mode`` (custom_mode), ``gain`` ("PilotGain");
* ``ref_x, ref_y, ref_psi, ref_vx, ref_vy, ref_r``: the desired motion at ``measured_at``
  (``vx, vy`` inertial);
* ``law_tau_x, law_tau_y, law_tau_psi``: the certified law's command before saturation, checked
  against the limits; ``tau_x, tau_y, tau_psi``: the force encoded (the law's saturated, the hold
  law's, or zero); ``cmd_x, cmd_y, cmd_z, cmd_r``: the MANUAL_CONTROL sent;
  ``ach_tau_x, ach_tau_y, ach_tau_psi``: the force those sticks make; ``saturated``;
* ``law`` (``certified``, ``hold`` or ``neutral``), ``action`` (the step's action, or empty),
  ``current`` (the estimated current speed, m/s), ``violations`` (JSON list of this vehicle's
  ``{assumption, value, bound}``) and ``fleet_violations`` (the same for the fleet).
"""

from __future__ import annotations

import json
import queue
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from auv_hinf.exceptions import LogError

#: The format tag in a log's metadata.
LOG_FORMAT = "auv-hinf-run-log/1"
#: Steps per Parquet row group.
ROW_GROUP_STEPS = 50
#: State columns, in the order of ``[x, y, psi, u, v, r]``.
STATE_COLUMNS = ("x", "y", "psi", "u", "v", "r")
#: Desired-motion columns.
REFERENCE_COLUMNS = ("ref_x", "ref_y", "ref_psi", "ref_vx", "ref_vy", "ref_r")
#: The certified law's command (before saturation), the force encoded, and the force the sticks make.
LAW_COLUMNS = ("law_tau_x", "law_tau_y", "law_tau_psi")
FORCE_COLUMNS = ("tau_x", "tau_y", "tau_psi")
ACHIEVED_COLUMNS = ("ach_tau_x", "ach_tau_y", "ach_tau_psi")
#: MANUAL_CONTROL columns.
COMMAND_COLUMNS = ("cmd_x", "cmd_y", "cmd_z", "cmd_r")

_F64, _I32 = pa.float64(), pa.int32()
#: Every column of a run log with its type.
SCHEMA = pa.schema(
    [("step", pa.int64()), ("time", _F64), ("period", _F64), ("vehicle", _I32)]
    + [(k, _F64) for k in STATE_COLUMNS]
    + [
        ("age", _F64),
        ("age_source", pa.string()),
        ("measured_at", _F64),
        ("nav_gap", _F64),
        ("heartbeat_gap", _F64),
        ("rtt", _F64),
        ("mode", _I32),
        ("gain", _F64),
    ]
    + [(k, _F64) for k in (*REFERENCE_COLUMNS, *LAW_COLUMNS, *FORCE_COLUMNS)]
    + [(k, _I32) for k in COMMAND_COLUMNS]
    + [(k, _F64) for k in ACHIEVED_COLUMNS]
    + [
        ("saturated", pa.bool_()),
        ("law", pa.string()),
        ("action", pa.string()),
        ("current", _F64),
        ("violations", pa.string()),
        ("fleet_violations", pa.string()),
    ]
)
#: Columns a CSV log from a real vehicle must have.
CSV_REQUIRED = ("time", "vehicle", *STATE_COLUMNS)
#: Columns it may have (each checks what it measures; without it, the check is skipped and reported).
CSV_OPTIONAL = (
    "step",
    "period",
    "age",
    "measured_at",
    "nav_gap",
    "heartbeat_gap",
    "mode",
    "gain",
    *LAW_COLUMNS,
    *ACHIEVED_COLUMNS,
    "saturated",
)


class RunLog:
    """Streams step rows to Parquet (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The Parquet file (its folder must exist).
    metadata : dict of str to str
        Key-value metadata of the file (the format tag is added).

    Raises
    ------
    LogError
        If the folder does not exist or the file cannot be written.
    """

    def __init__(self, path: str | Path, metadata: dict[str, str]) -> None:
        self.path = Path(path)
        if not self.path.parent.is_dir():
            raise LogError(f"the log's folder {str(self.path.parent)!r} does not exist")
        self.schema = SCHEMA.with_metadata({**metadata, "format": LOG_FORMAT})
        try:
            self.writer = pq.ParquetWriter(str(self.path), self.schema)
        except OSError as exc:
            raise LogError(f"cannot write the log {str(self.path)!r}: {exc}") from None
        self.rows: dict[str, list[Any]] = {f.name: [] for f in SCHEMA}
        self.steps = 0
        self.queue: queue.Queue[dict[str, list[Any]] | None] = queue.Queue()
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._work, name="run-log", daemon=True)
        self.thread.start()

    def _work(self) -> None:
        while True:
            batch = self.queue.get()
            if batch is None:
                return
            try:
                self.writer.write_table(pa.table(batch, schema=self.schema))
            except (OSError, pa.ArrowException) as exc:  # reported by close(); the loop keeps running
                self.error = exc

    def add(self, row: dict[str, Any]) -> None:
        """Append one vehicle's row of the current step.

        Parameters
        ----------
        row : dict
            A value for every column of :data:`SCHEMA`.
        """
        for name, column in self.rows.items():
            column.append(row[name])

    def end_step(self) -> None:
        """Close the current step (a full row group goes to the writer thread)."""
        self.steps += 1
        if self.steps % ROW_GROUP_STEPS == 0:
            self._flush()

    def _flush(self) -> None:
        if self.rows["step"]:
            self.queue.put(self.rows)
            self.rows = {f.name: [] for f in SCHEMA}

    def close(self) -> None:
        """Write what is left and close the file.

        Raises
        ------
        LogError
            If a write failed.
        """
        self._flush()
        self.queue.put(None)
        self.thread.join()
        self.writer.close()
        if self.error is not None:
            raise LogError(f"writing the log {str(self.path)!r} failed: {self.error}")


@dataclass(frozen=True)
class LogData:
    """A log read back.

    Attributes
    ----------
    frame : pandas.DataFrame
        One row per step and vehicle, sorted by step (or time) and vehicle.
    metadata : dict of str to str
        The Parquet metadata (empty for a CSV log).
    path : Path
        The file.
    """

    frame: pd.DataFrame
    metadata: dict[str, str]
    path: Path

    @property
    def is_run_log(self) -> bool:
        """Written by ``auv-hinf run`` (it carries the run's own verdicts)."""
        return self.metadata.get("format") == LOG_FORMAT

    def meta_json(self, key: str) -> Any:
        """A JSON value of the metadata (``None`` when absent).

        Parameters
        ----------
        key : str
            The metadata key.

        Returns
        -------
        Any
            The parsed value.
        """
        text = self.metadata.get(key)
        return None if text is None else json.loads(text)


def read_log(path: str | Path) -> LogData:
    """Read a run log (Parquet) or a CSV log in the documented format.

    Parameters
    ----------
    path : str or Path
        A ``.parquet`` file written by ``auv-hinf run``, or a ``.csv`` file.

    Returns
    -------
    LogData
        The rows and the metadata.

    Raises
    ------
    LogError
        If the file is missing, unreadable, lacks a required column, or its vehicles are not
        ``0 .. N-1`` with one row each per step.
    """
    p = Path(path)
    if not p.is_file():
        raise LogError(f"no log file {str(p)!r}")
    metadata: dict[str, str] = {}
    if p.suffix == ".parquet":
        try:
            table = pq.read_table(str(p))
        except (OSError, pa.ArrowException) as exc:
            raise LogError(f"{str(p)!r} is not a readable Parquet file: {exc}") from None
        metadata = {k.decode(): v.decode() for k, v in (table.schema.metadata or {}).items()}
        frame = table.to_pandas()
    else:
        try:
            frame = pd.read_csv(p)
        except (OSError, ValueError) as exc:
            raise LogError(f"{str(p)!r} is not a readable CSV file: {exc}") from None
    missing = [c for c in CSV_REQUIRED if c not in frame.columns]
    if missing:
        raise LogError(f"{str(p)!r} lacks the column(s) {', '.join(missing)}; a log needs {', '.join(CSV_REQUIRED)}")
    if frame.empty:
        raise LogError(f"{str(p)!r} has no rows: there is nothing to replay")
    for column in CSV_REQUIRED:
        values = pd.to_numeric(frame[column], errors="coerce")
        if values.isna().any():
            row = int(np.flatnonzero(values.isna().to_numpy())[0])
            raise LogError(
                f"{str(p)!r}: column {column!r} must hold numbers, got {str(frame[column].iloc[row])!r} (row {row})"
            )
        frame[column] = values
    if not np.all(np.isfinite(frame["time"].to_numpy(dtype=float))):
        raise LogError(f"{str(p)!r}: column 'time' must be finite")
    ids = frame["vehicle"].to_numpy(dtype=float)
    if not np.all(ids == np.round(ids)):
        raise LogError(f"{str(p)!r}: column 'vehicle' must hold whole numbers 0 .. N-1")
    if "step" not in frame.columns:
        frame = frame.assign(step=frame["time"].rank(method="dense").astype(int) - 1)
    frame = frame.sort_values(["step", "vehicle"], kind="stable").reset_index(drop=True)
    vehicles = sorted(int(v) for v in frame["vehicle"].unique())
    if vehicles != list(range(len(vehicles))):
        raise LogError(f"{str(p)!r}: vehicle indices must be 0 .. N-1, got {vehicles}")
    counts = frame.groupby("step")["vehicle"].count()
    if not (counts == len(vehicles)).all():
        bad = int(counts[counts != len(vehicles)].index[0])
        raise LogError(f"{str(p)!r}: step {bad} does not have one row per vehicle ({len(vehicles)})")
    return LogData(frame, metadata, p)


__all__ = [
    "ACHIEVED_COLUMNS",
    "COMMAND_COLUMNS",
    "CSV_OPTIONAL",
    "CSV_REQUIRED",
    "FORCE_COLUMNS",
    "LAW_COLUMNS",
    "LOG_FORMAT",
    "REFERENCE_COLUMNS",
    "ROW_GROUP_STEPS",
    "SCHEMA",
    "STATE_COLUMNS",
    "LogData",
    "RunLog",
    "read_log",
]
