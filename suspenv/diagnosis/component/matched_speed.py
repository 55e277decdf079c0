"""Bump/rebound asymmetry at matched speeds: a model-free test on cyclic dyno strokes.

Signs (damper on a dyno, as in :mod:`suspenv.models.components.damper`): velocity ``v``
[m/s] positive in bump (compression), force ``F`` [N] positive when it resists bump, so a
damper absorbs power (``F v > 0``).

For every half-cycle of the stroke (between two velocity reversals) the force is
averaged where ``|v|`` is within ``peak_band`` of that half-cycle's peak speed (mid-stroke
for a sine). Bump and rebound half-cycles of the same peak speed are paired, and the
*even part* ``E = (F_bump + F_rebound) / 2`` [N] is formed. Every element that is odd in
the motion cancels in ``E``: a symmetric damper curve (linear or digressive), Coulomb
friction, saturated hysteresis, any linear viscoelastic element in steady state, a gas
spring's stiffness (the two half-cycles sit at opposite strokes). A gas force or a
load-cell offset adds the same constant at every speed. Only a bump/rebound asymmetry of
the damper curve makes ``E`` change with speed. The errors come from the scatter between
cycles: each cycle is one independent sample, so the serial correlation of the
sample-by-sample residual does not enter.

Dyno programmes often run their speeds in increasing order, so a slowly drifting
load-cell zero would also move ``E`` from one speed to the next. The drift rate is
measured inside each speed group (the slope in time of each direction's force, averaged
over the two directions, so that a warming damper that weakens both cancels), and
every step of ``E`` between groups adjacent in time is compared with the drift those
rates predict over the step (assumption: the drift rate changes smoothly, so the rate
during a step lies between the rates measured just before and just after it). A step
that the drift cannot explain is a change of the bump/rebound difference with speed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats
from scipy.integrate import cumulative_trapezoid

from suspenv.core.errors import ValidationError


@dataclass(frozen=True)
class HalfCycle:
    """Force at the velocity peak of one half-cycle (one direction of stroke).

    ``speed`` [m/s] is the mean ``|v|`` in the peak window, ``force`` [N] the mean force
    there, ``time`` [s] the window's mid time, ``position`` [m] the window's mean stroke
    position (from the integrated velocity when no displacement is given),
    ``half_stroke`` [m] half the half-cycle's travel.
    """

    direction: int  # +1 bump (v > 0), -1 rebound
    speed: float
    force: float
    time: float
    position: float = 0.0  # [m] mean stroke position in the peak window
    half_stroke: float = 0.0  # [m] half the stroke covered by the half-cycle


@dataclass(frozen=True)
class SpeedGroup:
    """Bump and rebound half-cycles at one matched peak speed.

    ``force_bump`` / ``force_rebound`` [N] are means (``force_rebound`` is negative);
    ``stderr_*`` their standard errors from the cycle-to-cycle scatter (pooled over
    groups where a group has too few cycles to estimate its own); ``even`` [N] is
    ``(force_bump + force_rebound) / 2``.
    """

    speed: float
    n_bump: int
    n_rebound: int
    force_bump: float
    force_rebound: float
    stderr_bump: float
    stderr_rebound: float
    time: float
    drift: float  # [N/s] drift rate of the force measured inside the group
    drift_stderr: float  # [N/s]

    @property
    def even(self) -> float:
        return 0.5 * (self.force_bump + self.force_rebound)

    @property
    def even_stderr(self) -> float:
        return 0.5 * float(np.hypot(self.stderr_bump, self.stderr_rebound))

    @property
    def rebound_over_bump(self) -> float:
        """``|F_rebound| / |F_bump| - 1`` with the raw forces (assumes no offset)."""
        return -self.force_rebound / self.force_bump - 1.0

    def to_dict(self) -> dict[str, float]:
        return {
            "speed_m_s": self.speed,
            "n_bump": self.n_bump,
            "n_rebound": self.n_rebound,
            "force_bump_N": self.force_bump,
            "force_rebound_N": self.force_rebound,
            "stderr_bump_N": self.stderr_bump,
            "stderr_rebound_N": self.stderr_rebound,
            "even_part_N": self.even,
            "even_part_stderr_N": self.even_stderr,
            "rebound_over_bump_raw": self.rebound_over_bump,
            "time_s": self.time,
        }


@dataclass(frozen=True)
class DriftStep:
    """Change of the even part between two speed groups adjacent in time.

    ``change`` [N] measured, ``drift`` [N] what the drift rates measured inside the two
    groups predict over the time between them, ``sigma`` [N] the standard error of
    their difference; ``z`` = (change - drift) / sigma.
    """

    speed_from: float
    speed_to: float
    change: float
    drift: float
    sigma: float

    @property
    def z(self) -> float:
        return (self.change - self.drift) / self.sigma if self.sigma > 0 else 0.0


@dataclass
class MatchedSpeedAsymmetry:
    """Result of :func:`matched_speed_asymmetry`.

    ``p_constant``: probability of the observed spread of the even part if it were one
    constant (gas force / offset; an F test with the pooled cycle scatter);
    ``p_drift``: the same for a straight line in time (a steadily drifting zero);
    ``steps``: the changes between groups adjacent in time against the drift measured
    inside them; ``p_steps``: probability that all steps are drift (chi-square of the
    step z-scores, Bonferroni-free because it is one joint test).
    """

    groups: list[SpeedGroup]
    steps: list[DriftStep]
    offset: float
    p_constant: float
    p_drift: float
    p_steps: float
    supported: bool
    sentence: str
    unmatched_speeds: list[float] = field(default_factory=list)

    @property
    def even_range(self) -> float:
        """Largest minus smallest even part over the groups [N]."""
        e = [g.even for g in self.groups]
        return float(max(e) - min(e))

    def to_dict(self) -> dict[str, Any]:
        return {
            "groups": [g.to_dict() for g in self.groups],
            "steps": [
                {
                    "speed_from_m_s": st.speed_from,
                    "speed_to_m_s": st.speed_to,
                    "change_N": st.change,
                    "drift_N": st.drift,
                    "sigma_N": st.sigma,
                    "z": st.z,
                }
                for st in self.steps
            ],
            "offset_N": self.offset,
            "even_range_N": self.even_range,
            "p_constant": self.p_constant,
            "p_drift": self.p_drift,
            "p_steps": self.p_steps,
            "supported": self.supported,
            "sentence": self.sentence,
            "unmatched_speeds_m_s": self.unmatched_speeds,
        }


#: a half-cycle slower than this share of the largest speed is skipped (creep and hold)
MIN_SPEED_SHARE = 0.05
#: the peak window holds the samples with ``|v|`` within this share of the half-cycle's
#: peak speed
PEAK_BAND = 0.03
#: fewest samples in a half-cycle's peak window
MIN_PEAK_SAMPLES = 3
#: fewest half-cycles of a direction in a speed cluster (a scatter needs two)
MIN_PER_CLUSTER = 2
#: largest offset of a group's peak windows from symmetry about the stroke centre,
#: ``|x_b + x_r|``, as a share of the half-stroke
POSITION_TOL = 0.04
#: fewest matched speed groups of a cyclic test at several speeds
MIN_GROUPS = 3


def half_cycles(
    t: np.ndarray,
    v: np.ndarray,
    force: np.ndarray,
    x: np.ndarray | None = None,
) -> list[HalfCycle]:
    """Peak-velocity force (:data:`PEAK_BAND`) of every complete half-cycle of a stroke
    at least :data:`MIN_SPEED_SHARE` of the largest speed.

    Args:
        t: time [s]; v: velocity [m/s] (bump positive); force: force [N].
        x: stroke position [m] (default: the integrated velocity); positions are taken
            relative to the half-cycle's own centre (mid-way between its reversals).
    """
    t, v, force = (np.asarray(a, float) for a in (t, v, force))
    if not (t.shape == v.shape == force.shape and t.ndim == 1):
        raise ValidationError(
            "time, velocity and force must be 1-D arrays of one length, but got shapes "
            f"{t.shape}, {v.shape}, {force.shape}"
        )
    if x is None:
        x = cumulative_trapezoid(v, t, initial=0.0)
    x = np.asarray(x, float)
    if x.shape != t.shape:
        raise ValidationError(f"position must have the shape of time {t.shape}, but got {x.shape}")
    vmax = float(np.max(np.abs(v))) if v.size else 0.0
    floor = MIN_SPEED_SHARE * vmax
    sign = np.sign(v)
    flips = np.flatnonzero(sign[1:] * sign[:-1] < 0) + 1
    out: list[HalfCycle] = []
    for a, b in zip(flips[:-1], flips[1:], strict=True):  # complete half-cycles only
        seg = np.abs(v[a:b])
        peak = float(seg.max())
        if peak < floor:
            continue
        idx = a + np.flatnonzero(seg >= (1.0 - PEAK_BAND) * peak)
        if idx.size < MIN_PEAK_SAMPLES:
            continue
        out.append(
            HalfCycle(
                direction=1 if v[idx[0]] > 0 else -1,
                speed=float(np.mean(np.abs(v[idx]))),
                force=float(np.mean(force[idx])),
                time=float(np.mean(t[idx])),
                position=float(np.mean(x[idx]) - 0.5 * (x[a] + x[b - 1])),
                half_stroke=float(0.5 * abs(x[b - 1] - x[a])),
            )
        )
    return out


def relative_clusters(values: np.ndarray, tol: float) -> list[np.ndarray]:
    """Indices of positive ``values`` (speeds, frequencies) grouped, smallest first, so
    that the values of a group lie within ``tol`` (relative) of its smallest member."""
    order = np.argsort(values)
    groups: list[list[int]] = []
    for i in order:
        if groups and values[i] <= values[groups[-1][0]] * (1.0 + tol):
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
    return [np.array(g) for g in groups]


@dataclass(frozen=True)
class _Side:
    """Half-cycles of one direction at one speed: mean speed [m/s], mean force [N]."""

    members: tuple[HalfCycle, ...]

    @property
    def speed(self) -> float:
        return float(np.mean([c.speed for c in self.members]))

    @property
    def forces(self) -> np.ndarray:
        return np.array([c.force for c in self.members])

    @property
    def position(self) -> float:
        return float(np.mean([c.position for c in self.members]))

    def slope(self) -> tuple[float, float]:
        """Slope of the force in time [N/s] and its standard error (inf when the
        cluster is too short to tell)."""
        t = np.array([c.time for c in self.members])
        f = self.forces
        if f.size < 3 or np.ptp(t) <= 0:
            return 0.0, float("inf")
        b, a = np.polyfit(t, f, 1)
        r = f - (a + b * t)
        s2 = float(np.sum(r**2)) / (f.size - 2)
        return float(b), float(np.sqrt(s2 / np.sum((t - t.mean()) ** 2)))


def speed_groups(
    cycles: Sequence[HalfCycle], speed_tol: float = 0.02, match_tol: float = 0.01
) -> tuple[list[SpeedGroup], list[float]]:
    """Bump and rebound forces at matched peak speeds.

    Each direction's half-cycles are clustered by speed (within ``speed_tol``,
    relative; clusters of fewer than :data:`MIN_PER_CLUSTER` half-cycles are dropped).
    A rebound cluster and a bump cluster form a group when their mean speeds differ by
    at most ``match_tol`` (relative) and their peak windows sit symmetrically about the
    stroke centre (mean positions ``x_b + x_r`` within :data:`POSITION_TOL` of the
    half-stroke): only then is the motion half-wave symmetric, which is what makes the
    odd elements cancel. Standard errors use each cluster's cycle-to-cycle scatter,
    floored by the pooled scatter over all clusters. Returns the groups (slowest first)
    and the speeds of clusters left unpaired.
    """
    sides: dict[int, list[_Side]] = {1: [], -1: []}
    for d in (1, -1):
        if not (own := [c for c in cycles if c.direction == d]):
            continue
        sp = np.array([c.speed for c in own])
        for idx in relative_clusters(sp, speed_tol):
            if idx.size >= MIN_PER_CLUSTER:
                sides[d].append(_Side(tuple(own[i] for i in idx)))
    dev2 = sum(float(np.sum((c.forces - c.forces.mean()) ** 2)) for d in sides for c in sides[d])
    dof = sum(c.forces.size - 1 for d in sides for c in sides[d])
    pooled = dev2 / dof if dof > 0 else 0.0

    def stats_of(c: _Side) -> tuple[float, float]:
        f = c.forces
        var = max(float(np.var(f, ddof=1)) if f.size > 1 else 0.0, pooled)
        return float(f.mean()), float(np.sqrt(var / f.size))

    half_stroke = max((c.half_stroke for c in cycles), default=0.0)
    groups: list[SpeedGroup] = []
    used: set[int] = set()
    for r in sides[-1]:
        near = [b for b in sides[1] if abs(b.speed - r.speed) <= match_tol * r.speed]
        match = next((b for b in near if id(b) not in used), None)
        if match is None or abs(match.position + r.position) > POSITION_TOL * half_stroke:
            continue
        used.update((id(match), id(r)))
        (fb, eb), (fr, er) = stats_of(match), stats_of(r)
        (db, sb), (dr, sr) = match.slope(), r.slope()
        groups.append(
            SpeedGroup(
                speed=0.5 * (match.speed + r.speed),
                n_bump=len(match.members),
                n_rebound=len(r.members),
                force_bump=fb,
                force_rebound=fr,
                stderr_bump=eb,
                stderr_rebound=er,
                time=float(np.mean([m.time for m in match.members + r.members])),
                drift=0.5 * (db + dr),
                drift_stderr=0.5 * float(np.hypot(sb, sr)),
            )
        )
    unmatched = [c.speed for d in (-1, 1) for c in sides[d] if id(c) not in used]
    groups.sort(key=lambda g: g.speed)
    return groups, sorted(unmatched)


def _weighted_line_p(x: np.ndarray, y: np.ndarray, se: np.ndarray, degree: int, dof_err: int):
    """F-test p-value of the scatter of ``y`` about a weighted polynomial of ``degree``
    in ``x`` (0: a constant), with ``dof_err`` degrees of freedom behind ``se``."""
    w = 1.0 / se**2
    A = np.vander(x, degree + 1)
    coef, *_ = np.linalg.lstsq(A * np.sqrt(w)[:, None], y * np.sqrt(w), rcond=None)
    chi2 = float(np.sum(w * (y - A @ coef) ** 2))
    dof = y.size - (degree + 1)
    if dof <= 0:
        return float("nan"), coef
    return float(stats.f.sf(chi2 / dof, dof, max(dof_err, 1))), coef


def drift_steps(groups: Sequence[SpeedGroup]) -> list[DriftStep]:
    """Steps of the even part between groups adjacent in time, each against the drift
    predicted by the mean of the two groups' own drift rates over the time between
    them (groups whose drift rate could not be measured are skipped)."""
    order = sorted((g for g in groups if np.isfinite(g.drift_stderr)), key=lambda g: g.time)
    out = []
    for a, b in zip(order[:-1], order[1:], strict=True):
        dt = b.time - a.time
        rate = 0.5 * (a.drift + b.drift)
        rate_se = 0.5 * float(np.hypot(a.drift_stderr, b.drift_stderr))
        sigma = float(np.sqrt(a.even_stderr**2 + b.even_stderr**2 + (dt * rate_se) ** 2))
        out.append(DriftStep(a.speed, b.speed, b.even - a.even, rate * dt, sigma))
    return out


def matched_speed_asymmetry(
    t: np.ndarray,
    v: np.ndarray,
    force: np.ndarray,
    x: np.ndarray | None = None,
    alpha: float = 0.01,
) -> MatchedSpeedAsymmetry | None:
    """Does the bump/rebound difference change with speed? (see the module text).

    Args:
        t: time [s]; v: velocity [m/s], bump positive; force: force [N], resisting bump
            positive; x: stroke position [m] (optional).
        alpha: significance level of each test.

    Returns None when the stroke has fewer than :data:`MIN_GROUPS` matched speed groups
    (:func:`speed_groups`: not a cyclic test at several speeds). ``supported`` holds when a
    constant, a straight line in time and the measured drift are all rejected at level
    ``alpha``.
    """
    groups, unmatched = speed_groups(half_cycles(t, v, force, x))
    if len(groups) < MIN_GROUPS:
        return None
    e = np.array([g.even for g in groups])
    se = np.array([g.even_stderr for g in groups])
    se = np.maximum(se, 1e-9 * max(float(np.max(np.abs(e))), 1.0))
    tg = np.array([g.time for g in groups])
    dof_err = int(sum(g.n_bump + g.n_rebound - 2 for g in groups))
    p_const, c0 = _weighted_line_p(tg, e, se, 0, dof_err)
    p_drift, _ = _weighted_line_p(tg - tg.mean(), e, se, 1, dof_err)
    steps = drift_steps(groups)
    chi2 = float(sum(st.z**2 for st in steps))
    p_steps = float(stats.chi2.sf(chi2, len(steps))) if steps else float("nan")
    supported = bool(p_const < alpha and p_drift < alpha and p_steps < alpha)
    lo, hi = int(np.argmin(e)), int(np.argmax(e))
    big = max(steps, key=lambda st: abs(st.z)) if steps else None
    step_words = (
        f"; the largest step, {big.change:+.1f} N from {big.speed_from:.3g} to "
        f"{big.speed_to:.3g} m/s, is {abs(big.z):.1f} standard errors away from the "
        f"{big.drift:+.1f} N the measured drift predicts"
        if big
        else ""
    )
    facts = (
        f"at matched speeds the even part (bump + rebound)/2 of the force ranges from "
        f"{e[lo]:+.1f} ± {se[lo]:.1f} N ({groups[lo].speed:.3g} m/s) to {e[hi]:+.1f} ± "
        f"{se[hi]:.1f} N ({groups[hi].speed:.3g} m/s) over {len(groups)} speeds (constant gas "
        f"force / offset: p = {p_const:.2g}; steady zero drift: p = {p_drift:.2g}; drift "
        f"measured inside the speed groups: p = {p_steps:.2g}{step_words})"
    )
    if supported:
        sentence = (
            f"{facts}: the bump/rebound difference changes with speed, which a gas force, an "
            "offset or a drifting zero cannot do"
        )
    elif p_const >= alpha:
        sentence = f"{facts}: no change with speed beyond a constant force"
    else:
        sentence = (
            f"{facts}: the change could be a drift of the load-cell zero, because the speeds "
            "were run in time order; a test with the speeds in random order would separate them"
        )
    return MatchedSpeedAsymmetry(
        groups=groups,
        steps=steps,
        offset=float(c0[0]),
        p_constant=p_const,
        p_drift=p_drift,
        p_steps=p_steps,
        supported=supported,
        sentence=sentence,
        unmatched_speeds=unmatched,
    )
