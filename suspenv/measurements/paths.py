"""Where the shared data lives: the one rule every loader, CLI and benchmark uses."""

from __future__ import annotations

import os
from pathlib import Path

#: environment variable naming the shared data folder
DATA_ENV = "SUSPENV_DATA"


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
