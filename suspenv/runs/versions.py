"""Versions of the packages a result depends on (stored with every run and benchmark)."""

from __future__ import annotations

import platform
import re
import subprocess
from importlib import metadata
from pathlib import Path

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


def source_commit() -> str | None:
    """The git commit of the suspenv source that is running (``"<sha>"``, with
    ``"+modified"`` when tracked files differ from it), or None outside a git checkout
    (an installed wheel) or without git."""
    root = Path(__file__).resolve().parents[2]
    try:
        sha = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        if sha.returncode != 0:
            return None
        status = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    modified = "+modified" if status.returncode == 0 and status.stdout.strip() else ""
    return sha.stdout.strip() + modified


def package_versions() -> dict[str, str]:
    """``{package: version}`` for the tracked packages that are installed, plus Python and
    the git commit of the suspenv source (``suspenv_commit``) where it runs from a
    checkout."""
    out = {"python": platform.python_version()}
    commit = source_commit()
    if commit is not None:
        out["suspenv_commit"] = commit
    for name in tracked_packages():
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out
