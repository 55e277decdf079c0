"""The fast paths of the K&C evaluation against their reference paths.

* a path-independent model solves every grid point once, its bump and rebound legs side
  by side from the static state, and the return legs take the states of their grid
  points (``run_tests(reuse_revisits=True)``, the default) instead of solving every step
  of the loop one after the other (``reuse_revisits=False``): same channels to solver
  tolerance;
* a model with hysteresis or friction (path-dependent) always solves both legs;
* the problem's internal chunking and the batched objectives change nothing.
"""

from __future__ import annotations

import numpy as np
import pytest
from knc_checks import RTOL, channel_tolerance

from suspenv.metrics.knc import _objectives_one_by_one, objectives
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
from suspenv.problems.kc_identification import KCIdentification
from suspenv.rigs.knc import TESTS, run_tests


@pytest.fixture(scope="module")
def axles():
    rng = np.random.default_rng(3)
    problem = KCIdentification()
    X = np.vstack([reference_design(), problem.space.to_physical(rng.random((3, 49)))])
    return build_axle(X)


def test_path_independent_model_is_detected_from_its_elements(axles):
    assert not AxleSolver(axles).path_dependent
    cubic = [axle_effect("cubic_stiffness", "lower_arm", ratio=0.5)]
    assert not AxleSolver(axles, cubic).path_dependent  # elastic: no loading branch
    dahl = [axle_effect("dahl_hysteresis", "bushings", f_c=50.0, sigma_ratio=3.0)]
    assert AxleSolver(axles, dahl).path_dependent
    fric = [axle_effect("coulomb_friction", "strut", f_c=50.0, sigma=5e6)]
    assert AxleSolver(axles, fric).path_dependent


@pytest.mark.parametrize("effects", [(), ("cubic",)])
def test_reused_return_leg_equals_the_full_solve(axles, effects):
    eff = [axle_effect("cubic_stiffness", "lower_arm", ratio=0.5)] if effects else []
    fast = run_tests(axles, TESTS, steps=10, effects=eff)
    full = run_tests(axles, TESTS, steps=10, effects=eff, reuse_revisits=False)
    for t in TESTS:
        assert np.array_equal(fast[t].ok, full[t].ok)
        ok = full[t].ok
        assert ok.any()
        for name, v in full[t].channels.items():
            err = np.abs(fast[t].channels[name][ok] - v[ok]).max()
            assert err <= channel_tolerance(name), (t, name, err)
    # a path-independent model closes its loop: both branches agree to tolerance
    r = fast["parallel"]
    gap = np.abs(r.branch("toe", "up") - r.branch("toe", "down"))[r.ok].max()
    assert gap <= RTOL


def test_model_with_hysteresis_still_solves_both_legs(axles):
    eff = [axle_effect("dahl_hysteresis", "bushings", f_c=50.0, sigma_ratio=3.0)]
    one = axles.take(np.array([0]))
    fast = run_tests(one, ("parallel",), steps=8, effects=eff)["parallel"]
    full = run_tests(one, ("parallel",), steps=8, effects=eff, reuse_revisits=False)["parallel"]
    assert fast.ok.all()
    for name, v in full.channels.items():  # the option is ignored: the very same solve
        assert np.array_equal(fast.channels[name], v), name
    gap = np.abs(fast.branch("tyre_fz", "up") - fast.branch("tyre_fz", "down"))
    assert gap[0, fast.static_index].max() > 1.0  # the branches differ (a loop) [N]


def test_chunked_evaluation_and_batched_objectives_change_nothing():
    problem = KCIdentification()
    X = problem.space.to_physical(np.random.default_rng(5).random((7, 49)))
    whole = problem.simulate(X)
    problem.eval_chunk = 3  # chunks 2, 3, 2
    chunked = problem.simulate(X)
    assert np.array_equal(whole[1], chunked[1]) and whole[2] == chunked[2]
    assert np.allclose(whole[0], chunked[0], rtol=1e-12, atol=0.0, equal_nan=True)
    res = run_tests(build_axle(X), TESTS)
    assert np.array_equal(objectives(res), _objectives_one_by_one(res, {}), equal_nan=True)
