"""The compiled objectives of swept states (``suspenv.metrics.knc_kernel``, the
identification problem's path) against the numpy path.

Reference: the same problem with its compiled path off (``_compiled_path`` False): the
same compiled sweep's states through the rig's channels
(:meth:`AxleSolver.outputs`) and :func:`suspenv.metrics.knc.objectives`. Both apply the
same formulas in the same order to the same states; they differ only by the rounding of
the elementary functions (atan2, asin, atan: within an ulp each) and of the 3 x 3
products (BLAS may fuse them), a few ulps of the channels, which the fits' difference
quotients over the +-3-point window amplify by at most the ratio of a channel to its
differences (under 1e4 here). Hence a relative tolerance of 1e-10 of each objective's
largest size over the designs (the observed differences are about 1e-14).
"""

from __future__ import annotations

import numpy as np
import pytest

import suspenv.models.mcpherson.solver as solver_module
import suspenv.rigs.knc as rig_module
from suspenv.metrics.knc import OBJECTIVES
from suspenv.metrics.knc_kernel import CURVES, objective_table
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import TESTS

pytestmark = pytest.mark.skipif(not rig_module.compiled.AVAILABLE, reason="numba missing")


@pytest.fixture(scope="module")
def problem():
    return KCIdentification()


@pytest.fixture(scope="module")
def designs(problem):
    rng = np.random.default_rng(11)
    X = problem.space.to_physical(rng.random((12, problem.space.dim)))
    return np.vstack([problem.initial_design(), problem.truth_design(), X])


def _both(problem, X, monkeypatch):
    assert problem._compiled_path()
    compiled = problem.simulate(X)
    monkeypatch.setattr(KCIdentification, "_compiled_path", lambda self: False)
    reference = problem.simulate(X)
    monkeypatch.undo()
    return compiled, reference


@pytest.mark.parametrize("batch", [1, 14])
def test_compiled_objectives_are_the_numpy_paths(problem, designs, batch, monkeypatch):
    assert problem._compiled_path()
    F = np.vstack(
        [problem.simulate(designs[a : a + batch])[0] for a in range(0, len(designs), batch)]
    )
    monkeypatch.setattr(KCIdentification, "_compiled_path", lambda self: False)
    ref, ok, _ = problem.simulate(designs)
    assert ok.all() and np.isfinite(F).all()
    scale = np.abs(ref).max(axis=0)
    assert (np.abs(F - ref) <= 1e-10 * scale).all(), np.abs(F - ref).max(axis=0) / scale


def test_flagged_designs_are_evaluated_and_worded_by_the_rig(problem, designs, monkeypatch):
    # lock-up limits every design exceeds at the bump end: the compiled sweep flags
    # each, which the rig's path then evaluates and words
    monkeypatch.setattr(solver_module, "MAX_TRANSLATION", 1e-5)
    (F, ok, msgs), (F_ref, ok_ref, msgs_ref) = _both(problem, designs[:3], monkeypatch)
    assert not ok_ref.any() and "LockupError" in msgs_ref[0]
    assert np.array_equal(ok, ok_ref) and msgs == msgs_ref
    assert np.isnan(F).all() and np.isnan(F_ref).all()


def test_the_table_names_every_objectives_curves():
    table = objective_table(OBJECTIVES, TESTS)
    for o, (t, c, x, pick, single) in zip(OBJECTIVES, table, strict=True):
        assert (TESTS[t], CURVES[c], CURVES[x]) == (o.test, o.curve, o.x)
        assert single == (o.test == "single")
        assert pick == {"value": 0, "gradient": 1, "rate": 1, "rate_gradient": 2}[o.reduce]
