"""``benchmarks.minibus_ride_effects``' reuse of its stored long-run references: the
arrays it rebuilds from a stored result's rows are the rows' values (golden), and a
stored result that lacks a cell is refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import minibus_ride_effects as bench
from suspenv.models.minibus.vehicle import LOAD_CASES


def _stored(names: list[str]) -> dict:
    """A stored result whose every value encodes its cell (effect set, design, load
    case, end)."""
    rows = []
    for s, scen in enumerate(bench.SCENARIOS):
        for d, name in enumerate(names):
            for c, case in enumerate(LOAD_CASES):
                for e, end in enumerate(("front", "rear")):
                    code = 1000 * s + 100 * d + 10 * c + e
                    rows.append(
                        {
                            "effects": scen,
                            "design": name,
                            "load_case": case,
                            "end": end,
                            "time_120s": float(code),
                            "time_se_percent": code + 0.25,
                            "time_se_independent_records_percent": code + 0.5,
                        }
                    )
    return {"summary": {"pairs_per_value": 16}, "rows": rows}


def test_stored_runs_rebuild_the_long_runs_arrays():
    """Row i of the design x load case axis is design ``i % n`` of load case ``i // n``,
    ends front then rear (as :func:`long_runs` returns them)."""
    names = ["a", "b", "c"]
    runs = bench.stored_runs(_stored(names), names)
    assert list(runs) == list(bench.SCENARIOS)
    for s, scen in enumerate(bench.SCENARIOS):
        td, se, se_single = runs[scen]
        for e in range(2):
            for i in range(6):
                code = 1000 * s + 100 * (i % 3) + 10 * (i // 3) + e
                assert (td[e, i], se[e, i], se_single[e, i]) == (code, code + 0.25, code + 0.5)
    assert np.all(np.diff(runs["none"][0][0]) != 0)


def test_stored_runs_refuse_a_missing_cell():
    stored = _stored(["a", "b"])
    stored["rows"] = stored["rows"][1:]
    with pytest.raises(ValueError, match="every cell"):
        bench.stored_runs(stored, ["a", "b"])


def test_stored_runs_leave_out_a_set_the_file_lacks():
    """A set without stored rows (added after the file was written) is left to be run."""
    names = ["a", "b"]
    stored = _stored(names)
    stored["rows"] = [r for r in stored["rows"] if r["effects"] != "leaf_friction_600N"]
    kept = [s for s in bench.SCENARIOS if s != "leaf_friction_600N"]
    assert list(bench.stored_runs(stored, names)) == kept


def test_dahl_moments_are_wens_for_a_gaussian_force():
    """Zero-mean jointly Gaussian (v, z): kurtosis 3 and Wen's coefficients (Stein's
    lemma), within the sampling error of 400,000 samples (kurtosis SD sqrt(24/N) =
    0.008); a uniform force has kurtosis 9/5."""
    rng = np.random.default_rng(0)
    v, w = rng.standard_normal((2, 400_000))
    z = 300.0 * (0.45 * v + np.sqrt(1.0 - 0.45**2) * w)
    kurtosis, a, b = bench.dahl_moments(0.1 * v, z)
    assert abs(kurtosis - 3.0) < 0.05 and abs(a - 1.0) < 0.02 and abs(b - 1.0) < 0.02
    uniform = bench.dahl_moments(0.1 * v, 600.0 * (2.0 * rng.random(v.size) - 1.0))
    assert abs(uniform[0] - 1.8) < 0.01
