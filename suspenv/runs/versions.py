"""Versions of the packages a result depends on (stored with every run and benchmark).

:func:`package_versions` records Python, the git commit of the suspenv source, suspenv and
the packages it declares (required ones and the :data:`RESULT_EXTRAS`); with
``imported=True`` also every installed distribution that provides a module imported in
this process by then (:func:`imported_distributions`), so optional packages that ran
(nevergrad, distributed, an optuna storage's SQLAlchemy, ...) are recorded too. The optimize
pipeline writes the latter at the end of a run (``versions.json``).
"""

from __future__ import annotations

import functools
import platform
import re
import subprocess
import sys
from collections.abc import Iterable
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


@functools.cache
def source_commit() -> str | None:
    """The git commit of the suspenv source that is running (``"<sha>"``, with
    ``"+modified"`` when tracked files differ from it), or None outside a git checkout
    (an installed wheel) or without git.

    Asked once per process (two ``git`` calls, about 20 ms): the source a process runs is
    the one it imported, and every run and benchmark of the process records the same."""
    root = Path(__file__).resolve().parents[2]

    def git(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            ["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10
        )

    try:
        sha = git("rev-parse", "HEAD")
        if sha.returncode != 0:
            return None
        status = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    modified = "+modified" if status.returncode == 0 and status.stdout.strip() else ""
    return sha.stdout.strip() + modified


def imported_distributions(modules: Iterable[str] | None = None) -> dict[str, str]:
    """``{distribution: version}`` of every installed distribution that provides the
    top-level package of a module in ``modules`` (default: ``sys.modules`` now, i.e. every
    package imported in this process so far), sorted by name. Standard-library and
    suspenv's own modules map to no other distribution and are left out; a top-level name
    several distributions provide (a namespace package) names each of them."""
    names = list(sys.modules) if modules is None else list(modules)
    providers = metadata.packages_distributions()
    out: dict[str, str] = {}
    for top in sorted({m.partition(".")[0] for m in names}):
        for dist in providers.get(top, ()):
            if dist in out:
                continue
            try:
                out[dist] = metadata.version(dist)
            except metadata.PackageNotFoundError:
                continue
    return dict(sorted(out.items(), key=lambda kv: kv[0].lower()))


def package_versions(imported: bool = False) -> dict[str, str]:
    """``{package: version}`` for the tracked packages that are installed, plus Python and
    the git commit of the suspenv source (``suspenv_commit``) where it runs from a
    checkout; with ``imported`` also every distribution imported in this process
    (:func:`imported_distributions`; a tracked package keeps its entry)."""
    out = dict(_tracked_versions())
    if imported:
        known = {_normal(k) for k in out}
        for dist, version in imported_distributions().items():
            if _normal(dist) not in known:
                out[dist] = version
    return out


@functools.cache
def _tracked_versions() -> tuple[tuple[str, str], ...]:
    """Python, the source commit and the tracked packages' versions (read once per
    process: installed metadata does not change under a running process)."""
    out = {"python": platform.python_version()}
    commit = source_commit()
    if commit is not None:
        out["suspenv_commit"] = commit
    for name in tracked_packages():
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return tuple(out.items())


def _normal(name: str) -> str:
    """A distribution name in PEP 503 normal form (``PyYAML`` -> ``pyyaml``)."""
    return re.sub(r"[-_.]+", "-", name).lower()
