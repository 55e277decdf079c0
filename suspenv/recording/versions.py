"""Versions of the packages a result depends on (stored with every run and benchmark)."""

from __future__ import annotations

import platform
from importlib import metadata

TRACKED_PACKAGES = (
    "suspenv",
    "numpy",
    "scipy",
    "cma",
    "optuna",
    "gymnasium",
    "pymunk",
    "matplotlib",
    "distributed",
)


def package_versions() -> dict[str, str]:
    """``{package: version}`` for the tracked packages that are installed, plus Python."""
    out = {"python": platform.python_version()}
    for name in TRACKED_PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out
