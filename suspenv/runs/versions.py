"""Versions of the packages a result depends on (stored with every run and benchmark)."""

from __future__ import annotations

import platform
import re
from importlib import metadata

#: extras whose packages a result can depend on (the others are tooling, e.g. tests)
RESULT_EXTRAS = ("dask",)


def tracked_packages() -> tuple[str, ...]:
    """suspenv and the packages it declares (its installed metadata, so the list follows
    ``pyproject.toml``): the required ones and those of :data:`RESULT_EXTRAS`."""
    try:
        requirements = metadata.requires("suspenv") or []
    except metadata.PackageNotFoundError:
        requirements = []
    names = ["suspenv"]
    for req in requirements:
        spec, _, marker = req.partition(";")
        extra = re.search(r"extra\s*==\s*['\"]([^'\"]+)['\"]", marker)
        if extra and extra.group(1) not in RESULT_EXTRAS:
            continue
        name = re.match(r"[A-Za-z0-9_.\-]+", spec.strip())
        if name:
            names.append(name.group(0))
    return tuple(dict.fromkeys(names))


def package_versions() -> dict[str, str]:
    """``{package: version}`` for the tracked packages that are installed, plus Python."""
    out = {"python": platform.python_version()}
    for name in tracked_packages():
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out
