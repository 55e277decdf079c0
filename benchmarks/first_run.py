"""First run of a fresh install: CPU until the first K&C evaluation, and ``import suspenv``.

The repository is built into a wheel (as ``pip install .`` does: an isolated build
environment, ``setup.py`` compiling the loops of ``suspenv.core.compiled.AHEAD`` ahead of
time), installed into a new virtual environment (suspenv's dependencies are taken from
this environment through a ``.pth`` file: nothing downloads) and run from an empty
folder with an empty numba cache folder (``NUMBA_CACHE_DIR``): the state of a fresh
install. Measured there, in separate processes, for both ways of getting the compiled
loops in the same run:

* ``built``: the install's loops (``suspenv.core._kernels``);
* ``jit`` (the baseline: last round's only way): ``SUSPENV_COMPILED=jit``, every loop
  compiled by numba at its first call.

First evaluation: the process CPU time (user + system, from the interpreter's start)
until ``make_problem("KCIdentification")`` and the evaluation of one random design have
returned, i.e. everything a newcomer waits for; the second evaluation's CPU is beside it.
Import: the process CPU time from the interpreter's start until ``import suspenv`` has
returned (best of the built runs), and beside it ``python -X importtime -c "import
suspenv"``'s cumulative time of ``suspenv`` (wall time, which a loaded machine inflates;
best of five). Targets: first evaluation <= 3 s CPU, import <= 0.5 s CPU.

Run: ``python -m benchmarks.first_run [--repeats N]``; writes
``docs/benchmarks/first_run.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path
from typing import Any

from benchmarks.common import write_result

FIRST_TARGET_S = 3.0
IMPORT_TARGET_S = 0.5
ROOT = Path(__file__).resolve().parents[1]

#: run in the fresh install: CPU seconds since the interpreter's start at each step
CHILD = """
import json, time
import numpy as np
import suspenv
t_import = time.process_time()
p = suspenv.make_problem("KCIdentification")
x = p.space.to_physical(np.random.default_rng(0).random((1, p.space.dim)))
ok = bool(p.evaluate(x).ok.all())
t_first = time.process_time()
p.evaluate(x)
print(json.dumps({"import_s": t_import, "first_s": t_first,
                  "second_s": time.process_time() - t_first, "ok": ok}))
"""


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _env(**extra: str) -> dict[str, str]:
    """This environment without ``PYTHONPATH`` (the fresh install must see only itself)."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "SUSPENV_COMPILED")}
    return {**env, **extra}


def _install(tmp: Path) -> tuple[Path, float]:
    """A fresh virtual environment with suspenv installed from a wheel of the repository;
    returns its python and the CPU seconds of building the wheel."""
    cpu = _children_cpu()
    wheels = tmp / "wheels"
    pip = [sys.executable, "-m", "pip", "--quiet", "--disable-pip-version-check"]
    subprocess.run([*pip, "wheel", "--no-deps", "-w", str(wheels), str(ROOT)], check=True)
    build_cpu = _children_cpu() - cpu
    subprocess.run([sys.executable, "-m", "venv", str(tmp / "venv")], check=True)
    python = tmp / "venv" / "bin" / "python"
    site = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        check=True, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    wheel = next(wheels.glob("suspenv-*.whl"))
    subprocess.run([python, *pip[1:], "install", "--no-deps", str(wheel)], check=True, env=_env())
    # after the install (pip would take this environment's suspenv for installed)
    Path(site, "suspenv_deps.pth").write_text(sysconfig.get_path("purelib") + "\n")
    return python, build_cpu


def _run(python: Path, tmp: Path, mode: str, run: int) -> dict[str, Any]:
    """One cold first run in a process of its own (empty numba cache folder)."""
    env = _env(NUMBA_CACHE_DIR=str(tmp / f"numba-{mode}-{run}"))
    if mode == "jit":
        env["SUSPENV_COMPILED"] = "jit"
    done = subprocess.run([python, "-c", CHILD], cwd=tmp, env=env, capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"the first run ({mode}) failed:\n{done.stderr}")
    return {"mode": mode, "run": run, **json.loads(done.stdout.splitlines()[-1])}


def _import_time(python: Path, tmp: Path) -> float:
    """``import suspenv``'s cumulative seconds under ``-X importtime``."""
    err = subprocess.run(
        [python, "-X", "importtime", "-c", "import suspenv"],
        cwd=tmp, env=_env(), check=True, capture_output=True, text=True,
    ).stderr  # fmt: skip
    line = next(ln for ln in reversed(err.splitlines()) if ln.rstrip().endswith("| suspenv"))
    return int(line.split("|")[1]) / 1e6


def summary_import(rows: list[dict[str, Any]]) -> float:
    """CPU seconds from the interpreter's start to ``import suspenv`` done (built runs)."""
    return min(r["import_s"] for r in rows if r["mode"] == "built")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2, help="cold runs per mode")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="suspenv-first-run-") as name:
        tmp = Path(name)
        python, build_cpu = _install(tmp)
        rows = [_run(python, tmp, m, r) for r in range(args.repeats) for m in ("built", "jit")]
        imports = [_import_time(python, tmp) for _ in range(5)]
    first = {m: min(r["first_s"] for r in rows if r["mode"] == m) for m in ("built", "jit")}
    summary = {
        "first_evaluation_cpu_s": first["built"],
        "first_evaluation_cpu_s_jit": first["jit"],
        "ratio_jit_over_built": first["jit"] / first["built"],
        "import_suspenv_cpu_s": summary_import(rows),
        "import_suspenv_importtime_s": min(imports),
        "wheel_build_cpu_s": build_cpu,
        "first_target_s": FIRST_TARGET_S,
        "import_target_s": IMPORT_TARGET_S,
        "meets_first_target": bool(first["built"] <= FIRST_TARGET_S),
        "meets_import_target": bool(summary_import(rows) <= IMPORT_TARGET_S),
        "all_ok": all(r["ok"] for r in rows),
    }
    command = "python -m benchmarks.first_run" + (
        f" --repeats {args.repeats}" if args.repeats != 2 else ""
    )
    write_result("first_run", rows, summary, command, output_dir=args.output_dir)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
