"""Helpers shared by the benchmark scripts: timing, a plain table, JSON with machine facts."""

from __future__ import annotations

import json
import os
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: committed benchmark results live here (relative to the repository root)
DEFAULT_OUTPUT_DIR = Path("docs") / "benchmarks"


def best_time(fn: Callable[[], Any], repeat: int = 5, number: int = 1) -> float:
    """Best wall time in seconds of ``number`` calls of ``fn`` over ``repeat`` trials."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def machine_info() -> dict[str, Any]:
    """Facts that make a benchmark number interpretable."""
    from suspenv.runs.versions import package_versions

    return {
        "python": platform.python_version(),
        "machine": platform.machine(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "packages": package_versions(),
        "timestamp": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """A plain-text table; floats get 4 significant digits."""
    if not rows:
        return "(no rows)"
    cols = list(rows[0])

    def fmt(v: Any) -> str:
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    cells = [[fmt(r.get(c, "")) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(cols, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(v.ljust(w) for v, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(lines)


def write_result(
    name: str,
    rows: Sequence[dict[str, Any]],
    summary: dict[str, Any],
    command: str,
    output_dir: Path | str | None = None,
) -> Path:
    """Print the table and write ``<output_dir>/<name>.json``; returns the path."""
    out = Path(output_dir) if output_dir else DEFAULT_OUTPUT_DIR
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name}.json"
    payload = {
        "benchmark": name,
        "command": command,
        "summary": summary,
        "rows": list(rows),
        "machine": machine_info(),
    }
    path.write_text(json.dumps(payload, indent=2, default=float) + "\n")
    print(format_table(rows))
    for k, v in summary.items():
        print(f"{k}: {v:.4g}" if isinstance(v, float) else f"{k}: {v}")
    print(f"wrote {path}")
    return path


def wall_and_cpu(fn: Callable[[], Any]) -> tuple[float, float]:
    """(wall, CPU) seconds of one call. CPU time is the per-core figure on a loaded machine."""
    w0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w0, time.process_time() - c0


@dataclass
class BatchTiming:
    """Per-candidate times of a batched evaluation and of one-at-a-time evaluation, in ms."""

    batch: int
    repeats: int
    singles: int
    batched_cpu_ms: float
    batched_wall_ms: float
    single_cpu_ms: float
    single_wall_ms: float
    valid: int

    @property
    def gain(self) -> float:
        """How many times faster per candidate the batch is (CPU)."""
        return self.single_cpu_ms / self.batched_cpu_ms

    def rows(self, batch_label: str, single_label: str) -> list[dict[str, Any]]:
        return [
            {
                "mode": batch_label,
                "cpu_ms_per_candidate": self.batched_cpu_ms,
                "wall_ms_per_candidate": self.batched_wall_ms,
                "repeats": self.repeats,
            },
            {
                "mode": single_label,
                "cpu_ms_per_candidate": self.single_cpu_ms,
                "wall_ms_per_candidate": self.single_wall_ms,
                "repeats": self.singles,
            },
        ]
