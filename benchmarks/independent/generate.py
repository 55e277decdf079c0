"""Command line: ``python -m benchmarks.independent.generate --out DIR --seeds 5000-5009``.

Options: ``--families damper,mr_damper,friction_guide,quarter_car_rig`` (default all),
``--jobs N`` worker processes (default 1), ``--overwrite`` to write into a non-empty
``DIR`` (its ``cases/*.npz``, ``truth/*.json`` and ``manifest.json`` are replaced). Prints
one progress line per case. Every case is determined by its seed, family and kind.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from benchmarks.independent.cases import FAMILIES, CaseSpec, make_case, plan
from benchmarks.independent.export import write_case, write_manifest


def parse_seeds(text: str) -> list[int]:
    """``"5000-5009"``, ``"1,2,5"`` or a mix (``"1-3,7"``) -> sorted unique seeds (>= 0)."""
    seeds: set[int] = set()
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        lo, _, hi = part.partition("-")
        a, b = int(lo), int(hi or lo)
        if b < a:
            raise ValueError(f"seed range {part!r} runs backwards")
        seeds.update(range(a, b + 1))
    if not seeds:
        raise ValueError(f"no seeds in {text!r}")
    return sorted(seeds)


def _one(spec: CaseSpec, out: Path) -> tuple[str, float, int]:
    start = time.perf_counter()
    case = make_case(spec)
    write_case(case, out)
    return spec.case_id, time.perf_counter() - start, int(case.time.size)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--seeds", required=True)
    ap.add_argument("--families", default=",".join(FAMILIES))
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args(argv)
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError as exc:
        ap.error(str(exc))
    families = [f.strip() for f in args.families.split(",") if f.strip()]
    bad = [f for f in families if f not in FAMILIES]
    if bad or not families:
        ap.error(f"unknown families {bad}; families are {list(FAMILIES)}")
    out: Path = args.out
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        if not args.overwrite:
            print(
                f"{out} exists and is not empty; pass --overwrite to write into it", file=sys.stderr
            )
            return 2
        for sub, pattern in (("cases", "*.npz"), ("truth", "*.json")):
            for old in (out / sub).glob(pattern):
                old.unlink()
    out.mkdir(parents=True, exist_ok=True)
    specs = [s for seed in seeds for fam in families for s in plan(fam, seed)]
    ids = [s.case_id for s in specs]
    start = time.perf_counter()
    n = len(specs)
    if args.jobs <= 1:
        results = (_one(s, out) for s in specs)
        for i, (cid, sec, size) in enumerate(results, 1):
            print(f"[{i}/{n}] {cid}: {size} samples, {sec:.1f} s", flush=True)
    else:
        with ProcessPoolExecutor(args.jobs) as pool:
            futures = [pool.submit(_one, s, out) for s in specs]
            for i, fut in enumerate(futures, 1):
                cid, sec, size = fut.result()
                print(f"[{i}/{n}] {cid}: {size} samples, {sec:.1f} s", flush=True)
    write_manifest(out, ids, seeds, families)
    print(f"{n} cases in {time.perf_counter() - start:.1f} s -> {out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
