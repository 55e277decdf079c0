"""Same seed, same study: the README's minibus study (``suspenv run
experiments/minibus_nsga2.toml``, pymoo's NSGA-II) on a small budget gives the same
archive, Pareto front and pick when it is run again, on one worker or a pool of two, and
with one or two BLAS threads; with the rear leaves' interleaf friction too (the study of
``benchmarks.minibus_ride_effects``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from benchmarks.minibus_ride_effects import STUDY_FRICTION, STUDY_RMS_LIMIT
from benchmarks.minibus_study import CONFIG, archive_arrays
from suspenv.problems.minibus import MinibusRideHandling, study_outcome
from suspenv.registry import make_problem
from suspenv.runs.config import load_config
from suspenv.runs.runner import run_experiment

#: 8 generations of 40: every operator of the study's loop (survival, crowding,
#: crossover, mutation) acts on its own archive several times, in seconds
SMALL = (
    "budget=320",
    "strategy.options.population_size=40",
    "run.progress=false",
    "run.plots=false",
)
#: the archive's columns that a run's path decides
COLUMNS = ("unit", "x", "objectives", "constraints", "ok")
FRICTION = (STUDY_FRICTION, f"problem.options.rms_limit={STUDY_RMS_LIMIT}")


def _study(out: Path, workers: int, blas_threads: int, sets: tuple[str, ...]) -> dict[str, Any]:
    """The study's config with the small budget, ``workers`` and ``sets``, run in this
    process with the BLAS libraries limited to ``blas_threads`` (threadpoolctl sets
    their thread count at run time, as OPENBLAS_NUM_THREADS / OMP_NUM_THREADS do at
    start; a forked worker keeps it): its archive's arrays and config. No figures and
    no minibus report (both drawn from the archive afterwards, the test's seconds)."""
    overrides = [*SMALL, *sets, f'run.output="{out}"', f"run.workers={workers}"]
    config = load_config(CONFIG, overrides)
    with threadpool_limits(limits=blas_threads):
        run_dir, _ = run_experiment(config)
    return {"arrays": archive_arrays(run_dir), "config": config}


@pytest.mark.parametrize("sets", [(), FRICTION], ids=["default", "leaf_friction"])
def test_same_seed_gives_the_same_study_whatever_the_workers_and_blas_threads(
    tmp_path, monkeypatch, sets
):
    monkeypatch.setattr(MinibusRideHandling, "write_report", lambda self, run_dir, archive: [])
    # the same seed run three times: one worker and one BLAS thread, a pool of two, two
    # BLAS threads; each must repeat the first row by row
    runs = {
        (workers, threads): _study(tmp_path / f"{workers}-{threads}", workers, threads, sets)
        for workers, threads in ((1, 1), (2, 1), (1, 2))
    }
    ref = runs[(1, 1)]["arrays"]
    assert ref["ok"].size == 320 and ref["ok"].all()
    for key, run in runs.items():
        for col in COLUMNS:
            np.testing.assert_array_equal(run["arrays"][col], ref[col], err_msg=f"{key}: {col}")
    # and so the front and the report's pick
    config = runs[(1, 1)]["config"]
    problem = make_problem(config["problem"]["name"], **config["problem"].get("options", {}))
    found = [study_outcome(problem, run["arrays"]) for run in runs.values()]
    assert all(f is not None for f in found)
    for f in found[1:]:
        np.testing.assert_array_equal(f.front, found[0].front)
        assert f.pick == found[0].pick
