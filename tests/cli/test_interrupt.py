"""Ctrl-C (SIGINT): one line, exit 130, no traceback, and the work that finished kept on disk."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

from auv_hinf.campaign import runner
from auv_hinf.cli.args import EXIT_INTERRUPTED
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.exceptions import Interrupted
from auv_hinf.simulation import stream

#: The line of an interrupted command (the last one on stderr).
LINE = re.compile(r"^auv-hinf: interrupted after (\d+) of (\d+) runs; (.*)$")
#: Seconds the subprocess test waits for anything; the whole test ends well within a few of these.
TIMEOUT = 90.0


def _last_line(err: str) -> str:
    return err.replace("\r", "\n").strip().splitlines()[-1]


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow
def test_sigint_to_a_real_campaign_keeps_the_finished_runs(tmp_path: Path) -> None:
    runs, out = 400, tmp_path / "campaign"
    cmd = [sys.executable, "-m", "auv_hinf.cli.main", "campaign", "--preset", "paper-triangle", "--runs", str(runs)]
    chunk = 2
    cmd += ["--chunk", str(chunk), "--horizon", "20", "--out", str(out)]  # serial, one chunk of 2 runs every ~0.2 s
    # Ctrl-C as a terminal delivers it: the child's SIGINT at its default, even when this test runs in a
    # job that ignores it (a shell's background job inherits SIGINT ignored, and Python then installs no
    # KeyboardInterrupt handler at all)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=_default_sigint)
    chunks: list[bytes] = []  # raw: a read may split the bar's multi-byte characters
    assert proc.stderr is not None
    reader = threading.Thread(target=lambda: chunks.extend(iter(lambda: proc.stderr.read1(4096), b"")))
    reader.start()
    try:
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:  # wait for the progress bar to pass 6 runs, then press Ctrl-C
            counts = [int(k) for k in re.findall(rf"(\d+)/{runs} ".encode(), b"".join(chunks))]
            if (counts and counts[-1] >= 6) or proc.poll() is not None:
                break
            time.sleep(0.05)
        assert proc.poll() is None, b"".join(chunks).decode(errors="replace")
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=TIMEOUT)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        reader.join(timeout=TIMEOUT)
        assert proc.stdout is not None
        proc.stdout.close()
        proc.stderr.close()
    text = b"".join(chunks).decode(errors="replace")
    assert code == EXIT_INTERRUPTED and "Traceback" not in text, text
    match = LINE.match(_last_line(text))
    assert match is not None, text
    done = int(match.group(1))
    # the bar moves as a chunk's runs integrate, before the chunk is measured and kept: at the signal
    # every chunk before the one in flight has finished
    assert int(match.group(2)) == runs and 6 - chunk <= done < runs and match.group(3) == f"results so far in {out}"
    table = pd.read_parquet(out / "runs.parquet")
    assert list(table["run"]) == list(range(done))  # serial: the first K runs, each once
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == summary["counts"]["runs"] == done
    assert summary["runs_requested"] == runs and summary["interrupted"] is True
    assert (out / "excursions.png").exists()


def _interrupt_after(calls: int, real):
    """``real``, raising KeyboardInterrupt (as SIGINT does) at its call number ``calls`` (0-based)."""
    count = [0]

    def fake(*args, **kwargs):
        count[0] += 1
        if count[0] > calls:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    return fake


@pytest.mark.slow
def test_an_interrupted_campaign_is_the_chunks_that_finished(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(runner, "run_chunk", _interrupt_after(2, runner.run_chunk))
    with pytest.raises(Interrupted) as info:
        runner.run_campaign(preset_config("paper-triangle"), 9, seed=3, chunk=2, horizon=5.0)
    camp = info.value.partial
    assert isinstance(camp, runner.Campaign) and info.value.done == 4 and info.value.total == 9
    assert list(camp.table["run"]) == [0, 1, 2, 3] and camp.requested == 9 and camp.interrupted
    monkeypatch.setattr(runner, "run_chunk", _interrupt_after(0, runner.run_chunk))
    with pytest.raises(Interrupted) as info:
        runner.run_campaign(preset_config("paper-triangle"), 9, seed=3, chunk=2, horizon=5.0)
    assert info.value.partial is None and info.value.done == 0


@pytest.mark.slow
def test_simulate_interrupted_while_saving_keeps_the_run_and_the_rows_so_far(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real = stream.integrate_batch

    def stopped_midway(batch, sink):  # the sink sees the first samples, then Ctrl-C
        def partial(idx, systems, values):
            if idx.min() > 10:
                raise KeyboardInterrupt
            sink(idx, systems, values)

        real(batch, sink=partial)

    monkeypatch.setattr(stream, "integrate_batch", stopped_midway)
    save, out = tmp_path / "run.parquet", tmp_path / "out"
    argv = ["simulate", "--preset", "paper-triangle", "--horizon", "5", "--save", str(save), "--out", str(out)]
    code = main(argv)
    err = capsys.readouterr().err
    assert code == EXIT_INTERRUPTED and len(err.splitlines()) == 1, err
    match = LINE.match(err.strip())
    assert match is not None and match.group(1, 2) == ("1", "1"), err
    assert match.group(3).startswith(f"results so far in {out} and {save} (the run finished") and "of 5 s)" in err
    rows = pq.read_table(save).to_pandas()  # a valid file: the writer was closed
    t_last = rows["time"].max()
    assert 0.0 < t_last < 5.0 and len(rows) == 3 * rows["time"].nunique() and rows["time"].min() == 0.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["saved_until"] == pytest.approx(t_last) and (out / "trajectories.png").exists()


@pytest.mark.slow
def test_ctrl_c_before_any_run_is_one_line_and_exit_130(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from auv_hinf.simulation import engine

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(engine, "simulate", interrupted)
    assert main(["simulate", "--preset", "paper-triangle", "--horizon", "1"]) == EXIT_INTERRUPTED
    err = capsys.readouterr().err
    assert err == "auv-hinf: interrupted after 0 of 1 runs; no run finished, nothing written\n"
    monkeypatch.setattr("auv_hinf.config.presets.preset_config", interrupted)  # during the set-up
    assert main(["certify", "--preset", "paper-triangle"]) == EXIT_INTERRUPTED
    assert capsys.readouterr().err == "auv-hinf: interrupted\n"
