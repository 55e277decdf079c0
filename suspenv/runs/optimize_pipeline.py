"""The "optimize" pipeline: one problem, one strategy, one budget -> a run directory.

Writes ``archive.sqlite`` (every evaluation, as it happens), ``evaluations.csv``,
``summary.json``, ``config.resolved.toml``, ``versions.json`` and figures
(``convergence.png``; ``pareto_pairs.png`` and ``pareto_parallel.png`` for several
objectives, drawn by :mod:`suspenv.reports.run`), then any report the problem writes itself.

* Resolved config: :func:`check_optimize_config` fills in every default the run uses —
  the problem's ``config()`` and the strategy's ``options()`` merged under the given
  options — where that round-trips: the merged options, written to TOML and read back,
  rebuild a problem (strategy) with the same ``config()`` (``options()``); otherwise the
  given options stay as they were. So ``config.resolved.toml`` run as a config is the
  same experiment (it resumes the run directory).
* Versions: ``versions.json`` is rewritten at the end of the run with every distribution
  imported by then (:func:`suspenv.runs.versions.package_versions` with ``imported``).
* Figures: when drawing takes longer than :data:`PROGRESS_AFTER_S` seconds, what is being
  drawn is printed to stderr (unless ``run.progress = false``); notes on what the figures
  leave out go to ``summary.json`` (``figure_notes``).
* Run id: the archive's meta holds a ``run_id`` (made on the first run into the
  directory, kept by resumes); a strategy with ``bind_run`` (optuna NSGA-II with a
  storage) tags its stored trials with it, so a resumed run directory replays its own
  trials and a new one is refused another run's study unless ``resume`` is set.
"""

from __future__ import annotations

import copy
import json
import sqlite3
import sys
import threading
import time
import tomllib
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import option_names
from suspenv.core.tomlfile import dump_toml
from suspenv.registry import (
    STRATEGY_RESERVED,
    make_problem,
    make_strategy,
    problem_class,
    report_function,
    strategy_class,
)
from suspenv.runs import quality as run_quality
from suspenv.runs.archive import RunArchive
from suspenv.runs.config import plots_wanted
from suspenv.runs.evaluation import FaultPolicy
from suspenv.runs.executors import executor_workers, make_executor
from suspenv.runs.loop import optimize
from suspenv.runs.run_dir import load_summary, read_only_row, run_directory, write_json
from suspenv.runs.versions import package_versions

#: seconds of drawing after which the figure progress is printed to stderr
PROGRESS_AFTER_S = 2.0


class FigureProgress:
    """Prints what is being drawn to ``stream`` once drawing has taken more than
    ``after_s`` seconds (a timer prints the current step then; later steps at once)."""

    def __init__(self, after_s: float | None = None, stream: Any = None, on: bool = True):
        after_s = PROGRESS_AFTER_S if after_s is None else after_s
        self.after_s, self.on = after_s, on
        self.stream = stream if stream is not None else sys.stderr
        self.t0 = time.perf_counter()
        self.current = ""
        self.shown = False
        self._lock = threading.Lock()
        self._timer: threading.Timer | None = None
        if on:
            self._timer = threading.Timer(after_s, self._late)
            self._timer.daemon = True
            self._timer.start()

    def _print(self, text: str) -> None:
        elapsed = time.perf_counter() - self.t0
        print(f"suspenv: drawing {text} [{elapsed:.0f} s]", file=self.stream, flush=True)

    def _late(self) -> None:
        with self._lock:
            if self.current and not self.shown:
                self.shown = True
                self._print(self.current)

    def __call__(self, text: str) -> None:
        with self._lock:
            self.current = text
            if self.on and (self.shown or time.perf_counter() - self.t0 > self.after_s):
                self.shown = True
                self._print(text)

    def close(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
        with self._lock:
            if self.shown:
                elapsed = time.perf_counter() - self.t0
                print(f"suspenv: figures done [{elapsed:.0f} s]", file=self.stream, flush=True)


def write_run_outputs(
    problem: Any, run_dir: Path, config: dict[str, Any], result: Any, strategy: Any
) -> dict[str, Any]:
    """Summary JSON, CSV export, figures and ``versions.json`` (every package that ran) of
    a finished run; returns the summary."""
    notes: list[str] = []
    with RunArchive(run_dir) as archive:
        arrays = archive.arrays()
        archive.to_csv(run_dir / "evaluations.csv")
        names = list(problem.objective_names)
        feasible = run_quality.feasible(arrays["ok"], arrays["constraints"])
        curve = run_quality.quality_curve(problem, arrays)
        figures: list[Path] = []
        progress = FigureProgress(on=bool(config["run"].get("progress", True)))
        try:
            if plots_wanted(config) and len(arrays["ok"]):
                write_figures = report_function("run_figures")
                figures += write_figures(
                    arrays["objectives"], feasible, names, run_dir, progress=progress, notes=notes
                )
            progress(f"the {problem.name} report")
            figures += problem.write_report(run_dir, archive)
        finally:
            progress.close()
        versions = package_versions(imported=True)
        archive.set_meta(versions=versions)
    write_json(run_dir / "versions.json", versions)
    summary = {
        "name": config["name"],
        "seed": config["seed"],
        "problem": problem.name,
        "problem_options": config["problem"].get("options", {}),
        "strategy": config["strategy"]["name"],
        "strategy_options": strategy.options() if hasattr(strategy, "options") else {},
        "budget": config["budget"],
        **result.as_dict(),
        "n_ok": int(arrays["ok"].sum()),
        "n_feasible": int(feasible.sum()),
        "objective_names": names,
        **_quality_items(problem, arrays, feasible, curve),
        "figures": [str(Path(f).name) for f in figures],
        "figure_notes": notes,
    }
    write_json(run_dir / "summary.json", summary)
    return summary


def _quality_items(
    problem: Any, arrays: dict[str, np.ndarray], feasible: np.ndarray, curve: np.ndarray | None
) -> dict[str, Any]:
    """The summary's "best" (:mod:`suspenv.runs.quality`): the best-so-far quality curve
    and its last finite value; for several objectives without a quality, the front size."""
    if curve is None:
        return {
            "quality_name": None,
            "best_quality": None,
            "quality_curve": None,
            "front_size": run_quality.front_size(arrays["objectives"], feasible),
        }
    return {"quality_name": problem.quality_name, **run_quality.curve_items(curve)}


def _toml_round_trip(options: dict[str, Any]) -> dict[str, Any] | None:
    """``options`` as written to ``config.resolved.toml`` and read back (None values are
    left out, as the writer does), or None when they cannot be written."""
    try:
        text = dump_toml({"options": options})
    except (TypeError, ValueError):
        return None
    out: dict[str, Any] = tomllib.loads(text).get("options", {})
    return out


def resolved_options(
    given: dict[str, Any],
    used: dict[str, Any],
    accepted: list[str] | None,
    rebuild: Callable[[dict[str, Any]], dict[str, Any]],
) -> dict[str, Any]:
    """``given`` with the defaults of ``used`` (what the built object reports: a problem's
    ``config()``, a strategy's ``options()``) filled in, where that round-trips.

    Rules: only keys the constructor accepts (``accepted``; None: any) and the given
    options do not name are added; None values are not written (None is every such
    default); the merged options go through TOML and back, and ``rebuild(options)`` (the
    rebuilt object's ``config()`` / ``options()``) must equal ``used``. When it does not,
    the defaults whose values differ are dropped and it is tried once more; failing
    that, the given options are returned unchanged."""
    defaults = {
        k: v
        for k, v in used.items()
        if k not in given and v is not None and (accepted is None or k in accepted)
    }
    if not defaults:
        return dict(given)
    for _ in range(2):
        merged = _toml_round_trip({**defaults, **given})
        if merged is None:
            return dict(given)
        try:
            again = rebuild(copy.deepcopy(merged))
        except (ValidationError, TypeError, ValueError):
            return dict(given)
        if _equal(again, used):
            return {k: merged[k] for k in [*given, *sorted(defaults)] if k in merged}
        defaults = {k: v for k, v in defaults.items() if _equal(again.get(k), used.get(k))}
    return dict(given)


def _equal(a: Any, b: Any) -> bool:
    """``a == b`` as a bool; False where the comparison has no single truth value."""
    try:
        return bool(a == b)
    except (ValueError, TypeError):
        return False


def _archived_run_id(config: dict[str, Any]) -> str | None:
    """The ``run_id`` in the meta of the run directory's archive, read-only (None when
    there is no archive or no id)."""
    db = run_directory(config) / RunArchive.FILENAME
    if not db.is_file():
        return None
    try:
        row = read_only_row(db, "SELECT value FROM meta WHERE key = 'run_id'")
    except sqlite3.Error:
        return None
    if row is None:
        return None
    value = json.loads(row[0])
    return value if isinstance(value, str) else None


def run_id_of(run_dir: Path) -> str:
    """The run directory's id (archive meta ``run_id``), made and stored when missing."""
    with RunArchive(run_dir) as archive:
        value = archive.meta().get("run_id")
        if not isinstance(value, str) or not value:
            value = uuid.uuid4().hex
            archive.set_meta(run_id=value)
    return value


def _build(config: dict[str, Any]) -> tuple[Any, Any]:
    """The config's problem and strategy, built with its options (each checks them)."""
    problem = make_problem(config["problem"]["name"], **config["problem"].get("options", {}))
    options = config["strategy"].get("options", {})
    return problem, make_strategy(config["strategy"]["name"], problem, config["seed"], **options)


def check_optimize_config(config: dict[str, Any]) -> dict[str, Any]:
    """Build the config's problem and strategy (every option checked by their constructors),
    check the strategy's storage (when it has one: read-only, see
    :meth:`suspenv.strategies.nsga2.NSGA2.check_storage`), fill ``run.timeout_s`` with the
    problem's own when the config leaves it out, and fill the problem and strategy options
    with every default they use (:func:`resolved_options`). ``config_path`` is left out, so
    that the ``config.resolved.toml`` written from the result reads back as a config.

    Runs before a run directory exists: a bad option leaves nothing behind."""
    pname, sname = config["problem"]["name"], config["strategy"]["name"]
    given_p = dict(config["problem"].get("options", {}))
    given_s = dict(config["strategy"].get("options", {}))
    problem, strategy = _build(config)
    check_storage = getattr(strategy, "check_storage", None)
    if callable(check_storage):
        check_storage(_archived_run_id(config))
    # ``config_path`` (where the config was read from) is not a config key: kept in the
    # resolved config it would make config.resolved.toml unreadable as a config
    out = {k: v for k, v in config.items() if k != "config_path"}
    out["run"] = dict(config["run"])
    out["run"]["timeout_s"] = FaultPolicy.for_run(config["run"], problem).timeout_s
    used_p = problem.config()
    out["problem"] = {
        **config["problem"],
        "options": resolved_options(
            given_p,
            used_p,
            option_names(problem_class(pname)),
            lambda o: make_problem(pname, **o).config(),
        ),
    }
    options = getattr(strategy, "options", None)
    if callable(options):
        out["strategy"] = {
            **config["strategy"],
            "options": resolved_options(
                given_s,
                options(),
                option_names(strategy_class(sname), STRATEGY_RESERVED),
                lambda o: make_strategy(sname, problem, seed=config["seed"], **o).options(),
            ),
        }
    return out


def _check_summary(run_dir: Path) -> None:
    """Before a resume: the archive holds at least the evaluations that the run's
    ``summary.json`` counts (an archive emptied or replaced beside it would otherwise be
    evaluated again silently); a damaged summary is named."""
    if not (run_dir / "summary.json").is_file():
        return
    summary = load_summary(run_dir)
    with RunArchive(run_dir) as archive:
        archive.check_count(summary.get("n_evaluations"), str(run_dir / "summary.json"))


def run_optimize_pipeline(config: dict[str, Any], run_dir: Path) -> dict[str, Any]:
    """Run the config's strategy on its problem; write every output into ``run_dir``."""
    problem, strategy = _build(config)
    _check_summary(run_dir)
    bind_problem = getattr(strategy, "bind_problem", None)
    if callable(bind_problem):  # names a live study (optuna) after the problem
        bind_problem(problem)
    bind_run = getattr(strategy, "bind_run", None)
    if callable(bind_run):
        bind_run(run_id_of(run_dir))
    with make_executor(config["run"]) as executor:
        result = optimize(
            problem,
            strategy,
            config["budget"],
            run_dir=run_dir,
            seed=config["seed"],
            executor=executor,
            workers=executor_workers(config["run"]),
            chunk_size=config["run"].get("chunk_size"),
            progress=config["run"].get("progress", True),
            meta={"config": config},
            faults=FaultPolicy.for_run(config["run"], problem),
        )
    return write_run_outputs(problem, run_dir, config, result, strategy)
