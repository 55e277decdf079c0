"""The minibus study benchmark, end to end on a small study (slow: three runs of it)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmarks import minibus_study

SMALL_STUDY = """
description = "minibus study benchmark, small"
seed = 3
budget = 48

[problem]
name = "MinibusRideHandling"
options = {}

[strategy]
name = "pymoo_nsga2"
options = { population_size = 16, crossover_prob = 0.85 }

[run]
output = "runs"
workers = 2
progress = false
"""


@pytest.mark.slow
def test_the_benchmark_times_the_command_against_a_bare_loop_of_the_same_designs(
    tmp_path: Path,
) -> None:
    config = tmp_path / "small.toml"
    config.write_text(SMALL_STUDY)
    out = tmp_path / "bench"
    assert (
        minibus_study.main(["--repeat", "1", "--config", str(config), "--output-dir", str(out)])
        == 0
    )
    d = json.loads((out / "minibus_study.json").read_text())
    s = d["summary"]
    assert [r["way"] for r in d["rows"]] == list(minibus_study.WAYS)
    # the bare loop evaluated the very designs the command archived (same seed, same
    # operators): the baseline times the same work; and the pool changed no number
    assert s["bare_loop_same_designs"] is True
    assert s["same_numbers_1_and_2_workers"] is True
    assert s["study"]["evaluations"] == 48 and s["evaluations"] == 48
    assert 0 < s["loop_wall_s"] < s["command_wall_s"]
    assert s["rest_wall_s"] == pytest.approx(s["command_wall_s"] - s["loop_wall_s"])
    assert s["meets_target"] == (s["command_wall_s"] <= 60.0)
    assert not (tmp_path / "runs").exists()  # every run folder stayed in the benchmark's own
