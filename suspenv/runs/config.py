"""Experiment configuration: TOML files, ``--set key=value`` overrides, validation.

A config (see ``experiments/*.toml``)::

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
    timeout_s = 60.0             # seconds per design before it is a fault of the machinery
                                 # (default: the problem's own timeout_s)
    retries = 3                  # retries of a chunk after a fault of the machinery
    retry_backoff_s = 1.0        # wait before the first retry; doubles for each next one

Pipelines may read further tables of their own (:data:`PIPELINE_TABLES`, e.g.
``[study]``), which the pipeline's check (:func:`suspenv.registry.pipeline_check`)
validates before any work. Unknown keys are errors for every pipeline: at the top level
(any key that is neither in :data:`KNOWN_TOP` nor one of the pipeline's own tables) and
in the ``[problem]``, ``[strategy]`` and ``[run]`` tables. A pipeline registered by a
user, whose tables are not known here, has its top level checked by its own check.
"""

from __future__ import annotations

import copy
import re
import tomllib
from pathlib import Path
from typing import Any

from suspenv.core.errors import ValidationError
from suspenv.core.options import did_you_mean, flag, integer, text
from suspenv.core.tomlfile import read_toml
from suspenv.runs.evaluation import FaultPolicy

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
        "retries": 3,
        "retry_backoff_s": 1.0,
    },
}

KNOWN_TOP = {"name", "seed", "budget", "pipeline", "problem", "strategy", "run", "description"}
#: keys of the [run] table: those with a default, and two without (chunk_size: one chunk
#: per worker; timeout_s: the problem's own)
KNOWN_RUN = {*DEFAULTS["run"], "chunk_size", "timeout_s"}
#: keys of the [problem] and [strategy] tables
KNOWN_PART = {"name", "options"}
#: the tables each shipped pipeline reads besides :data:`KNOWN_TOP`
PIPELINE_TABLES: dict[str, set[str]] = {
    "optimize": set(),
    "tey2014": {"study"},
    "identify": {"identify"},
    "diagnosis_benchmark": {"benchmark", "diagnosis"},
}
#: address schemes of Dask's transports
DASK_SCHEMES = ("tcp", "tls", "ucx", "ws", "wss", "inproc")


def plots_wanted(config: dict[str, Any]) -> bool:
    """Whether a run draws its figures: the config's ``run.plots``, or the default of
    :data:`DEFAULTS` where the config has none (a bare pipeline call, an older archive)."""
    return bool((config.get("run") or {}).get("plots", DEFAULTS["run"]["plots"]))


def _merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def flatten_config(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested tables as dotted keys: ``{"a": {"b": 1}}`` -> ``{"a.b": 1}`` (an empty
    table is a value of its own)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict) and v:
            out.update(flatten_config(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def config_differences(
    a: dict[str, Any], b: dict[str, Any], ignore: frozenset[str] = frozenset()
) -> list[str]:
    """How config ``b`` differs from ``a``, one ``"dotted.key: old -> new"`` line per
    differing value in key order (``(unset)`` where one lacks the key); top-level keys in
    ``ignore`` are left out. The words of a resumed run's refusal and of ``compare``'s."""
    fa = flatten_config({k: v for k, v in a.items() if k not in ignore})
    fb = flatten_config({k: v for k, v in b.items() if k not in ignore})
    return [
        f"{k}: {fa.get(k, '(unset)')!r} -> {fb.get(k, '(unset)')!r}"
        for k in sorted(set(fa) | set(fb))
        if fa.get(k, "(unset)") != fb.get(k, "(unset)")
    ]


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
    for override in overrides:
        path, value = parse_override(override)
        node = out
        for part in path[:-1]:
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise ValidationError(
                    f"--set {override!r}: `{part}` is a value ({nxt!r}), not a table"
                )
            node = nxt
        node[path[-1]] = value
    return out


def _check_unknown(keys: set[str], known: set[str], where: str) -> None:
    for k in sorted(keys - known):
        hint = did_you_mean(k, sorted(known), n=1)
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
    for table in ("problem", "strategy", "run"):
        if table in config and not isinstance(config[table], dict):
            raise ValidationError(f"config: `{table}` must be a table, but got {config[table]!r}")
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
    _check_unknown(set(cfg["run"]), KNOWN_RUN, "run.")
    for table in ("problem", "strategy"):
        _check_unknown(set(cfg[table]), KNOWN_PART, f"{table}.")
    _check_pipeline_keys(cfg)
    cfg["seed"] = integer("config", "seed", cfg["seed"], lo=0)
    if "budget" in cfg:
        cfg["budget"] = integer("config", "budget", cfg["budget"], lo=1)
    _check_run(cfg["run"])
    for table in ("problem", "strategy"):
        if not isinstance(cfg[table].get("options", {}), dict):
            raise ValidationError(f"config: `{table}.options` must be a table")
    return cfg


def _check_pipeline_keys(cfg: dict[str, Any]) -> None:
    """The top-level keys the config's pipeline knows (:data:`PIPELINE_TABLES`), and what
    the optimize pipeline requires: problem and strategy names, a budget."""
    text("config", "pipeline", cfg["pipeline"], empty=True)
    tables = PIPELINE_TABLES.get(cfg["pipeline"])
    if tables is not None:
        _check_unknown(set(cfg), KNOWN_TOP | tables, "")
    if cfg["pipeline"] != "optimize":
        return
    for table in ("problem", "strategy"):
        text("config", f"{table}.name", cfg[table].get("name"), empty=True)
    if "budget" not in cfg:
        raise ValidationError("config: `budget` (number of evaluations) is required")


def _check_run(run: dict[str, Any]) -> None:
    """Types and ranges of the ``[run]`` table (timeout and retries: FaultPolicy)."""
    run["workers"] = integer("config", "run.workers", run["workers"], lo=1)
    if run.get("chunk_size") is not None:
        run["chunk_size"] = integer("config", "run.chunk_size", run["chunk_size"], lo=1)
    for key in ("plots", "progress"):
        flag("config", f"run.{key}", run[key])
    if not isinstance(run["output"], str) or not run["output"]:
        raise ValidationError(
            f"config: `run.output` must be a folder name, but got {run['output']!r}"
        )
    address = run.get("dask_scheduler")
    scheme, _, host = address.partition("://") if isinstance(address, str) else ("", "", "")
    if address is not None and (scheme not in DASK_SCHEMES or not host.strip("/")):
        raise ValidationError(
            "config: `run.dask_scheduler` must be a scheduler address "
            f"({'|'.join(DASK_SCHEMES)}://host:port, e.g. 'tcp://host:8786' or "
            f"'tls://host:8786'), but got {address!r}"
        )
    timeout = run.get("timeout_s")
    FaultPolicy(
        timeout_s=FaultPolicy.timeout_s if timeout is None else timeout,
        retries=run["retries"],
        backoff_s=run["retry_backoff_s"],
    )


def load_config(
    path: str | Path, overrides: list[str] | None = None, allow_code: bool = False
) -> dict[str, Any]:
    """Read a TOML config, apply ``key=value`` overrides, fill defaults, validate
    (``allow_code``: see :func:`validate`)."""
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"config file {str(path)!r} does not exist")
    raw = read_toml(path, f"config {str(path)!r}")
    raw.setdefault("name", path.stem)
    raw = apply_overrides(raw, overrides or [])
    cfg = validate(raw, allow_code)
    cfg["config_path"] = str(path)
    return cfg
