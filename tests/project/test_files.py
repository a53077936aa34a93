"""Outputs are written whole or not at all: an interrupted write leaves no truncated file."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.files import write_text, written


def test_a_write_that_completes_lands_under_its_name_and_leaves_nothing_else(tmp_path):
    write_text(tmp_path / "summary.json", "{}")
    with written(tmp_path / "trajectory.npz") as tmp:
        assert tmp.suffix == ".npz" and tmp.parent == tmp_path and tmp.name.startswith(".")
        np.savez_compressed(tmp, t=np.arange(3.0))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary.json", "trajectory.npz"]
    assert np.load(tmp_path / "trajectory.npz")["t"].tolist() == [0.0, 1.0, 2.0]


@pytest.mark.parametrize("stop", [KeyboardInterrupt, OSError])
def test_an_interrupted_write_keeps_the_earlier_file_and_removes_the_partial_one(tmp_path, stop):
    path = tmp_path / "trajectory.npz"
    np.savez_compressed(path, t=np.zeros(2))
    with pytest.raises(stop), written(path) as tmp:
        tmp.write_bytes(b"PK\x03\x04 half a file")
        raise stop
    assert [p.name for p in tmp_path.iterdir()] == ["trajectory.npz"]
    assert np.load(path)["t"].tolist() == [0.0, 0.0]
