"""Export a run directory to an optuna storage that optuna-dashboard reads, with names.

``suspenv export optuna RUN_DIR --storage sqlite:///runs.db [--study NAME]`` (or
:func:`export_optuna`) writes every archived evaluation of the run as one trial of a new
study, in evaluation order (trial number = evaluation index):

* Parameters: the physical design values under the problem's parameter names, each with
  ``FloatDistribution(low, high, log)`` of its design-space bounds. The bounds come from
  the problem the run's resolved config names, rebuilt with its options
  (:func:`suspenv.registry.make_problem`); its parameter names must equal the archive's.
  When the problem cannot be rebuilt (an archive without a config, an unregistered
  problem) the bounds are each parameter's observed range, and the study's user attribute
  ``bounds`` says ``"observed"`` (else ``"design space"``). Values are clipped into the
  bounds only for float rounding (at most 1e-9 of the range; farther is an error).
* Objectives: the values of each evaluation, every direction "minimize"; their names by
  ``study.set_metric_names``, their units (where the problem has them) in the study's
  user attribute ``objective_units``.
* States: an evaluation that succeeded with finite objectives is ``COMPLETE``; any other
  is ``FAIL`` (no values; the message in the trial's user attribute ``message``).
* Constraints (feasible when <= 0): the system attribute ``"constraints"``, a list of the
  k values in the order of the study's user attribute ``constraint_names`` — the format
  optuna's samplers and optuna-dashboard read (optuna 5 reads it as constraints ``"0"``,
  ``"1"``, ...). Failed trials have none.
* Study user attributes: ``run`` (name), ``run_dir``, ``seed``, ``problem``,
  ``problem_options``, ``strategy``, ``strategy_options``, ``budget``, ``suspenv_version``,
  ``suspenv_commit`` (when recorded), ``parameter_units``, ``objective_names``,
  ``objective_units``, ``constraint_names``, ``bounds``. Trial user attributes: ``batch``,
  ``row``, ``wall_time_s``, and ``message`` when failed.

A study of that name already in the storage is refused (a ValidationError naming the
storage and the study) unless ``replace=True``, which deletes it first. A storage given as
a plain file path means SQLite (``runs.db`` -> ``sqlite:///runs.db``). Before anything is
written, :func:`check_storage` connects to it: a URL that does not parse, an unknown
database kind, a driver that is not installed, a database that cannot be opened, an
in-memory SQLite database, the run's own archive and any database that holds tables but
is not an optuna storage are each a ValidationError naming the URL and the rule.

Cost: optuna's RDB storage writes one trial in 15-25 ms to SQLite (its ORM, row by row,
measured here), so a 3,000-evaluation run takes about a minute and 30,000 about ten; the
command shows a progress bar.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import text
from suspenv.registry import make_problem
from suspenv.runs.archive import RunArchive

#: relative distance (of the range) beyond a bound still taken as float rounding
BOUND_TOLERANCE = 1e-9
#: trials written per call of optuna's ``add_trials`` (progress is reported per block)
BLOCK = 250


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote."""

    storage: str
    study_name: str
    n_trials: int
    n_complete: int
    n_failed: int
    bounds: str  # "design space" or "observed"


def storage_url(storage: str) -> str:
    """``storage`` as an optuna storage URL: a plain path means SQLite."""
    text("optuna export", "storage", storage)
    return storage if "://" in storage else f"sqlite:///{storage}"


#: tables every optuna RDB storage has (a database with other tables only is not one)
OPTUNA_TABLES = {"studies", "version_info"}
#: pip package of each SQLAlchemy driver module that a URL may need
DRIVERS = {"psycopg2": "psycopg2-binary", "psycopg": "psycopg[binary]", "MySQLdb": "mysqlclient"}


def check_storage(url: str, run_dir: Path) -> None:
    """Refuse a storage that optuna cannot use, or must not write to (see the module
    docstring); connects once, writes nothing."""
    import sqlalchemy
    from sqlalchemy.engine import make_url

    rule = f"optuna export: --storage {url!r}"
    try:  # optuna fills the URL as a str.format template ({SCHEMA_VERSION})
        url.format(SCHEMA_VERSION=0)
    except (ValueError, LookupError, AttributeError) as exc:
        raise ValidationError(
            f"{rule} has braces that are not a template field ({exc}); optuna reads "
            "`{` and `}` as one, so write them `{{` and `}}`"
        ) from None
    try:
        parsed = make_url(url)
        engine = sqlalchemy.create_engine(parsed)
    except sqlalchemy.exc.NoSuchModuleError:
        raise ValidationError(
            f"{rule} names an unknown kind of database {url.split(':')[0]!r} (or driver); give "
            "sqlite:///FILE, postgresql://..., mysql://... or a file path"
        ) from None
    except (sqlalchemy.exc.ArgumentError, ValueError) as exc:
        raise ValidationError(f"{rule} is not a database URL ({exc})") from None
    except ImportError as exc:
        module = getattr(exc, "name", None) or str(exc)
        raise ValidationError(
            f"{rule} needs the database driver {module!r}, which is not installed: "
            f"pip install {DRIVERS.get(str(module), module)}"
        ) from None
    if parsed.get_backend_name() == "sqlite":
        _check_sqlite_file(parsed.database, run_dir, rule)
    try:
        with engine.connect() as con:
            tables = set(sqlalchemy.inspect(con).get_table_names())
    except sqlalchemy.exc.SQLAlchemyError as exc:
        reason = str(getattr(exc, "orig", None) or exc).splitlines()[0]
        raise ValidationError(f"{rule} cannot be opened ({reason})") from None
    finally:
        engine.dispose()
    if tables and not tables >= OPTUNA_TABLES:
        raise ValidationError(
            f"{rule} holds tables ({', '.join(sorted(tables)[:5])}) but is not an optuna "
            "storage; give a new file or an existing optuna storage"
        )


def _check_sqlite_file(database: str | None, run_dir: Path, rule: str) -> None:
    """An SQLite storage is a file, and not the run's own archive."""
    if not database or database == ":memory:" or database.startswith("file::memory:"):
        raise ValidationError(
            f"{rule} is an in-memory database: the study would be lost when the command "
            "ends; give a file (sqlite:///runs.db)"
        )
    own = (run_dir / RunArchive.FILENAME).resolve()
    if Path(database).resolve() == own:
        raise ValidationError(
            f"{rule} is the run's own archive {str(own)!r}, which is append-only: give "
            "another file (sqlite:///runs.db)"
        )


def _problem_of(meta: dict[str, Any]) -> Any | None:
    """The run's problem rebuilt from its resolved config (None when it cannot be, or when
    its parameter names differ from the archive's)."""
    config: dict[str, Any] = meta["config"] if isinstance(meta.get("config"), dict) else {}
    table = config.get("problem", {}) if isinstance(config.get("problem"), dict) else {}
    name = table.get("name", meta.get("problem"))
    options = table.get("options", {}) if isinstance(table.get("options"), dict) else {}
    try:
        problem = make_problem(str(name), **options)
    except (ValidationError, ImportError, TypeError):
        return None
    if list(problem.space.names) != list(meta.get("parameter_names", [])):
        return None
    return problem


def _bounds(problem: Any | None, X: np.ndarray) -> list[tuple[float, float, bool]]:
    """(low, high, log) per parameter: the design space's, else the observed ranges."""
    if problem is not None:
        return [(p.low, p.high, p.log) for p in problem.space.parameters]
    out = []
    for j in range(X.shape[1]):
        col = X[np.isfinite(X[:, j]), j]
        lo, hi = (float(col.min()), float(col.max())) if col.size else (0.0, 1.0)
        out.append((lo, hi if hi > lo else lo + 1.0, False))
    return out


def _inside(x: float, low: float, high: float, name: str) -> float:
    tol = BOUND_TOLERANCE * (high - low)
    if not low - tol <= x <= high + tol:
        raise ValidationError(
            f"optuna export: parameter {name!r} = {x!r} is outside its bounds [{low!r}, {high!r}]"
        )
    return min(max(x, low), high)


def _study_attrs(
    meta: dict[str, Any], run_dir: Path, objectives: list[str], units: list[str], bounds: str
) -> dict[str, Any]:
    """The study's user attributes (see the module docstring); None values left out."""
    config: dict[str, Any] = meta["config"] if isinstance(meta.get("config"), dict) else {}
    versions = meta.get("versions") or {}
    attrs: dict[str, Any] = {
        "run": config.get("name", run_dir.name),
        "run_dir": str(run_dir.resolve()),
        "seed": meta.get("seed", config.get("seed")),
        "problem": meta.get("problem"),
        "problem_options": config.get("problem", {}).get("options", {}),
        "strategy": meta.get("strategy"),
        "strategy_options": config.get("strategy", {}).get("options", {}),
        "budget": meta.get("budget"),
        "suspenv_version": versions.get("suspenv"),
        "suspenv_commit": versions.get("suspenv_commit"),
        "parameter_units": list(meta.get("parameter_units") or []),
        "objective_names": objectives,
        "objective_units": units,
        "constraint_names": list(meta.get("constraint_names") or []),
        "bounds": bounds,
    }
    return {k: v for k, v in attrs.items() if v is not None}


def _new_study(url: str, name: str, replace: bool, objective_names: list[str]) -> Any:
    """An empty optuna study ``name`` in ``url`` minimising the named objectives; a study
    of that name already there is refused unless ``replace``."""
    import optuna

    from suspenv.strategies.nsga2 import quiet

    optuna.logging.set_verbosity(logging.WARNING)
    exists = any(s.study_name == name for s in optuna.get_all_study_summaries(url))
    if exists and not replace:
        raise ValidationError(
            f"optuna export: the storage {url!r} already holds a study {name!r}; give "
            "another name (--study NAME) or replace it (--replace)"
        )
    if exists:
        optuna.delete_study(study_name=name, storage=url)
    study = optuna.create_study(
        storage=url, study_name=name, directions=["minimize"] * len(objective_names)
    )
    with quiet():  # set_metric_names is "experimental" in optuna 3.2-5
        study.set_metric_names(objective_names)
    return study


def _trial(a: dict[str, np.ndarray], i: int, dists: dict[str, Any], constrained: bool) -> Any:
    """Evaluation ``i`` of the archive ``a`` as an optuna trial: COMPLETE with its values
    (and constraints when ``constrained``) when it succeeded with finite objectives, else
    FAIL with its message."""
    import optuna
    from optuna.trial import TrialState

    params = {
        p: _inside(float(a["x"][i, j]), d.low, d.high, p) for j, (p, d) in enumerate(dists.items())
    }
    f = a["objectives"][i]
    ok = bool(a["ok"][i]) and bool(np.isfinite(f).all())
    user: dict[str, Any] = {
        "batch": int(a["batch"][i]),
        "row": int(a["row"][i]),
        "wall_time_s": float(a["wall_time"][i]) if np.isfinite(a["wall_time"][i]) else None,
    }
    system: dict[str, Any] = {}
    if ok and constrained:
        system["constraints"] = [float(g) for g in a["constraints"][i]]
    if not ok:
        user["message"] = str(a["message"][i]) or "non-finite objective"
    return optuna.trial.create_trial(
        state=TrialState.COMPLETE if ok else TrialState.FAIL,
        values=[float(v) for v in f] if ok else None,
        params=params,
        distributions=dists,
        user_attrs={k: v for k, v in user.items() if v is not None},
        system_attrs=system,
    )


def export_optuna(
    run_dir: str | Path,
    storage: str,
    study_name: str | None = None,
    replace: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> ExportResult:
    """Write every evaluation archived in ``run_dir`` to ``storage`` as study
    ``study_name`` (default: the run directory's name); see the module docstring.

    ``progress(done, total)`` is called after each block of :data:`BLOCK` trials (optuna
    writes a trial in about 20 ms to SQLite: 30,000 evaluations take minutes)."""
    from optuna.distributions import FloatDistribution
    from optuna.trial import TrialState

    run_dir = Path(run_dir)
    if not (run_dir / RunArchive.FILENAME).is_file():
        raise ValidationError(f"{str(run_dir)!r} is not a run directory (no {RunArchive.FILENAME})")
    url = storage_url(storage)
    check_storage(url, run_dir)
    with RunArchive(run_dir) as archive:
        meta = archive.meta()
        a = archive.arrays()
    name = study_name if study_name is not None else run_dir.resolve().name
    text("optuna export", "study_name", name)
    pnames = list(meta.get("parameter_names") or [f"x{j}" for j in range(a["x"].shape[1])])
    onames = list(meta.get("objective_names") or [f"f{j}" for j in range(a["objectives"].shape[1])])
    problem = _problem_of(meta)
    bounds = _bounds(problem, a["x"])
    source = "design space" if problem is not None else "observed"
    units = list(getattr(problem, "objective_units", ()) or ())
    units = units if len(units) == len(onames) else []

    dists = {
        p: FloatDistribution(lo, hi, log=log)
        for p, (lo, hi, log) in zip(pnames, bounds, strict=True)
    }

    study = _new_study(url, name, replace, onames)
    for key, value in _study_attrs(meta, run_dir, onames, units, source).items():
        study.set_user_attr(key, value)
    constrained = bool(meta.get("constraint_names"))
    trials = [_trial(a, i, dists, constrained) for i in range(len(a["ok"]))]
    for start in range(0, len(trials), BLOCK):
        study.add_trials(trials[start : start + BLOCK])
        if progress is not None:
            progress(min(start + BLOCK, len(trials)), len(trials))
    complete = sum(t.state == TrialState.COMPLETE for t in trials)
    return ExportResult(url, name, len(trials), complete, len(trials) - complete, source)
