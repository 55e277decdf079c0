"""Optional physics of the McPherson axle: strut friction, progressive bushings."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.metrics.knc import loop_width, objectives_subset
from suspenv.models.mcpherson import AxleEffects, AxleSolver, build_axle, reference_design
from suspenv.rigs.knc import run_tests


@pytest.fixture(scope="module")
def axle():
    return build_axle(reference_design()[None, :])


def test_strut_friction_loop_width_matches_hand_calculation(axle):
    # reference: hand calculation. A saturated friction force f between rod and tube
    # reverses between the branches (2 f along the strut); through the motion ratio MR it
    # acts on the wheel, which shares it between the tyre (k_t) and the suspension
    # (wheel rate k_w) in parallel, so the tyre sees 2 f MR k_t / (k_t + k_w).
    f = 100.0
    eff = AxleEffects(strut_friction=f, strut_friction_sigma=5e6)
    res = run_tests(axle, ("parallel",), steps=10, effects=eff)
    assert res["parallel"].ok.all()
    plain = run_tests(axle, ("parallel",), steps=10)
    k_w = objectives_subset(plain, ("par_susp_ride_rate_pos",))[0, 0]
    k_t = axle.constants.tyre_rate
    mr = AxleSolver(axle).motion_ratio_kinematic[0, 0]
    r = res["parallel"]
    gap = r.branch("tyre_fz", "up") - r.branch("tyre_fz", "down")
    hand = 2 * f * mr * k_t / (k_t + k_w)
    assert gap[0, r.static_index, 0] == pytest.approx(hand, rel=0.03)


def test_progressive_bushings_stiffen_and_keep_the_loop_closed(axle):
    # reference: a cubic term only adds stiffness (energy argument) and is elastic
    eff = AxleEffects(cubic_bushings=("lca_front", "lca_rear", "top_mount"), cubic_ratio=0.5)
    res = run_tests(axle, ("parallel",), steps=10, effects=eff)
    plain = run_tests(axle, ("parallel",), steps=10)
    assert loop_width(res).max() < 0.05  # elastic: no loop
    name = ("par_susp_ride_rate_pos",)
    assert objectives_subset(res, name)[0, 0] > objectives_subset(plain, name)[0, 0]
    d = res["parallel"].branch("tyre_fz", "down") - plain["parallel"].branch("tyre_fz", "down")
    assert np.abs(d).max() > 1.0
