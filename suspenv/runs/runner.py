"""Run an experiment config: resolve, prepare the run directory, dispatch to its pipeline."""

from __future__ import annotations

import shutil
import time
import tomllib
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError
from suspenv.registry import pipeline_function
from suspenv.runs.run_dir import prepare_run_dir, run_directory

#: keys that may differ between a run and its resumption (they do not change numbers)
RESUMABLE_DIFFERENCES = {"run", "config_path"}


def _differences(a: dict[str, Any], b: dict[str, Any], prefix: str = "") -> list[str]:
    out = []
    for k in sorted(set(a) | set(b)):
        if not prefix and k in RESUMABLE_DIFFERENCES:
            continue
        va, vb = a.get(k), b.get(k)
        if isinstance(va, dict) and isinstance(vb, dict):
            out += _differences(va, vb, f"{prefix}{k}.")
        elif va != vb:
            out.append(f"{prefix}{k}: {va!r} -> {vb!r}")
    return out


def run_experiment(config: dict[str, Any], overwrite: bool = False) -> tuple[Path, dict[str, Any]]:
    """Run a resolved config; resume when its run directory holds the same experiment."""
    path = run_directory(config)
    resolved = path / "config.resolved.toml"
    if resolved.exists():
        if overwrite:
            shutil.rmtree(path)
        else:
            old = tomllib.loads(resolved.read_text())
            diff = _differences(old, config)
            if diff:
                raise ValidationError(
                    f"run directory {str(path)!r} holds a different experiment "
                    f"({'; '.join(diff[:5])}); use another `name`/`seed`, or --overwrite"
                )
    run_dir = prepare_run_dir(config)
    pipeline = pipeline_function(config.get("pipeline", "optimize"))
    t0 = time.perf_counter()
    summary = pipeline(config, run_dir)
    summary.setdefault("pipeline_wall_time_s", time.perf_counter() - t0)
    return run_dir, summary
