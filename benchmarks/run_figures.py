"""Benchmark: the default run figures of a many-objective run (time, peak memory, pixels).

Reported: a default ``optimize`` run on the 40-objective KCIdentification problem spent
94 s and 1.6 GB drawing a 10400 x 10400 px pair plot (5.4 s without plots). This script
draws ``write_run_figures`` (:mod:`suspenv.reports.run`) for synthetic objectives of that
shape — ``m`` objectives x ``n`` feasible evaluations, lognormal values times a per-column
unit scale 10^U(-4, 3) (mixed units, like the K&C mismatches), ``default_rng(0)`` — each
case in a fresh Python process, and records:

* ``seconds``: wall time of ``write_run_figures`` (after matplotlib is imported and has
  drawn one small figure, so import and font-cache time are not counted);
* ``peak_rss_mb`` / ``rss_increase_mb``: the process's peak resident memory
  (``resource.getrusage``) and its increase over the level before drawing (Agg's pixel
  buffers live outside Python's allocator, so ``tracemalloc`` would not see them);
* every figure's file name and size in pixels.

``--before PATH`` also measures another implementation of ``write_run_figures`` (a .py
file, e.g. the previous one: ``git show 364eb8b:suspenv/reports/run.py > /tmp/before.py``)
on the main case. Run: ``python -m benchmarks.run_figures [--before PATH]``; writes
``docs/benchmarks/run_figures.json``.
"""

from __future__ import annotations

import argparse
import json
import resource
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.common import write_result

#: (objectives, evaluations) of the cases; the first is the reported one
CASES = ((40, 2500), (40, 20000), (5, 2500))


def _png_size(path: Path) -> tuple[int, int]:
    with path.open("rb") as fh:
        head = fh.read(24)
    width, height = struct.unpack(">II", head[16:24])
    return int(width), int(height)


def _worker(module: str | None, m: int, n: int) -> dict[str, Any]:
    """One measurement in this process (called in a fresh one by :func:`measure`)."""
    import importlib.util

    import numpy as np

    from suspenv.reports._mpl import pyplot

    if module is None:
        from suspenv.reports import run as figures
    else:
        spec = importlib.util.spec_from_file_location("figures_under_test", module)
        assert spec is not None and spec.loader is not None
        figures = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(figures)
    rng = np.random.default_rng(0)
    F = rng.lognormal(0.0, 1.0, (n, m)) * 10.0 ** rng.uniform(-4, 3, m)
    feasible = np.ones(n, dtype=bool)
    if m == 40:
        from suspenv.metrics.knc import OBJECTIVE_NAMES

        names = list(OBJECTIVE_NAMES)
    else:
        names = [f"f{j}" for j in range(m)]
    plt = pyplot()  # warm up: import, fonts, one small drawing
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1])
    with tempfile.TemporaryDirectory() as tmp:
        fig.savefig(Path(tmp) / "warm.png")
        plt.close(fig)
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        t0 = time.perf_counter()
        paths = figures.write_run_figures(F, feasible, names, Path(tmp))
        seconds = time.perf_counter() - t0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        files = {Path(p).name: "x".join(map(str, _png_size(Path(p)))) for p in paths}
    scale = 1024.0 if sys.platform != "darwin" else 1024.0 * 1024.0  # ru_maxrss: KiB / B
    return {
        "seconds": seconds,
        "peak_rss_mb": peak / scale,
        "rss_increase_mb": (peak - before) / scale,
        "files": files,
    }


def measure(module: str | None, m: int, n: int) -> dict[str, Any]:
    """Measure ``write_run_figures`` of ``module`` (None: suspenv's) in a fresh process."""
    args = [sys.executable, "-m", "benchmarks.run_figures", "--worker", str(m), str(n)]
    if module is not None:
        args += ["--module", module]
    done = subprocess.run(args, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"figure worker failed:\n{done.stderr}")
    out: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", help="a .py file with the previous write_run_figures")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    parser.add_argument("--worker", nargs=2, type=int, help=argparse.SUPPRESS)
    parser.add_argument("--module", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(_worker(args.module, *args.worker)))
        return 0
    rows = []
    runs: list[tuple[str, str | None, int, int]] = []
    if args.before:
        runs.append(("before", args.before, *CASES[0]))
    runs += [("after", None, m, n) for m, n in CASES]
    for label, module, m, n in runs:
        r = measure(module, m, n)
        rows.append(
            {
                "version": label,
                "objectives": m,
                "evaluations": n,
                "seconds": round(r["seconds"], 2),
                "peak_rss_mb": round(r["peak_rss_mb"], 1),
                "rss_increase_mb": round(r["rss_increase_mb"], 1),
                "largest_px": max(r["files"].values(), key=lambda s: eval_px(s)),
                "files": r["files"],
            }
        )
        print(
            f"{label:6s} m={m:3d} n={n:6d}: {r['seconds']:7.2f} s, peak {r['peak_rss_mb']:7.1f} MB "
            f"(+{r['rss_increase_mb']:.1f}), {r['files']}",
            flush=True,
        )
    main_after = next(r for r in rows if r["version"] == "after")
    summary: dict[str, Any] = {
        "case": {"objectives": CASES[0][0], "evaluations": CASES[0][1]},
        "after_seconds": main_after["seconds"],
        "after_peak_rss_mb": main_after["peak_rss_mb"],
        "after_largest_px": main_after["largest_px"],
    }
    before = next((r for r in rows if r["version"] == "before"), None)
    if before is not None:
        summary.update(
            before_seconds=before["seconds"],
            before_peak_rss_mb=before["peak_rss_mb"],
            before_largest_px=before["largest_px"],
            before_module=args.before,
        )
    table = [{k: v for k, v in r.items() if k != "files"} for r in rows]
    write_result(
        "run_figures",
        table,
        summary,
        "python -m benchmarks.run_figures --before <previous reports/run.py>",
        args.output_dir,
    )
    return 0


def eval_px(size: str) -> int:
    """Pixels of a ``"WxH"`` string (to pick the largest figure)."""
    w, h = size.split("x")
    return int(w) * int(h)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
