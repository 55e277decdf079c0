"""A suite run compared: what each instance knows of its optimum, handed to the analysis.

:func:`compare_suite` reads ``suite.json`` (:mod:`suspenv.suite.runner`) and compares its
runs with :func:`suspenv.analysis.compare.compare` (``suite=True``: each instance on its
own, a performance profile across them), passing per instance (keyed by the problem hash
the analysis gives the instance's runs):

- ``optimum`` -> ``f_opt`` (targets ``f_opt + 10^k``);
- ``target`` (the truth's quality of an identification) -> the targets
  :data:`TARGET_FACTORS` times that value, so "reached the truth's level" is the last
  target and the easier ones lead up to it;
- ``front`` -> the reference front (hypervolume deficit and IGD against it).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.analysis.compare import Comparison, compare
from suspenv.analysis.load import load_run
from suspenv.core.errors import ValidationError
from suspenv.suite.fronts import load_front
from suspenv.suite.runner import SUITE_FILE

#: targets of a "target" instance, as multiples of the truth's quality (last: the truth)
TARGET_FACTORS = (10.0, 5.0, 3.0, 2.0, 1.5, 1.2, 1.1, 1.05, 1.0)


def read_suite(folder: str | Path) -> dict[str, Any]:
    """The ``suite.json`` of a suite run's output folder."""
    path = Path(folder) / SUITE_FILE
    if not path.is_file():
        raise ValidationError(
            f"{str(folder)!r} holds no {SUITE_FILE} (made by `suspenv suite run`)"
        )
    data: dict[str, Any] = json.loads(path.read_text())
    return data


def compare_suite(folder: str | Path, **options: Any) -> Comparison:
    """Compare every run of a suite run (keywords go to the analysis' ``compare``)."""
    data = read_suite(folder)
    cards = {card["name"]: card for card in data["instances"]}
    f_opt: dict[str, float] = {}
    targets: dict[str, list[float]] = {}
    fronts: dict[str, np.ndarray] = {}
    runs = []
    for run in data["runs"]:
        record = load_run(run["run_dir"])
        runs.append(record)
        known = cards[f"{run['function']}/i{run['instance']}"]["known"]
        key = record.problem_hash
        if known["kind"] == "optimum":
            f_opt[key] = float(known["f"])
        elif known["kind"] == "target":
            targets[key] = [float(known["f"]) * k for k in TARGET_FACTORS]
        elif known["kind"] == "front":
            fronts[key] = load_front(known["front"]).points
    return compare(
        runs,
        suite=True,
        f_opt=f_opt or None,
        targets=targets or None,
        reference_front=fronts or None,
        **options,
    )
