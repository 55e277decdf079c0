"""Where the shared data lives (the one rule every loader, CLI and benchmark uses), and
the rules of the folders and file names the commands write.

Output rules (``suspenv diagnose``, ``suspenv knc``, ``suspenv planar``):

* :func:`check_output_dir`: a command refuses to write into an existing non-empty
  folder unless the user passes ``--overwrite``; then it replaces only the files of
  the same names it writes, and deletes nothing;
* :func:`plain_file_name` / :func:`output_file`: a file name derived from data (a
  vehicle name, a recording name) becomes a plain file name (letters, digits, ``_``,
  ``-``, ``.``; not hidden, no path), so nothing is written outside the output folder.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from suspenv.core.errors import ValidationError

#: environment variable naming the shared data folder
DATA_ENV = "SUSPENV_DATA"
#: longest file name made from data (characters)
MAX_NAME = 128
_UNSAFE = re.compile(r"[^A-Za-z0-9_.\-]+")


def data_dir() -> Path:
    """The shared data folder (real recordings under ``real/``; never copied into the
    repository).

    In order: the folder named by the environment variable ``SUSPENV_DATA``; else
    ``../shared/data`` relative to the current working directory, when it exists; else
    ``../shared/data`` relative to the source checkout holding the ``suspenv`` package
    (returned whether or not it exists, so a caller can say where it looked).
    """
    env = os.environ.get(DATA_ENV)
    if env:
        return Path(env).expanduser()
    here = Path.cwd().parent / "shared" / "data"
    if here.is_dir():
        return here
    return Path(__file__).resolve().parents[2].parent / "shared" / "data"


def plain_file_name(text: str, fallback: str = "unnamed") -> str:
    """``text`` as a plain file name: every run of characters other than letters, digits,
    ``_``, ``-`` and ``.`` becomes ``_`` (so ``/`` and ``\\`` never survive), leading
    ``.`` and ``-`` are dropped (no hidden file, no ``..``, nothing read as an option),
    at most :data:`MAX_NAME` characters; ``fallback`` when nothing is left."""
    name = _UNSAFE.sub("_", str(text)).lstrip(".-")[:MAX_NAME]
    return name or fallback


def output_file(out_dir: Path, name: str) -> Path:
    """``out_dir / plain_file_name(name)``, checked to lie directly in ``out_dir``."""
    path = Path(out_dir) / plain_file_name(name)
    if path.resolve().parent != Path(out_dir).resolve():
        raise ValidationError(
            f"output file {name!r} would leave the output folder {str(out_dir)!r}"
        )
    return path


def check_output_dir(out_dir: Path, overwrite: bool, flag: str = "--overwrite") -> Path:
    """Refuse ``out_dir`` when it is a file, or an existing folder that is not empty and
    ``overwrite`` is False (the message names the folder and ``flag``). Creates nothing:
    the writers make the folder when they write."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValidationError(
            f"output folder {str(out_dir)!r} is a file; choose another folder with --out"
        )
    if out_dir.is_dir() and not overwrite and any(out_dir.iterdir()):
        raise ValidationError(
            f"output folder {str(out_dir)!r} exists and is not empty; pass {flag} to replace "
            "the files of the same names this command writes there (nothing else is "
            "deleted), or choose another folder with --out"
        )
    return out_dir
