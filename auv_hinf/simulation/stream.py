"""Full trajectories of a run streamed to a Parquet file, in O(N) memory at any fleet size.

:func:`save_trajectories` integrates the scenario again with a sink
(:data:`~auv_hinf.numerics.integrators.SampleSink`): each batch of output samples becomes
one Parquet row group of ``samples x N`` rows and is released, so the memory does not grow
with the number of samples. The run itself keeps only the samples its report and plots need
(:func:`~auv_hinf.certificate.run_plan.run_samples`); this file has every vehicle at every sample.

Columns: ``t`` (s), ``vehicle`` (0 .. N-1), ``x``, ``y`` (m, inertial), ``psi`` (rad), ``u``,
``v`` (m/s, body frame, relative to the water), ``r`` (rad/s), and with integral action the
integrator ``z_x``, ``z_y`` (m s).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import Interrupted, ParameterError
from auv_hinf.implementation.sampled_loop import integrate_sampled
from auv_hinf.simulation.engine import integrate_batch
from auv_hinf.simulation.scenario import Scenario, ScenarioBatch

#: Interval of the saved samples (s): the paper's figures are read at 0.1 s.
SAVE_INTERVAL = 0.1
#: Rows per Parquet row group (about 8 MB at 8 columns): the memory the stream holds at once.
ROW_GROUP_ROWS = 2**17
#: Column names of the plant state, in the order of a vehicle's state.
STATE_COLUMNS = ("x", "y", "psi", "u", "v", "r")
#: Column names of the integrator state of integral action (m s).
INTEGRATOR_COLUMNS = ("z_x", "z_y")


def parquet_path(path: str | Path) -> Path:
    """``path`` as the Parquet file :func:`save_trajectories` writes.

    Parameters
    ----------
    path : str or Path
        The file name; must end in ``.parquet``.

    Raises
    ------
    ParameterError
        If the file name does not end in ``.parquet``.
    """
    out = Path(path)
    if out.suffix != ".parquet":
        raise ParameterError(f"--save writes Parquet: give a file name ending in .parquet, got {str(out)!r}")
    return out


def save_trajectories(scn: Scenario, path: str | Path, interval: float = SAVE_INTERVAL) -> Path:
    """Integrate ``scn`` again and stream every vehicle's state every ``interval`` s to ``path``.

    The columns are ``time`` (s), ``vehicle`` and the state ``x, y, psi, u, v, r`` (m, rad, m/s,
    rad/s; with integral action the integrator's too): the log format ``auv-hinf replay`` reads.

    Parameters
    ----------
    scn : Scenario
        The run (its law, plant, current, start, implementation and seed: the same run).
    path : str or Path
        A ``.parquet`` file to write (overwritten).
    interval : float
        Sample interval (s), > 0; the last sample is at the horizon.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ParameterError
        If the file name does not end in ``.parquet`` or ``interval`` is not positive.
    Interrupted
        On Ctrl-C: the file is closed, valid, with the samples integrated so far; ``partial`` is
        the time of the last one (s), ``None`` when none was written.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = parquet_path(path)
    if not (np.isfinite(interval) and interval > 0.0):
        raise ParameterError(f"the save interval must be > 0 s, got {interval!r}")
    samples = max(2, round(scn.horizon / interval) + 1)
    run = replace(scn, samples=samples)
    times, n, width = run.times, run.n, run.law.width
    names = STATE_COLUMNS + (INTEGRATOR_COLUMNS if width > 6 else ())
    schema = pa.schema([("time", pa.float64()), ("vehicle", pa.int32())] + [(c, pa.float64()) for c in names])
    vehicle = np.arange(n, dtype=np.int32)
    pending: list[tuple[NDArray[np.int_], FloatArray]] = []  # samples not yet written
    written = [0, -1]  # samples written, index of the last one
    with pq.ParquetWriter(out, schema) as writer:

        def flush() -> None:
            if not pending:
                return
            idx = np.concatenate([i for i, _ in pending])
            states = np.concatenate([v for _, v in pending]).reshape(idx.size, n, -1)
            pending.clear()
            cols = {"time": np.repeat(times[idx], n), "vehicle": np.tile(vehicle, idx.size)}
            cols |= {c: states[:, :, k].ravel() for k, c in enumerate(names)}
            writer.write_table(pa.table(cols, schema=schema))
            written[0], written[1] = written[0] + idx.size, max(written[1], int(idx.max()))

        def sink(idx: NDArray[np.int_], systems: NDArray[np.int_], values: FloatArray) -> None:
            pending.append((idx.copy(), values.copy()))  # one scenario: every row is one sample of it
            if sum(i.size for i, _ in pending) * n >= ROW_GROUP_ROWS:
                flush()

        batch = ScenarioBatch((run,))
        try:
            if run.implementation.continuous:
                integrate_batch(batch, sink=sink)
            else:
                integrate_sampled(batch, sink=sink)
        except KeyboardInterrupt:  # keep what was integrated: the file closes valid, with every sample so far
            flush()
            last = float(times[written[1]]) if written[1] >= 0 else None
            raise Interrupted(written[0], samples, last) from None
        flush()
    return out


__all__ = [
    "INTEGRATOR_COLUMNS",
    "ROW_GROUP_ROWS",
    "SAVE_INTERVAL",
    "STATE_COLUMNS",
    "parquet_path",
    "save_trajectories",
]
