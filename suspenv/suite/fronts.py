"""Reference fronts of the suite's multi-objective functions.

ZDT1's front is analytic (``f2 = 1 - sqrt(f1)``, sampled at 1001 points). The others are
computed once with a large budget (:func:`compute_front`: NSGA-II, pymoo backend, over
several seeds; the non-dominated union of every feasible evaluation) and shipped as
``suspenv/data/suite/<name>.json`` with their provenance (command, strategy, options,
budget, seeds, versions, date), so a benchmark never recomputes them and anyone can.

Fronts are the best known, not the true Pareto fronts: a strategy can dominate parts of
them. Indicators (hypervolume, IGD) against them compare strategies; they are not
distances to the optimum.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.pareto import nondominated
from suspenv.registry import make_strategy, problem_class
from suspenv.runs.loop import optimize
from suspenv.runs.versions import package_versions
from suspenv.suite.instances import build

#: where shipped fronts live (package data)
FRONT_DIR = Path(__file__).resolve().parents[1] / "data" / "suite"


@dataclass(frozen=True)
class Front:
    """A reference front: (n, m) objective values, their names, the (n, d) physical designs
    that reached them (None when analytic) and where they come from."""

    name: str
    objectives: tuple[str, ...]
    points: np.ndarray
    provenance: dict[str, Any]
    designs: np.ndarray | None = None


def load_front(name: str) -> Front:
    """The reference front ``name`` ("zdt1", "carside", "minibus")."""
    if name == "zdt1":
        return Front(
            "zdt1",
            ("f1", "f2"),
            problem_class("ZDT1").pareto_front(1001),
            {"source": "analytic: f2 = 1 - sqrt(f1) for f1 in [0, 1], 1001 points"},
        )
    path = FRONT_DIR / f"{name}.json"
    if not path.is_file():
        raise ValidationError(
            f"no reference front {name!r} (looked for {path}); compute it with "
            f"`suspenv suite front {name}`"
        )
    data = json.loads(path.read_text())
    points = np.asarray(data["front"], dtype=float)
    designs = np.asarray(data["designs"], dtype=float)
    return Front(name, tuple(data["objectives"]), points, dict(data["provenance"]), designs)


def thin(F: np.ndarray, max_points: int) -> np.ndarray:
    """Indices of at most ``max_points`` rows of F that cover it evenly: farthest-point
    sampling in objectives scaled by the front's range (deterministic: starts from the
    row with the smallest first objective)."""
    n = len(F)
    if n <= max_points:
        return np.arange(n)
    span = np.ptp(F, axis=0)
    G = (F - F.min(axis=0)) / np.where(span > 0, span, 1.0)
    chosen = [int(np.argmin(F[:, 0]))]
    dist = np.linalg.norm(G - G[chosen[0]], axis=1)
    for _ in range(max_points - 1):
        i = int(np.argmax(dist))
        chosen.append(i)
        dist = np.minimum(dist, np.linalg.norm(G - G[i], axis=1))
    return np.sort(np.array(chosen))


def compute_front(
    function_name: str,
    budget: int,
    seeds: tuple[int, ...] = (1, 2, 3),
    population: int = 200,
    out: Path | None = None,
    max_points: int = 2000,
) -> Front:
    """Run NSGA-II (pymoo) ``budget`` evaluations per seed on the function's instance 1;
    write the non-dominated union of feasible evaluations to ``out`` (default: the
    shipped file) with its provenance, and return it."""
    inst = build(function_name)  # an unknown name: an error with the nearest names
    if inst.known.kind != "front":
        raise ValidationError(
            f"`suspenv suite front` needs a multi-objective suite function with a computed "
            f"front, but got {function_name!r}"
        )
    f, p = inst.function, inst.problem
    name = inst.known.front or function_name
    objectives: list[np.ndarray] = []
    designs: list[np.ndarray] = []
    t0 = time.perf_counter()

    def keep(b: int, U: np.ndarray, batch: Any) -> None:
        objectives.append(batch.objectives[batch.feasible])
        designs.append(p.space.to_physical(U)[batch.feasible])

    for seed in seeds:
        strategy = make_strategy("pymoo_nsga2", p, seed=seed, population_size=population)
        optimize(p, strategy, budget, seed=seed, callbacks=[keep])
    F, X = np.vstack(objectives), np.vstack(designs)
    front = nondominated(F)
    F, X = F[front], X[front]
    _, first = np.unique(F, axis=0, return_index=True)
    F, X = F[np.sort(first)], X[np.sort(first)]
    found = len(F)
    keep_rows = thin(F, max_points)
    F, X = F[keep_rows], X[keep_rows]
    provenance = {
        "command": f"suspenv suite front {function_name} --budget {budget} "
        f"--seeds {' '.join(map(str, seeds))} --population {population}",
        "strategy": "pymoo_nsga2",
        "population_size": population,
        "budget_per_seed": budget,
        "seeds": list(seeds),
        "problem": f.problem,
        "options": f.options_for(1),
        "points": int(len(F)),
        "non_dominated_found": int(found),
        "thinning": f"farthest-point sampling to at most {max_points} points in objectives "
        "scaled to [0, 1] by the front's own range, starting from the best point of f1",
        "seconds": round(time.perf_counter() - t0, 1),
        "date": time.strftime("%Y-%m-%d"),
        "versions": package_versions(),
    }
    result = Front(name, tuple(p.objective_names), F, provenance, X)
    path = out or FRONT_DIR / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        json.dumps(
            {
                "name": name,
                "objectives": list(result.objectives),
                "parameters": list(p.space.names),
                "provenance": provenance,
                "front": [[float(v) for v in row] for row in F],
                "designs": [[float(v) for v in row] for row in X],
            },
            indent=None,
            separators=(",", ":"),
        )
        + "\n"
    )
    return result
