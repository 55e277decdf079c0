"""Car side-impact problem against independently computed values.

References used here, none of them computed by the implementation:
* hand arithmetic at x = (1, ..., 1), every term written out below;
* the RE suite's printed formulas (Tanabe and Ishibuchi 2020, RE41/CRE31), whose
  coefficients have the material constants already multiplied in (e.g. 0.06486 =
  0.188 * 0.345), re-typed term by term in :func:`re_suite_reference`, while the
  implementation keeps the original factors (0.188 * x1 * x8);
* the ideal point published with the RE suite for RE41:
  (15.576004, 3.58525, 10.61064375, 0.0), and the nadir components f2 = 4.42725,
  f3 = 13.09138125 (box corners, since f1 rises and f2, f3 fall in every variable).
"""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.problems.carside import RESPONSE_LIMITS, CarSideImpact
from suspenv.registry import make_problem

LIMITS = np.array([1.0, 0.32, 0.32, 0.32, 32.0, 32.0, 32.0, 4.0, 9.9, 15.7])


def re_suite_reference(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(f1, f2, f3) and the RE suite's g_i = limit_i - r_i (feasible when >= 0)."""
    x1, x2, x3, x4, x5, x6, x7 = (float(v) for v in x)
    f1 = 1.98 + 4.9 * x1 + 6.67 * x2 + 6.98 * x3 + 4.01 * x4 + 1.78 * x5 + 0.00001 * x6 + 2.73 * x7
    f2 = 4.72 - 0.5 * x4 - 0.19 * x2 * x3
    vmbp = 10.58 - 0.674 * x1 * x2 - 0.67275 * x2
    vfd = 16.45 - 0.489 * x3 * x7 - 0.843 * x5 * x6
    f3 = 0.5 * (vmbp + vfd)
    g = [
        1 - (1.16 - 0.3717 * x2 * x4 - 0.0092928 * x3),
        0.32
        - (
            0.261
            - 0.0159 * x1 * x2
            - 0.06486 * x1
            - 0.019 * x2 * x7
            + 0.0144 * x3 * x5
            + 0.0154464 * x6
        ),
        0.32
        - (
            0.214
            + 0.00817 * x5
            - 0.045195 * x1
            - 0.0135168 * x1
            + 0.03099 * x2 * x6
            - 0.018 * x2 * x7
            + 0.007176 * x3
            + 0.023232 * x3
            - 0.00364 * x5 * x6
            - 0.018 * x2 * x2
        ),
        0.32 - (0.74 - 0.61 * x2 - 0.031296 * x3 - 0.031872 * x7 + 0.227 * x2 * x2),
        32 - (28.98 + 3.818 * x3 - 4.2 * x1 * x2 + 1.27296 * x6 - 2.68065 * x7),
        32 - (33.86 + 2.95 * x3 - 5.057 * x1 * x2 - 3.795 * x2 - 3.4431 * x7 + 1.45728),
        32 - (46.36 - 9.9 * x2 - 4.4505 * x1),
        4 - f2,
        9.9 - vmbp,
        15.7 - vfd,
    ]
    return np.array([f1, f2, f3]), np.array(g)


def test_hand_arithmetic_at_all_ones():
    # hand calculation at x = (1, 1, 1, 1, 1, 1, 1):
    # f1 = 1.98 + 4.9 + 6.67 + 6.98 + 4.01 + 1.78 + 0.00001 + 2.73 = 29.05001 kg
    # f2 = 4.72 - 0.5 - 0.19 = 4.03 kN
    # Vmbp = 10.58 - 0.674 - 0.67275 = 9.23325; Vfd = 16.45 - 0.489 - 0.843 = 15.118
    # f3 = (9.23325 + 15.118) / 2 = 12.175625 m/s
    responses = [
        1.16 - 0.3717 - 0.0092928,  # abdomen load 0.7790072 kN
        0.261 - 0.0159 - 0.06486 - 0.019 + 0.0144 + 0.0154464,  # VC upper 0.1910864
        0.1852162,  # VC middle: 0.214 + 0.00817 - 0.045195 - 0.0135168 + 0.03099 - 0.018
        #             + 0.007176 + 0.023232 - 0.00364 - 0.018
        0.74 - 0.61 - 0.031296 - 0.031872 + 0.227,  # VC lower 0.293832
        28.98 + 3.818 - 4.2 + 1.27296 - 2.68065,  # rib upper 27.19031 mm
        33.86 + 2.95 - 5.057 - 3.795 - 3.4431 + 1.45728,  # rib middle 25.97218 mm
        46.36 - 9.9 - 4.4505,  # rib lower 32.0095 mm (violates 32 by 0.0095)
        4.03,  # pubic force (violates 4 by 0.03)
        9.23325,
        15.118,
    ]
    x = np.ones(7)
    batch = CarSideImpact(constraint_scale="absolute").evaluate(x)
    np.testing.assert_allclose(batch.objectives[0], [29.05001, 4.03, 12.175625], rtol=1e-12)
    np.testing.assert_allclose(batch.constraints[0], np.array(responses) - LIMITS, atol=1e-12)
    rel = CarSideImpact().evaluate(x).constraints[0]
    np.testing.assert_allclose(rel, np.array(responses) / LIMITS - 1.0, atol=1e-12)
    # infeasible exactly through rib_lower and pubic force
    assert list(np.flatnonzero(rel > 0)) == [6, 7]
    re41 = CarSideImpact(variant="RE41").evaluate(x)
    # f4 = 0.0095 (mm) + 0.03 (kN), the RE suite's summed violation
    np.testing.assert_allclose(re41.objectives[0, 3], 0.0395, atol=1e-12)


@pytest.mark.parametrize(
    "x",
    [
        [1.2, 0.8, 0.9, 1.1, 1.5, 0.6, 1.0],
        [0.5, 1.35, 1.5, 0.5, 2.625, 0.4, 1.2],
        [1.37, 0.52, 0.61, 1.44, 0.9, 1.13, 0.45],
    ],
)
def test_matches_re_suite_formulas(x):
    f_ref, g_re = re_suite_reference(np.array(x))
    abs_batch = CarSideImpact(constraint_scale="absolute").evaluate(np.array(x))
    np.testing.assert_allclose(abs_batch.objectives[0], f_ref, rtol=1e-12)
    # RE states g >= 0 feasible; ours is g <= 0 feasible: g_ours = -g_RE
    np.testing.assert_allclose(abs_batch.constraints[0], -g_re, atol=1e-10)
    rel = CarSideImpact(constraint_scale="relative").evaluate(np.array(x)).constraints[0]
    np.testing.assert_allclose(rel, -g_re / LIMITS, atol=1e-12)
    re41 = CarSideImpact(variant="RE41").evaluate(np.array(x))
    # RE41's f4: sum of the violated amounts max(0, -g_RE)
    np.testing.assert_allclose(re41.objectives[0, :3], f_ref, rtol=1e-12)
    np.testing.assert_allclose(re41.objectives[0, 3], np.clip(-g_re, 0, None).sum(), atol=1e-10)


def test_published_ideal_and_nadir_corners():
    p = CarSideImpact(variant="RE41")
    lower, upper = p.space.lower, p.space.upper
    # RE suite ideal point f1 = 15.576004 (all thicknesses at their lower bound)
    lo = p.evaluate(lower).objectives[0]
    assert lo[0] == pytest.approx(15.576004, abs=1e-9)
    # RE suite nadir components f2 = 4.42725, f3 = 13.09138125 at the same corner
    assert lo[1] == pytest.approx(4.42725, abs=1e-9)
    assert lo[2] == pytest.approx(13.09138125, abs=1e-9)
    # RE suite ideal f2 = 3.58525, f3 = 10.61064375 (all at their upper bound)
    hi = p.evaluate(upper).objectives[0]
    assert hi[1] == pytest.approx(3.58525, abs=1e-9)
    assert hi[2] == pytest.approx(10.61064375, abs=1e-9)
    # no design in the box beats the published ideal point
    rng = np.random.default_rng(0)
    F = p.evaluate(p.space.to_physical(rng.random((5000, 7)))).objectives
    ideal = np.array([15.576004, 3.58525, 10.61064375, 0.0])
    assert (F - ideal >= -1e-9).all()


def test_batch_is_vectorised_and_equals_row_by_row():
    p = CarSideImpact()
    X = p.space.to_physical(np.random.default_rng(1).random((50, 7)))
    batch = p.evaluate(X)
    rows = [p.evaluate(x) for x in X]
    np.testing.assert_allclose(batch.objectives, np.vstack([r.objectives for r in rows]))
    np.testing.assert_allclose(batch.constraints, np.vstack([r.constraints for r in rows]))
    assert batch.ok.all()


def test_shapes_names_and_units():
    p = make_problem("CarSideImpact")
    assert (p.space.dim, p.n_objectives, p.n_constraints) == (7, 3, 10)
    assert p.constraint_names == tuple(name for name, _, _ in RESPONSE_LIMITS)
    assert p.objective_units == ("kg", "kN", "m/s")
    assert set(p.space.units) == {"mm"}
    q = make_problem("CarSideImpact", variant="re41")
    assert (q.n_objectives, q.n_constraints) == (4, 0)
    assert q.config() == {"variant": "RE41", "constraint_scale": "relative"}


def test_feasible_and_infeasible_designs_exist():
    # the constraints bind somewhere inside the box: both kinds appear in a sample
    p = CarSideImpact()
    batch = p.evaluate(p.space.to_physical(np.random.default_rng(2).random((2000, 7))))
    assert 0 < batch.feasible.sum() < len(batch)


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        ({"variant": "RE42"}, "`variant` must be one of ['CRE31', 'RE41'], but got 'RE42'"),
        ({"constraint_scale": "pymoo"}, "`constraint_scale` must be one of"),
    ],
)
def test_bad_options_name_the_rule(options, fragment):
    with pytest.raises(ValidationError) as err:
        CarSideImpact(**options)
    assert fragment in str(err.value)


def test_nan_design_is_rejected():
    with pytest.raises(ValidationError, match="must be finite"):
        CarSideImpact().evaluate(np.array([1.0, np.nan, 1, 1, 1, 1, 1]))


def test_total_violation_is_the_same_dimensionless_number_in_both_scales():
    # reference: g = r - limit divided by its declared scale (the limit) equals
    # g = r / limit - 1 exactly, so the two modes' totals agree to float precision;
    # the absolute mode's plain sum would add kN to mm and m/s
    rng = np.random.default_rng(3)
    p_abs = CarSideImpact(constraint_scale="absolute")
    x = p_abs.space.lower + rng.random((64, 7)) * (p_abs.space.upper - p_abs.space.lower)
    absolute = p_abs.evaluate(x)
    relative = CarSideImpact().evaluate(x)
    assert (relative.violation > 0).any() and (relative.violation == 0).any()
    np.testing.assert_allclose(absolute.violation, relative.violation, rtol=1e-12, atol=1e-15)
    plain = np.clip(absolute.constraints, 0.0, None).sum(axis=1)
    assert not np.allclose(plain, relative.violation)
