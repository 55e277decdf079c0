"""Experiment configuration: TOML files, ``--set key=value`` overrides, validation.

A config (see ``configs/*.toml``)::

    name = "sphere_cmaes"        # run name (default: the file's stem)
    seed = 1                     # every run has a seed
    budget = 2000                # evaluations
    pipeline = "optimize"        # registered pipeline (default "optimize")

    [problem]
    name = "Sphere"
    options = { dim = 10 }

    [strategy]
    name = "cmaes"
    options = { popsize = 12 }

    [run]
    workers = 1                  # >1: a process pool
    output = "runs"              # parent folder of run directories
    plots = true
    progress = true

Pipelines may read further tables of their own (e.g. ``[study]``); unknown top-level keys
are an error only for the "optimize" pipeline's own tables.
"""

from __future__ import annotations

import copy
import difflib
import re
import tomllib
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError

DEFAULTS: dict[str, Any] = {
    "seed": 0,
    "pipeline": "optimize",
    "problem": {"options": {}},
    "strategy": {"options": {}},
    "run": {
        "workers": 1,
        "output": "runs",
        "plots": True,
        "progress": True,
        "dask_scheduler": None,
    },
}

KNOWN_TOP = {"name", "seed", "budget", "pipeline", "problem", "strategy", "run", "description"}
KNOWN_RUN = {"workers", "output", "plots", "progress", "dask_scheduler", "chunk_size"}


def _merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def parse_override(text: str) -> tuple[list[str], Any]:
    """``"strategy.options.popsize=42"`` -> (["strategy", "options", "popsize"], 42).

    The value is parsed as a TOML value (numbers, booleans, strings, arrays); a bare word
    that is not valid TOML is taken as a string.
    """
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValidationError(f"--set needs `key=value`, but got {text!r}")
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key.split("."), value


def apply_overrides(config: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    out = copy.deepcopy(config)
    for text in overrides:
        path, value = parse_override(text)
        node = out
        for part in path[:-1]:
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise ValidationError(f"--set {text!r}: `{part}` is a value ({nxt!r}), not a table")
            node = nxt
        node[path[-1]] = value
    return out


def _check_unknown(keys: set[str], known: set[str], where: str) -> None:
    for k in sorted(keys - known):
        near = difflib.get_close_matches(k, sorted(known), n=1)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise ValidationError(f"config: unknown key {where}{k!r}{hint}")


#: a run name: a plain file name (no path separators, not hidden), so the run directory
#: stays inside the output folder
RUN_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.\-]{0,127}")


def check_code_names(cfg: dict[str, Any], allow_code: bool) -> None:
    """A ``module:attribute`` problem or strategy name imports and runs that code; it is
    refused unless the user allowed it (``suspenv run --allow-code``), never by the config
    itself. Registered names (``suspenv list``) are always fine."""
    for table in ("problem", "strategy"):
        name = (cfg.get(table) or {}).get("name")
        if isinstance(name, str) and ":" in name and not allow_code:
            raise ValidationError(
                f"config: `{table}.name = {name!r}` names code to import (module:attribute); "
                "a config runs code only when the user says so: pass --allow-code to "
                "`suspenv run`, or register it with suspenv.registry.register_problem / "
                "register_strategy"
            )


def validate(config: dict[str, Any], allow_code: bool = False) -> dict[str, Any]:
    """Fill defaults and check types; errors name the key, the rule and the value.

    ``allow_code``: the user allows ``module:attribute`` problem and strategy names (see
    :func:`check_code_names`); a config cannot allow it itself."""
    if "allow_code" in (config.get("run") or {}):
        raise ValidationError(
            "config: `run.allow_code` cannot be set by a config (a config does not decide "
            "to run code); pass --allow-code to `suspenv run`"
        )
    cfg = _merge(DEFAULTS, config)
    name = cfg.get("name")
    if not isinstance(name, str) or not RUN_NAME.fullmatch(name):
        raise ValidationError(
            "config: `name` must be a plain file name (letters, digits, '_', '-', '.', not "
            f"starting with '.' or '-', at most 128 characters), but got {name!r}"
        )
    check_code_names(cfg, allow_code)
    if cfg["pipeline"] == "optimize":
        _check_unknown(set(cfg), KNOWN_TOP, "")
        _check_unknown(set(cfg["run"]), KNOWN_RUN, "run.")
        for table in ("problem", "strategy"):
            if not isinstance(cfg[table].get("name"), str):
                raise ValidationError(
                    f"config: `{table}.name` must be a string, but got {cfg[table].get('name')!r}"
                )
        if "budget" not in cfg:
            raise ValidationError("config: `budget` (number of evaluations) is required")
    seed = cfg["seed"]
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ValidationError(f"config: `seed` must be an integer >= 0, but got {seed!r}")
    if "budget" in cfg:
        b = cfg["budget"]
        if not isinstance(b, int) or isinstance(b, bool) or b < 1:
            raise ValidationError(f"config: `budget` must be an integer >= 1, but got {b!r}")
    w = cfg["run"]["workers"]
    if not isinstance(w, int) or isinstance(w, bool) or w < 1:
        raise ValidationError(f"config: `run.workers` must be an integer >= 1, but got {w!r}")
    for table in ("problem", "strategy"):
        if not isinstance(cfg[table].get("options", {}), dict):
            raise ValidationError(f"config: `{table}.options` must be a table")
    return cfg


def load_config(
    path: str | Path, overrides: list[str] | None = None, allow_code: bool = False
) -> dict[str, Any]:
    """Read a TOML config, apply ``key=value`` overrides, fill defaults, validate
    (``allow_code``: see :func:`validate`)."""
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"config file {str(path)!r} does not exist")
    try:
        raw = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValidationError(f"config {str(path)!r} is not valid TOML: {exc}") from None
    raw.setdefault("name", path.stem)
    raw = apply_overrides(raw, overrides or [])
    cfg = validate(raw, allow_code)
    cfg["config_path"] = str(path)
    return cfg
