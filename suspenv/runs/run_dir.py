"""Run directories: ``<output>/<name>-seed<seed>/`` with the resolved config and versions."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

from suspenv.runs.versions import package_versions


def run_directory(config: dict[str, Any]) -> Path:
    """The run directory of a resolved config (not created)."""
    return Path(config["run"]["output"]) / f"{config['name']}-seed{config['seed']}"


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def dump_toml(config: dict[str, Any]) -> str:
    """A small TOML writer for resolved configs (scalars, arrays, nested tables; no None)."""
    lines: list[str] = []

    def table(prefix: str, d: dict[str, Any]) -> None:
        scalars = {k: v for k, v in d.items() if not isinstance(v, dict) and v is not None}
        subs = {k: v for k, v in d.items() if isinstance(v, dict)}
        if prefix and (scalars or not subs):
            lines.append(f"\n[{prefix}]")
        for k, v in scalars.items():
            lines.append(f"{k} = {_toml_value(v)}")
        for k, v in subs.items():
            table(f"{prefix}.{k}" if prefix else k, v)

    table("", config)
    text = "\n".join(lines).lstrip() + "\n"
    tomllib.loads(text)  # what we write must read back
    return text


def prepare_run_dir(config: dict[str, Any]) -> Path:
    """Create the run directory; write ``config.resolved.toml`` and ``versions.json``."""
    path = run_directory(config)
    path.mkdir(parents=True, exist_ok=True)
    (path / "config.resolved.toml").write_text(dump_toml(config))
    (path / "versions.json").write_text(json.dumps(package_versions(), indent=2) + "\n")
    return path
