"""Run an experiment config: check it, prepare the run directory, dispatch to its pipeline.

Order, so that a bad config leaves nothing behind and two runs never share a directory:
1. the pipeline's check (:func:`suspenv.registry.pipeline_check`) builds and validates
   everything the config names and fills in the defaults it will use; no file is written;
2. the run directory is locked (:func:`suspenv.runs.run_dir.locked`);
3. an existing run directory either holds the same experiment (the run resumes), holds no
   results yet (it is replaced: e.g. what a crashed start left), or is refused unless
   ``overwrite``; a damaged ``config.resolved.toml`` or ``versions.json`` is named, and
   ``overwrite`` starts such a folder anew;
4. the resolved config and versions are written (atomically, as every file of a run
   directory: :func:`suspenv.core.atomic.write_file`), then the pipeline runs.
"""

from __future__ import annotations

import json
import os
import shutil
import time
import tomllib
from pathlib import Path
from typing import Any

from suspenv.core.errors import SuspenvError, ValidationError
from suspenv.registry import pipeline_check, pipeline_function
from suspenv.runs.config import config_differences, validate
from suspenv.runs.run_dir import (
    LOCK_FILE,
    holds_results,
    locked,
    prepare_run_dir,
    run_directory,
)
from suspenv.runs.versions import package_versions

#: keys that may differ between a run and its resumption (they do not change numbers)
RESUMABLE_DIFFERENCES = frozenset({"run", "config_path"})


def check_config(config: dict[str, Any]) -> dict[str, Any]:
    """The config after its pipeline's check: every option validated, defaults filled in.
    Writes nothing."""
    pipeline_function(config.get("pipeline", "optimize"))  # unknown: error with suggestions
    check = pipeline_check(config.get("pipeline", "optimize"))
    return config if check is None else check(config)


def _resolved(old: dict[str, Any]) -> dict[str, Any]:
    """An existing run directory's config with the defaults of today's check filled in
    (a directory written before a default was recorded still resumes); as written when
    it no longer passes the check (it then differs, and the difference is named)."""
    try:
        return check_config(validate({k: v for k, v in old.items() if k != "config_path"}))
    except SuspenvError:
        return old


def _clear(path: Path) -> None:
    """Empty the run directory but keep it and its lock file (the lock is held)."""
    for child in path.iterdir():
        if child.name == LOCK_FILE:
            continue
        if child.is_dir() and not child.is_symlink():
            shutil.rmtree(child)
        else:
            child.unlink()


def _damaged(path: Path, exc: Exception) -> ValidationError:
    return ValidationError(
        f"{str(path)!r} is damaged ({type(exc).__name__}: {exc}); the run directory cannot "
        "be resumed from it: start it anew with --overwrite (deletes what it holds), or "
        "restore the file from a copy"
    )


def _read_resolved(path: Path) -> dict[str, Any]:
    """The run directory's ``config.resolved.toml``; a damaged file is named."""
    try:
        return tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise _damaged(path, exc) from None


def _differences_from(resolved: Path, config: dict[str, Any]) -> list[str]:
    """How ``config`` differs from the run directory's ``config.resolved.toml``; a damaged
    file differs in everything (refused when the folder holds results, else replaced)."""
    try:
        old = _read_resolved(resolved)
    except ValidationError:
        if holds_results(resolved.parent):
            raise
        return ["config.resolved.toml: damaged"]
    return config_differences(_resolved(old), config, RESUMABLE_DIFFERENCES)


def _refuse_links(path: Path) -> None:
    """A symbolic link inside a run directory would take the run's writes out of its
    output folder: refused, naming it (``--overwrite`` removes the link itself)."""
    for entry in path.rglob("*"):
        if entry.is_symlink():
            raise ValidationError(
                f"run directory {str(path)!r} holds a symbolic link {entry.name!r} (to "
                f"{os.readlink(entry)!r}); a run writes only inside its output folder: "
                "remove the link, or start the run anew with --overwrite"
            )


def _check_same_code(path: Path) -> None:
    """Refuse to resume results written by another suspenv commit: the resumed rows and
    the new ones would come from two versions of the code (``versions.json``)."""
    stored = path / "versions.json"
    if not stored.is_file():
        return
    try:
        versions = json.loads(stored.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise _damaged(stored, exc) from None
    old = versions.get("suspenv_commit") if isinstance(versions, dict) else None
    new = package_versions().get("suspenv_commit")
    if old and new and old != new:
        raise ValidationError(
            f"run directory {str(path)!r} holds results of suspenv {old}, but this is "
            f"{new}: resuming would mix results of two versions of the code; use "
            "--overwrite (or another `name`/`seed`)"
        )


def run_experiment(config: dict[str, Any], overwrite: bool = False) -> tuple[Path, dict[str, Any]]:
    """Run a resolved config; resume when its run directory holds the same experiment."""
    config = check_config(config)
    path = run_directory(config)
    with locked(path):
        resolved = path / "config.resolved.toml"
        if overwrite:
            _clear(path)  # whatever it holds, damaged files and links included
        _refuse_links(path)
        if resolved.exists():
            diff = _differences_from(resolved, config)
            if diff and not holds_results(path):
                _clear(path)
            elif diff:
                raise ValidationError(
                    f"run directory {str(path)!r} holds a different experiment "
                    f"({'; '.join(diff[:5])}); use another `name`/`seed`, or --overwrite"
                )
            elif holds_results(path):
                _check_same_code(path)
        run_dir = prepare_run_dir(config)
        pipeline = pipeline_function(config.get("pipeline", "optimize"))
        t0 = time.perf_counter()
        summary = pipeline(config, run_dir)
        summary.setdefault("pipeline_wall_time_s", time.perf_counter() - t0)
    return run_dir, summary
