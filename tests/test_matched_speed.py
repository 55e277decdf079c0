"""Matched-speed bump/rebound test on planted dyno strokes.

References: the planted truths themselves. A sine stroke at several speeds through a
symmetric digressive curve plus a constant (gas) force has a constant even part; the
same with separate bump/rebound knees has an even part that changes with speed by the
closed-form amount 0.5 * (F_bump(v) - F_rebound(v)); a zero drifting linearly in time
moves the even part with time, not speed.
"""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.component.matched_speed import half_cycles, matched_speed_asymmetry

STROKE = 0.0125  # m, half-stroke of the sine
SPEEDS = (0.02, 0.04, 0.06, 0.1, 0.15, 0.25)  # m/s, peak speeds run in this order


def _digressive(v: np.ndarray, c: float, vk: float) -> np.ndarray:
    return c * v / (1.0 + np.abs(v) / vk)


def _stroke(
    rng: np.random.Generator,
    bump=(4e4, 0.02),
    rebound=(4e4, 0.02),
    offset: float = -6.0,
    drift: float = 0.0,
    noise: float = 2.0,
    cycles: int = 5,
    rate: float = 1000.0,
):
    """Sine strokes at each speed of SPEEDS in turn; force = curve + offset + drift t +
    Coulomb friction 30 N + noise (N)."""
    t_all, x_all, v_all = [], [], []
    t0 = 0.0
    for vp in SPEEDS:
        w = vp / STROKE
        n = int(round(cycles * 2 * np.pi / w * rate))
        t = t0 + np.arange(n) / rate
        x_all.append(STROKE * np.sin(w * (t - t0)))
        v_all.append(vp * np.cos(w * (t - t0)))
        t_all.append(t)
        t0 = t[-1] + 1.0 / rate
    t, x, v = (np.concatenate(a) for a in (t_all, x_all, v_all))
    f = np.where(v >= 0, _digressive(v, *bump), _digressive(v, *rebound))
    f = f + offset + drift * t + 30.0 * np.tanh(v / 1e-3) + noise * rng.standard_normal(t.size)
    return t, x, v, f


def test_symmetric_curve_with_gas_force_is_not_called_asymmetric():
    t, x, v, f = _stroke(np.random.default_rng(0))
    m = matched_speed_asymmetry(t, v, f, x)
    assert m is not None and len(m.groups) == len(SPEEDS)
    assert not m.supported
    assert m.p_constant > 0.01
    # the constant is the planted gas force
    assert m.offset == pytest.approx(-6.0, abs=1.0)
    assert "no change with speed" in m.sentence


def test_low_speed_rebound_asymmetry_is_found_with_the_planted_size():
    rebound = (6e4, 0.012)
    t, x, v, f = _stroke(np.random.default_rng(1), rebound=rebound)
    m = matched_speed_asymmetry(t, v, f, x)
    assert m is not None and m.supported
    assert m.p_constant < 1e-6 and m.p_steps < 0.01
    for g in m.groups:  # closed form of the even part at each speed
        expect = -6.0 + 0.5 * (
            _digressive(np.array(g.speed), 4e4, 0.02) - _digressive(np.array(g.speed), *rebound)
        )
        assert g.even == pytest.approx(float(expect), abs=3 * g.even_stderr + 1.0)


def test_zero_drift_in_time_is_not_taken_for_asymmetry():
    # symmetric curve, zero drifting at 0.5 N/s while the speeds rise in time order
    t, x, v, f = _stroke(np.random.default_rng(2), drift=0.5)
    m = matched_speed_asymmetry(t, v, f, x)
    assert m is not None
    assert m.p_constant < 0.01  # the even part does move ...
    assert not m.supported  # ... but the drift measured inside each speed explains it
    assert "drift" in m.sentence


def test_half_cycles_find_the_peak_speed_at_mid_stroke():
    t, x, v, f = _stroke(np.random.default_rng(3), noise=0.0)
    hc = half_cycles(t, v, f, x)
    fast = [c for c in hc if c.speed > 0.2]
    # the half-cycle that spans the jump from the previous speed is not centred
    centred = [c for c in fast if abs(c.position) < 0.05 * STROKE]
    assert len(fast) >= 8 and len(centred) >= len(fast) - 1
    assert all(c.speed == pytest.approx(0.25, rel=0.02) for c in centred)


def test_bad_input_names_the_rule():
    with pytest.raises(ValidationError, match="one length"):
        half_cycles(np.arange(5.0), np.arange(4.0), np.arange(5.0))


def test_a_single_speed_gives_no_verdict():
    t = np.arange(0, 10, 1e-3)
    v = 0.1 * np.cos(8 * t)
    assert matched_speed_asymmetry(t, v, 1e3 * v) is None


def test_real_damper_dyno_difference_changes_with_speed(shared_data):
    """Real racing damper: the bump/rebound difference is not a constant force."""
    from suspenv.measurements import load_damper_dyno

    path = shared_data / "real" / "damper_dyno_fsae" / "TR22-FC0739-1-4-1-4.dat"
    rec = load_damper_dyno(path)
    m = matched_speed_asymmetry(
        rec.time, rec.inputs["velocity"], rec.outputs["force"], rec.inputs["displacement"]
    )
    assert m is not None and len(m.groups) >= 5
    assert m.p_constant < 1e-6
    # rebound stronger at the slowest matched speed
    assert m.groups[0].rebound_over_bump > 0.03
