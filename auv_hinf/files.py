"""Files written whole or not at all.

An output interrupted half-way (Ctrl-C while ``simulate --out`` writes its trajectory) must not be
left behind as a truncated file that looks complete. Every output goes to a temporary name beside
its own and is renamed onto it when written in full (a rename within one folder is atomic on
POSIX); an interrupted write removes the temporary file.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def written(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; renamed onto ``path`` when the block ends normally.

    The temporary name keeps ``path``'s extension (writers such as ``savefig`` and ``np.savez`` read
    the format from it) and is hidden (a leading dot). When the block raises, or is interrupted, the
    temporary file is removed and ``path`` is left as it was.

    Parameters
    ----------
    path : str or Path
        The file to write.

    Yields
    ------
    Path
        The temporary file to write instead of ``path``.
    """
    target = Path(path)
    tmp = target.with_name(f".{target.name}.part{target.suffix}")
    try:
        yield tmp
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all (:func:`written`).

    Parameters
    ----------
    path : str or Path
        The file.
    text : str
        Its content.
    """
    with written(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


__all__ = ["write_text", "written"]
