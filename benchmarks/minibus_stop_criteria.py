"""Minibus ride, end stops: the stop's equivalent gain by other linearisation criteria,
against the deflection statistics of long runs and against the stored reference.

The spectral method replaces an end stop ``F = k_stop max(x - gap, 0)`` (p = 1) on a
spring deflection x (mean m, RMS s; ``a = (gap - m)/s``) by a rate acting all the time.
Criteria of that rate (:data:`CRITERIA`; K the spring's own rate, N/m):

- ``gaussian`` (Booton, Kazakov; Stein's lemma; the method's before the closure):
  ``E[F'] = k_stop (1 - Phi(a))``, the mean-square-optimal gain for a Gaussian deflection;
- ``potential_energy`` (equal mean potential energies; Elishakoff's energy criterion):
  ``2 E[U]/s^2 = k_stop (E[max(t - a, 0)^2] - max(-a, 0)^2)``, U the stop's potential
  about the mean, t standard normal;
- ``energy_mean_square`` (least mean-square deviation of the potential energies; Zhang,
  Elishakoff & Zhang 1991; review: Proppe, Pradlwarter & Schueller 2003, Prob. Eng.
  Mech. 18:1): ``2 E[U y^2]/E[y^4]``, for a Gaussian y by Stein's lemma twice
  ``(2/3) gaussian + (1/3) potential_energy``;
- ``potential_closure`` (non-Gaussian closure): ``E[F y]/E[y^2]`` under the stationary
  density of a one-degree-of-freedom oscillator with the spring K and the stop under
  white noise (Caughey's exact form ``p ∝ exp(-V(x)/(K s0^2))``, V the spring's and the
  stop's potential), s0 set so that its variance is s^2: the corner's own stiffness
  ratio ``k_stop/K``, where the method takes the whole vehicle's (below);
- ``kazakov_variance`` (Kazakov's second criterion, equal variances of the element's
  force and of its linear stand-in): ``sqrt(Var F)/s`` for a Gaussian deflection, and
  ``kazakov_variance_closure`` the same under the closure's density.

Part 1 (``--pairs`` antithetic pairs of 120 s records, RK4 at 200 Hz, 15 mm bump stops
at 300 kN/m front and rear as :data:`benchmarks.minibus_ride_effects.STOPS`; the
designs whose stops touch most and the centre, both load cases): per
spring (left and right pooled) the deflection's mean, RMS, skewness, kurtosis, contact
probability, the stop's measured mean-square-optimal gain ``E[(F - E F) y]/E[y^2]``
(y = x - m), its cross-spectral gain ``Re S_yF / S_yy`` over three bands and its
remainder's RMS (:data:`MEASURED`); at the measured m, s every criterion's gain and
the spectral method's own (``gain_method``: its whole-vehicle stiffness ratio and
skewness tilt), and the method's own mean, RMS and contact probability.
``--reuse-runs`` takes the measured entries (and part 3's ``remainder_measured``) from
the stored JSON and recomputes the rest.

Part 2 (no runs): the spectral values of the effect sets with stops (``bump_stops``,
``leaf_friction_and_stops``) with each criterion as the stop's gain (the Gaussian mean
force in the balance, no remainder), against the 120 s reference stored in
``minibus_ride_effects.json``.

Part 3 (no runs but part 1's): the stop's remainder ``r = F - E[F] - k y`` added as a
second excitation (:data:`REMAINDERS`), its cross-spectra for a Gaussian deflection by
its Hermite terms of order 2..``ORDERS`` (Mehler's formula and the FFT,
:func:`remainder_spectra`) scaled to the variance of the variant's statistics, through
the mass matrix only or through the whole linear model, against the stored reference;
the method itself (``method``: :func:`suspenv.metrics.ride.ride_spectral`, which adds
the remainder on its own grids); and with part 1's measured gains and remainder
cross-spectra in place of both (``remainder_measured``).

Run: ``python -m benchmarks.minibus_stop_criteria [--reuse-runs]``; writes
``docs/benchmarks/minibus_stop_criteria.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
from scipy.signal import csd, welch
from scipy.special import ndtr

from benchmarks.common import DEFAULT_OUTPUT_DIR, machine_info, write_result
from benchmarks.minibus_ride_effects import (
    RECORD_S,
    SAMPLE_RATE,
    SCENARIOS,
    STOPS,
    TARGET_PERCENT,
    designs,
    records,
)
from suspenv.metrics import ride
from suspenv.metrics.iso2631 import weighting_magnitude
from suspenv.models.effects.effect import Effect
from suspenv.models.minibus import linearisation
from suspenv.models.minibus.ride_model import RideModel
from suspenv.models.minibus.stop_closure import (
    ORDERS,
    gaussian_remainder_variance,
    hermite_remainder,
)
from suspenv.models.minibus.vehicle import (
    LOAD_CASES,
    REFERENCE_MINIBUS,
    stacked_vehicle_parameters,
)
from suspenv.models.road import CLASS_BAND, RandomRoad

GAP, K_STOP = STOPS[0].params["gap"], STOPS[0].params["k_stop"]
#: designs of part 1: the stops' frequent contact (all-low, 1010) and the centre
DIAG_DESIGNS = ("low corner", "alternating 1010", "centre")
#: bands of the cross-spectral gain (Hz): body modes, between, wheel hop
BANDS = ((0.8, 2.5), (2.5, 6.0), (6.0, 15.0))
PAIRS = 4
#: grid of the potential closure's density (multiples of s) and its points
_U = np.linspace(-8.0, 8.0, 1601)

Gain = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def _gaussian(k: np.ndarray, m: np.ndarray, s: np.ndarray) -> np.ndarray:
    return linearisation.stop_moments(GAP, K_STOP, 1.0, s, m)[1]


def _potential_energy(k: np.ndarray, m: np.ndarray, s: np.ndarray) -> np.ndarray:
    a = (GAP - m) / s
    return K_STOP * (linearisation.tail_moment(a, 2.0) - np.maximum(-a, 0.0) ** 2)


def _energy_mean_square(k: np.ndarray, m: np.ndarray, s: np.ndarray) -> np.ndarray:
    return (2.0 * _gaussian(k, m, s) + _potential_energy(k, m, s)) / 3.0


def _closure_density(
    k: np.ndarray, m: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The potential closure's density on ``y = s u`` (u on :data:`_U`): weights
    ``∝ exp(-(y^2 + k_stop/K max(m + y - gap, 0)^2)/(2 s0^2))`` (summing to 1), with s0
    by bisection so that Var y = s^2; also y - E[y] (m) and the stop force (N)."""
    k, m, s = (np.asarray(v, float)[..., None] for v in np.broadcast_arrays(k, m, s))
    y = s * _U
    pen = np.maximum(m + y - GAP, 0.0)
    ratio = K_STOP / k

    def moments(c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        w = np.exp(-0.5 * (y * y + ratio * pen * pen) / (c * s) ** 2)
        w /= w.sum(-1, keepdims=True)
        mu = (w * y).sum(-1, keepdims=True)
        return w, mu, (w * (y - mu) ** 2).sum(-1, keepdims=True)

    # s0/s lies between 1 (no contact) and sqrt(1 + k_stop/K) (contact throughout)
    lo, hi = np.ones_like(s), np.broadcast_to(1.0 + np.sqrt(1.0 + ratio), s.shape)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        small = moments(mid)[2] < s * s
        lo, hi = np.where(small, mid, lo), np.where(small, hi, mid)
    w, mu, _ = moments(0.5 * (lo + hi))
    return w, y - mu, K_STOP * pen


def _potential_closure(k: np.ndarray, m: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``E[F y]/E[y^2]`` under the closure's density (:func:`_closure_density`)."""
    w, y, force = _closure_density(k, m, s)
    return (w * force * y).sum(-1) / (w * y * y).sum(-1)


def _kazakov_variance(k: np.ndarray, m: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Kazakov's equal-variance gain ``sqrt(Var F)/s``, Gaussian deflection:
    ``k_stop sqrt(E[max(t - a, 0)^2] - E[max(t - a, 0)]^2)``."""
    a = (GAP - m) / s
    t1, t2 = linearisation.tail_moment(a, 1.0), linearisation.tail_moment(a, 2.0)
    return K_STOP * np.sqrt(np.maximum(t2 - t1 * t1, 0.0))


def _kazakov_variance_closure(k: np.ndarray, m: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``sqrt(Var F / Var y)`` under the closure's density."""
    w, y, force = _closure_density(k, m, s)
    mean = (w * force).sum(-1, keepdims=True)
    return np.sqrt((w * (force - mean) ** 2).sum(-1) / (w * y * y).sum(-1))


#: criteria: name -> (gain, label in docs/minibus.md's table)
CRITERIA: dict[str, tuple[Gain, str]] = {
    "gaussian": (_gaussian, "Gaussian `E[F']` (Booton, Kazakov; the method's before the closure)"),
    "energy_mean_square": (
        _energy_mean_square,
        "least mean-square deviation of the potential energies (Zhang, Elishakoff & "
        "Zhang 1991), `(2/3) E[F'] + (1/3) 2 E[U]/σ²`",
    ),
    "potential_closure": (
        _potential_closure,
        "non-Gaussian closure: `E[F y]/E[y²]` under the exact stationary density of a "
        "1-DOF oscillator with the spring and the stop (Caughey), its variance matched",
    ),
    "potential_energy": (_potential_energy, "equal mean potential energies, `2 E[U]/σ²`"),
    "kazakov_variance_closure": (
        _kazakov_variance_closure,
        "Kazakov's equal variances `√(Var F)/σ`, the closure's density",
    ),
    "kazakov_variance": (_kazakov_variance, "the same, Gaussian"),
}
#: the effect sets with stops
STOP_SETS = ("bump_stops", "leaf_friction_and_stops")
#: the cells missed by the Gaussian gain (docs/minibus.md's table, in this order)
MISSED = (
    "bump_stops/low corner/full_load/front",
    "bump_stops/low corner/full_load/rear",
    "bump_stops/alternating 1010/full_load/rear",
)


def deflections(X: np.ndarray, pairs: int) -> np.ndarray:
    """Spring deflections (m, + compression; (rows, FL FR RL RR, time)) of the nonlinear
    model with :data:`STOPS` over ``pairs`` antithetic pairs of records, concatenated."""
    model = RideModel(stacked_vehicle_parameters(X, LOAD_CASES), effects=STOPS)
    q = slice(0, model.nq)
    return np.concatenate(
        [
            np.einsum("nqt,qe->net", rec.states[:, q], model.E[q, :4])
            for _, _, rec in records(model, pairs, REFERENCE_MINIBUS, record_states=True)
            if rec.states is not None
        ],
        axis=2,
    )


def corner_rate(lz: linearisation.ElementLinearisation, end: int) -> np.ndarray:
    """The corner spring's own rate K (N/m; (rows, 1)) at the stop's contact point, as
    the method takes it (``ElementLinearisation._compliance``): the front wheel rate,
    the leaf's primary rate or, where its helper knee lies below the gap, the composite
    one."""
    comp = lz._compliances[end][0]
    assert comp is not None  # the benchmark's stops: one p = 1 bump stop per end
    return comp[4][:, None]


#: part 1's row entries measured in the runs (``--reuse-runs`` keeps them)
MEASURED: tuple[str, ...] = ("mean_mm", "rms_mm", "skewness", "kurtosis", "contact_percent")
MEASURED += ("gain_measured_kN_m", "remainder_rms_measured_N")
MEASURED += tuple(f"gain_measured_{lo:g}_{hi:g}Hz_kN_m" for lo, hi in BANDS)


def run_statistics(x: np.ndarray) -> dict[str, float]:
    """The :data:`MEASURED` entries (gains kN/m, remainder RMS N) of one spring's
    deflections ``x`` (m; (sides, time))."""
    m = float(x.mean())
    y = x - m
    s = float(y.std())
    force = K_STOP * np.maximum(x - GAP, 0.0)
    gain = float(((force - force.mean()) * y).mean() / s**2)
    row = {
        "mean_mm": 1e3 * m,
        "rms_mm": 1e3 * s,
        "skewness": float((y**3).mean() / s**3),
        "kurtosis": float((y**4).mean() / s**4),
        "contact_percent": float(100 * (x > GAP).mean()),
        "gain_measured_kN_m": gain / 1e3,
        "remainder_rms_measured_N": float((force - force.mean() - gain * y).std()),
    }
    f, syy = welch(y, SAMPLE_RATE, nperseg=4096, axis=-1)
    _, syf = csd(y, force - force.mean(axis=-1, keepdims=True), SAMPLE_RATE, nperseg=4096)
    for lo, hi in BANDS:
        band = (f >= lo) & (f < hi)
        band_gain = np.real(syf[:, band].sum()) / syy[:, band].sum()
        row[f"gain_measured_{lo:g}_{hi:g}Hz_kN_m"] = float(band_gain / 1e3)
    return row


def criteria_row(k: float, m: float, s: float) -> dict[str, float]:
    """At a spring deflection of mean ``m`` and RMS ``s`` (m) on a spring of rate ``k``
    (N/m): the Gaussian contact probability (%), the remainder's RMS for a Gaussian
    deflection and under the closure's density (N) and every criterion's gain
    (kN/m)."""
    mm, ss = np.array(m), np.array(s)
    row = {
        "contact_gaussian_percent": float(100 * ndtr(-(GAP - m) / s)),
        "remainder_rms_gaussian_N": float(
            K_STOP * s * np.sqrt(gaussian_remainder_variance((GAP - mm) / ss))
        ),
        "remainder_rms_closure_N": float(np.sqrt(closure_remainder_variance(np.array(k), mm, ss))),
    }
    for name, (fn, _) in CRITERIA.items():
        row[f"gain_{name}_kN_m"] = float(fn(np.array(k), mm, ss) / 1e3)
    return row


def converged(
    X: np.ndarray, effects: list[Effect]
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, linearisation.ElementLinearisation]:
    """The spectral method with ``effects``: its result, the rates of its last pass (n,
    n_rates; columns of :mod:`suspenv.models.minibus.linearisation`), the element RMS
    values its last update took (n, 12; recorded on the way) and its linearisation."""
    seen: dict[str, Any] = {}
    rates_of, fixed_point_of = linearisation.ElementLinearisation.rates, ride._fixed_point

    def rates(
        self: linearisation.ElementLinearisation, sig: np.ndarray, r: np.ndarray
    ) -> np.ndarray:
        seen["sig"], seen["lz"] = sig.copy(), self
        return rates_of(self, sig, r)

    def fixed_point(*args: Any, **kwargs: Any) -> tuple[np.ndarray, int, Any]:
        out = fixed_point_of(*args, **kwargs)
        seen["r"] = out[0]
        return out

    with (
        mock.patch.object(linearisation.ElementLinearisation, "rates", rates),
        mock.patch.object(ride, "_fixed_point", fixed_point),
        _without_remainder(),
    ):
        sp = ride.ride_spectral(X, effects=effects)
    return sp, seen["r"], seen["sig"], seen["lz"]


def spring_means(lz: linearisation.ElementLinearisation, sig: np.ndarray) -> np.ndarray:
    """The balance's mean spring deflections (m; (rows, FL FR RL RR)) at the element RMS
    values ``sig`` (:meth:`ElementLinearisation.spring_mean`)."""
    sd = [sig[:, linearisation.SIG_FRONT], sig[:, linearisation.SIG_LEAF]]
    return np.hstack(
        [lz.spring_mean(end, sig[:, 2 * end : 2 * end + 2], sd[end]) for end in (0, 1)]
    )


def diag_designs() -> np.ndarray:
    """The designs of :data:`DIAG_DESIGNS` (physical units)."""
    names, X = designs()
    return X[[names.index(d) for d in DIAG_DESIGNS]]


def measured_rows(x: np.ndarray) -> list[dict[str, object]]:
    """Part 1's measured rows: per design of :data:`DIAG_DESIGNS`, load case and end,
    :func:`run_statistics` of their spring deflections ``x`` (:func:`deflections`)."""
    n = len(DIAG_DESIGNS)
    return [
        {
            "design": DIAG_DESIGNS[i % n],
            "load_case": LOAD_CASES[i // n],
            "end": end,
            **run_statistics(x[i, 2 * j : 2 * j + 2]),
        }
        for i in range(x.shape[0])
        for j, end in enumerate(("front", "rear"))
    ]


def element_statistics(measured: list[dict[str, object]]) -> list[dict[str, object]]:
    """Part 1 rows: the ``measured`` ones (:func:`measured_rows`, in its order) with
    every criterion at their mean and RMS (:func:`criteria_row`), the spectral method's
    own stop gain and remainder RMS there (its whole-vehicle stiffness ratio and
    skewness tilt, ``ElementLinearisation._closure``), and its own spring deflection
    mean, RMS and Gaussian contact probability (left side, its last pass)."""
    _, _, sig, lz = converged(diag_designs(), STOPS)
    m_sp = spring_means(lz, sig)[:, [0, 2]]
    s_sp = sig[:, [linearisation.SIG_FRONT.start, linearisation.SIG_LEAF.start]]
    rows: list[dict[str, object]] = []
    for q, row in enumerate(measured):
        i, j = divmod(q, 2)
        m, s = 1e-3 * float(row["mean_mm"]), 1e-3 * float(row["rms_mm"])  # type: ignore[arg-type]
        mm, ss = np.full((len(m_sp), 2), m), np.full((len(m_sp), 2), s)
        v = _method_variance(lz, np.tile((GAP - mm) / ss, 2))[:, 2 * j]
        rows.append(
            {
                **row,
                **criteria_row(float(corner_rate(lz, j)[i, 0]), m, s),
                "gain_method_kN_m": float(lz._stop_rate(j, mm, ss)[i, 0] / 1e3),
                "remainder_rms_method_N": float(K_STOP * s * np.sqrt(v[i])),
                "spectral_mean_mm": 1e3 * float(m_sp[i, j]),
                "spectral_rms_mm": 1e3 * float(s_sp[i, j]),
                "spectral_contact_percent": float(100 * ndtr(-(GAP - m_sp[i, j]) / s_sp[i, j])),
            }
        )
    return rows


def _gaussian_stop_terms(
    self: linearisation.ElementLinearisation, end: int, m: np.ndarray, sd: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``ElementLinearisation._stop_terms`` for a Gaussian deflection (the method's
    before the closure): the stops' mean force (N) and its derivative ``E[F']`` (N/m)."""
    force, slope = np.zeros_like(m), np.zeros_like(m)
    for sign, gap, k_stop, p in self.stops[end]:
        f, k = linearisation.stop_moments(gap, k_stop, p, sd, sign * m)
        force, slope = force + sign * f, slope + k
    return force, slope


def _without_remainder() -> Any:
    """A context in which the spectral method adds no stop remainder (part 3 adds its
    own)."""
    return mock.patch.object(
        ride, "_stop_remainder", lambda lin, lz, r, *_: np.zeros((r.shape[0], 2, 2))
    )


@contextlib.contextmanager
def _patched_rate(rate: Callable[..., np.ndarray]) -> Iterator[None]:
    """A context in which the stops' mean force is the Gaussian one, their rate
    ``rate(lz, end, m, sd)`` (N/m) and the method adds no remainder."""
    with (
        mock.patch.multiple(
            linearisation.ElementLinearisation, _stop_terms=_gaussian_stop_terms, _stop_rate=rate
        ),
        _without_remainder(),
    ):
        yield


def _patched(gain: Gain) -> contextlib.AbstractContextManager[None]:
    """:func:`_patched_rate` with the rate ``gain`` of (K, m, s) (the benchmark's stops:
    one bump stop per end at ``GAP``, ``K_STOP``)."""
    return _patched_rate(
        lambda lz, end, m, sd: gain(np.broadcast_to(corner_rate(lz, end), m.shape), m, sd)
    )


def _deviations(reference: dict, values: dict[str, np.ndarray]) -> dict[str, float]:
    """Per stop cell ``effects/design/load case/end`` of the effect sets of ``values``
    (per set, (rows, front/rear) weighted RMS, m/s^2): its deviation (%) from the
    stored ``reference``."""
    names = designs()[0]
    cells = {}
    for r in reference["rows"]:
        if r["effects"] in values:
            i = names.index(r["design"]) + len(names) * LOAD_CASES.index(r["load_case"])
            value = values[r["effects"]][i, ("front", "rear").index(r["end"])]
            key = f"{r['effects']}/{r['design']}/{r['load_case']}/{r['end']}"
            cells[key] = float(100 * (value / r["time_120s"] - 1))
    return cells


def _cells_summary(label: str, cells: dict[str, float]) -> dict[str, object]:
    """Counts within target (all, front, rear), range, the Gaussian gain's misses."""
    err = np.array(list(cells.values()))
    ok = {k: abs(e) <= TARGET_PERCENT for k, e in cells.items()}
    return {
        "label": label,
        "within_target": f"{int((np.abs(err) <= TARGET_PERCENT).sum())}/{err.size}",
        **{
            f"within_target_{end}": f"{sum(v for k, v in ok.items() if k.endswith(end))}/"
            f"{sum(k.endswith(end) for k in ok)}"
            for end in ("front", "rear")
        },
        "missed_by_gaussian_percent": [cells[k] for k in MISSED],
        "error_min_percent": float(err.min()),
        "error_max_percent": float(err.max()),
        "error_rms_percent": float(np.sqrt(np.mean(err**2))),
        "cells_percent": cells,
    }


def _aw(sp: dict[str, np.ndarray]) -> np.ndarray:
    return np.stack([sp["aw_front"], sp["aw_rear"]], 1)


def spectral_cells(reference: dict) -> dict[str, dict[str, object]]:
    """Part 2: per criterion, each stop cell's deviation (%) from the stored reference."""
    X = designs()[1]
    out: dict[str, dict[str, object]] = {}
    for name, (gain, label) in CRITERIA.items():
        with _patched(gain):
            values = {s: _aw(ride.ride_spectral(X, effects=SCENARIOS[s])) for s in STOP_SETS}
        out[name] = _cells_summary(label, _deviations(reference, values))
    return out


# ------------------------------------------------------- part 3: the impacts' remainder
#: uniform grid of the remainder's spectra (Hz): step (the covariances' period, 64 s,
#: covers the slowest mode's decay) and top (above the stops' contact frequencies)
F_STEP, F_TOP = 1.0 / 64.0, 128.0
#: the remainder's variants: name -> (statistics of the stop: ``gaussian`` (Gaussian
#: mean force, gain ``E[F']`` and remainder), ``closure`` (the corner closure's gain
#: and remainder variance, :func:`_potential_closure`, the Gaussian mean force),
#: ``corner`` (the method with the corner's own stiffness ratio ``k_stop/K`` and no
#: skewness tilt, :func:`_corner_only`) or ``method`` (the method's own, whole-vehicle
#: ratio and tilt); path of the remainder: ``filtered`` through the linear model,
#: ``direct`` through the mass matrix only; label)
REMAINDERS: dict[str, tuple[str, str, str]] = {
    "gaussian_direct": (
        "gaussian",
        "direct",
        "Gaussian `E[F']` and its Hermite remainder (a second-order consistent Gaussian "
        "correction) through the mass matrix only",
    ),
    "closure_direct": (
        "closure",
        "direct",
        "the corner closure's gain and remainder variance, the Gaussian mean force, "
        "remainder through the mass matrix only",
    ),
    "corner_direct": (
        "corner",
        "direct",
        "the corner closure for the mean force, gain and remainder (κ = `k_stop/K`, no "
        "skewness tilt: the method before the whole-vehicle law), through the mass matrix",
    ),
    "method_filtered": (
        "method",
        "filtered",
        "the method's statistics (whole-vehicle κ, skewness tilt), the remainder through "
        "the whole linear model instead of the mass matrix",
    ),
}


def _moments(w: np.ndarray, y: np.ndarray, force: np.ndarray) -> tuple[np.ndarray, ...]:
    """Mean force (N), gain ``E[F y]/E[y^2]`` (N/m) and remainder variance ``Var F -
    E[F y]^2/E[y^2]`` (N^2) under the weights ``w`` (last axis) of :func:`_closure_density`."""
    mean = (w * force).sum(-1)
    fy, yy = (w * force * y).sum(-1), (w * y * y).sum(-1)
    return mean, fy / yy, (w * (force - mean[..., None]) ** 2).sum(-1) - fy * fy / yy


def closure_remainder_variance(k: np.ndarray, m: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``Var F - E[F y]^2/E[y^2]`` (N^2) under the closure's density."""
    return _moments(*_closure_density(k, m, s))[2]


def _corner_only(self: linearisation.ElementLinearisation, stats: np.ndarray | None) -> None:
    """``ElementLinearisation.set_corners`` as the method was before the whole-vehicle
    law: each p = 1 stop's stiffness ratio ``k_stop/K`` (K its corner spring's rate at
    the contact point), no skewness tilt."""
    self.skew = np.zeros_like(self.skew)
    for end in (0, 1):
        self.kappa[end][:] = [
            None if c is None else np.repeat((stop[2] / c[4])[:, None], 2, axis=1)
            for c, stop in zip(self._compliances[end], self.stops[end], strict=True)
        ]


def _method_variance(lz: linearisation.ElementLinearisation, a: np.ndarray) -> np.ndarray:
    """The method's remainder variance over ``(k_stop s)^2`` ((n, 4); FL..RR) of the
    benchmark's bump stops at ``a = (gap - m)/s`` (``ElementLinearisation._closure``)."""
    v = []
    for e, (kappa,) in enumerate(lz.kappa):
        assert kappa is not None  # one p = 1 bump stop per end
        v += lz._closure(e, 1.0, kappa, a[:, 2 * e : 2 * e + 2], "v")
    return np.hstack(v)


@contextlib.contextmanager
def _statistics(name: str) -> Iterator[None]:
    """A context that sets the stops' mean force, gain and closure as the
    :data:`REMAINDERS` statistics ``name`` and adds no remainder of the method's."""
    patch: contextlib.AbstractContextManager[Any] = contextlib.nullcontext()
    if name in ("gaussian", "closure"):
        patch = _patched(_gaussian if name == "gaussian" else _potential_closure)
    elif name == "corner":
        patch = mock.patch.object(linearisation.ElementLinearisation, "set_corners", _corner_only)
    with patch, _without_remainder():
        yield


def _variance_ratio(
    stats: str, lz: linearisation.ElementLinearisation, means: np.ndarray, sd: np.ndarray
) -> np.ndarray:
    """The ratio (n, 4) of the remainder's variance under the statistics ``stats`` to the
    Gaussian one, at spring deflections of means ``means`` and RMS ``sd`` (m)."""
    a = (GAP - means) / sd
    gauss = gaussian_remainder_variance(a)
    if stats == "gaussian":
        return np.ones_like(sd)
    if stats == "closure":
        k = np.hstack([np.broadcast_to(corner_rate(lz, e), sd[:, :2].shape) for e in (0, 1)])
        return closure_remainder_variance(k, means, sd) / ((K_STOP * sd) ** 2 * gauss)
    return _method_variance(lz, a) / gauss


def stop_responses(
    X: np.ndarray, r: np.ndarray, lz: linearisation.ElementLinearisation, f: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Of the linear model with the rates ``r`` (whole model, modal form): transfer
    functions (n, Nf, 6, 8) at f (Hz) from the wheel road inputs FL..RR (m) and forces
    on the springs FL, FR, RL, RR (N, + resisting compression) to the measuring points'
    displacements (front, rear) and the spring deflections (m); and the forces' direct
    feedthrough to the measuring points' accelerations, ``Co M^-1 (-e_j)`` ((n, 2, 4);
    (m/s^2)/N)."""
    lin = RideModel(stacked_vehicle_parameters(X, LOAD_CASES), linear=True)
    nq = lin.nq
    M, C, K, Kin, Cin = lin.linear_system(
        r[:, linearisation.DAMPER], r[:, linearisation.LEAF], r[:, linearisation.FRONT]
    )
    springs = lin.E[:nq, 0:4]
    force = np.broadcast_to(-springs, Kin.shape)
    Co = np.vstack([ride._output_matrix(lin)[0:2], springs.T])
    hyst = None
    if lz.dahl is not None:
        hyst = (lin.E[:nq, 2:4].T, r[:, linearisation.DAHL_C], r[:, linearisation.DAHL_K])
    lam, P = ride.modal_form(
        M, C, K, np.concatenate([Kin, force], 2), np.concatenate([Cin, 0 * force], 2), Co, hyst
    )
    direct = np.einsum("pq,nqr,rj->npj", Co[:2], np.linalg.inv(M), -springs)
    return ride.modal_response(lam, P, f)[:, :, :6], direct


def deflection_spectra(H: np.ndarray, f: np.ndarray) -> np.ndarray:
    """One-sided cross-spectra ``S_ij = E[d_i conj(d_j)]`` (m^2/Hz; (n, Nf, 4, 4)) of
    the spring deflections under the road (its class band) from :func:`stop_responses`'
    transfer functions H at f (Hz)."""
    road = RandomRoad()
    lo, hi = road.speed * CLASS_BAND[0], min(road.speed * CLASS_BAND[1], road.sample_rate)
    gq, delay, rho = ride.road_terms(np.maximum(f, lo), road, REFERENCE_MINIBUS)
    gq = np.where((f >= lo) & (f <= hi), gq, 0.0)
    g = H[:, :, 2:, :4]
    left = g[..., 0] + delay[None, :, None] * g[..., 2]
    right = g[..., 1] + delay[None, :, None] * g[..., 3]
    rr = rho[None, :, None]
    cols = (left + rr * right, np.sqrt(np.maximum(1.0 - rr * rr, 0.0)) * right)
    cross = sum(c[..., :, None] * c[..., None, :].conj() for c in cols)
    return cross * gq[None, :, None, None]


def remainder_spectra(S: np.ndarray, means: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """One-sided cross-spectra (N^2/Hz; (n, Nf, 4, 4)) of the four stops' remainders
    for Gaussian deflections of cross-spectra ``S`` (on ``k F_STEP``, k = 0..) and means
    ``means`` (m; (n, 4)): covariances by the inverse FFT, the remainders' by Mehler's
    formula (:func:`hermite_remainder`), each stop's scaled by ``sqrt(scale)`` (the
    ratio of its remainder's variance to the Gaussian one), back by the FFT."""
    nfft = 2 * (S.shape[1] - 1)
    c = 0.5 * nfft * F_STEP  # R(k/(nfft F_STEP)) = c irfft(conj S): the trapezoid rule
    R = c * np.fft.irfft(np.conj(S), n=nfft, axis=1)
    sd = np.sqrt(np.einsum("nii->ni", R[:, 0]))
    rho = R / (sd[:, None, :, None] * sd[:, None, None, :])
    coef = hermite_remainder((GAP - means) / sd) * (K_STOP * sd * np.sqrt(scale))[None]
    out, power = np.zeros_like(R), rho
    for cn in coef:
        power = power * rho
        out += cn[:, None, :, None] * cn[:, None, None, :] * power
    return np.conj(np.fft.rfft(out, axis=1)) / c


def remainder_mean_squares(
    H: np.ndarray, direct: np.ndarray, Sr: np.ndarray, f: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Wk-weighted mean squares ((m/s^2)^2; (n, front/rear)) the remainders of
    cross-spectra ``Sr`` (on the uniform grid f) add at the measuring points: through
    the linear model (``filtered``) and through the mass matrix only (``direct``)."""
    df = f[1] - f[0]
    band = (f >= ride.ISO_BAND[0]) & (f <= ride.ISO_BAND[1])
    wk2 = np.where(band, weighting_magnitude(np.maximum(f, df), "Wk") ** 2, 0.0)
    h = H[:, :, :2, 4:]
    w4 = (2 * np.pi * f) ** 4
    filtered = np.einsum("nfpi,nfij,nfpj,f->np", h, Sr, h.conj(), w4 * wk2)
    through_mass = np.einsum("npi,nfij,npj,f->np", direct, Sr, direct, wk2)
    return df * filtered.real, df * through_mass.real


def remainder_cells(reference: dict) -> dict[str, dict[str, object]]:
    """Part 3: the stop cells with the stops' remainder added (:data:`REMAINDERS`), and
    the method itself (``method``: :func:`suspenv.metrics.ride.ride_spectral`)."""
    X = designs()[1]
    f = np.arange(0.0, F_TOP + F_STEP / 2, F_STEP)
    out: dict[str, dict[str, object]] = {}
    for name, (stats, path, label) in REMAINDERS.items():
        values = {}
        for s in STOP_SETS:
            with _statistics(stats):
                sp, r, sig, lz = converged(X, SCENARIOS[s])
                means = spring_means(lz, sig)
                H, direct = stop_responses(X, r, lz, f)
                S = deflection_spectra(H, f)
                sd = np.sqrt(np.einsum("nfii->ni", S[:, 1:-1]).real * F_STEP)
                Sr = remainder_spectra(S, means, _variance_ratio(stats, lz, means, sd))
            filtered, through_mass = remainder_mean_squares(H, direct, Sr, f)
            values[s] = np.sqrt(_aw(sp) ** 2 + (filtered if path == "filtered" else through_mass))
        out[name] = _cells_summary(label, _deviations(reference, values))
    method = {s: _aw(ride.ride_spectral(X, effects=SCENARIOS[s])) for s in STOP_SETS}
    label = (
        "the spectral method itself (whole-vehicle κ, skewness tilt, remainder through the mass)"
    )
    out["method"] = _cells_summary(label, _deviations(reference, method))
    return out


def measured_remainder(x: np.ndarray, reference: dict) -> dict[str, dict[str, float]]:
    """Part 3 with the runs' own statistics: the diagnostic designs' bump-stop cells with
    each stop's measured gain ``E[(F - E F) y]/E[y^2]`` in the linear model and its
    measured remainder's cross-spectra (Welch, part 1's runs ``x``) added through the
    mass matrix only or through the linear model: deviations (%) from the reference."""
    X = diag_designs()
    y = x - x.mean(-1, keepdims=True)
    force = K_STOP * np.maximum(x - GAP, 0.0)
    force -= force.mean(-1, keepdims=True)
    gain = (force * y).mean(-1) / (y * y).mean(-1)  # (rows, 4)
    rem = force - gain[..., None] * y
    spectra = [
        [csd(rem[:, i], rem[:, j], SAMPLE_RATE, nperseg=4096) for j in range(4)] for i in range(4)
    ]
    f = spectra[0][0][0]
    Sr = np.conj(np.stack([np.stack([q[1] for q in row], -1) for row in spectra], -2))

    def stop_rate(
        lz: linearisation.ElementLinearisation, end: int, m: np.ndarray, sd: np.ndarray
    ) -> np.ndarray:
        return gain[:, 2 * end : 2 * end + 2]

    with _patched_rate(stop_rate):
        sp, r, _, lz = converged(X, STOPS)
    H, direct = stop_responses(X, r, lz, f)
    filtered, through_mass = remainder_mean_squares(H, direct, Sr, f)
    aw = _aw(sp)
    ref = {
        (q["design"], q["load_case"], q["end"]): q["time_120s"]
        for q in reference["rows"]
        if q["effects"] == "bump_stops"
    }
    out = {}
    for i in range(aw.shape[0]):
        for j, end in enumerate(("front", "rear")):
            design, case = DIAG_DESIGNS[i % len(DIAG_DESIGNS)], LOAD_CASES[i // len(DIAG_DESIGNS)]
            t = ref[(design, case, end)]
            out[f"bump_stops/{design}/{case}/{end}"] = {
                "linear_part": float(100 * (aw[i, j] / t - 1)),
                "direct": float(100 * (np.sqrt(aw[i, j] ** 2 + through_mass[i, j]) / t - 1)),
                "filtered": float(100 * (np.sqrt(aw[i, j] ** 2 + filtered[i, j]) / t - 1)),
            }
    return out


def _runs(result: dict) -> dict[str, str]:
    """Commit and time of part 1's runs from a result's machine entry."""
    machine = result["machine"]
    return {"commit": machine["packages"].get("suspenv_commit"), "timestamp": machine["timestamp"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=PAIRS, help="antithetic record pairs")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    parser.add_argument(
        "--reuse-runs",
        action="store_true",
        help="part 1's measured entries and remainder_measured from the stored JSON",
    )
    args = parser.parse_args(argv)
    reference_path = Path(DEFAULT_OUTPUT_DIR) / "minibus_ride_effects.json"
    reference = json.loads(reference_path.read_text())
    if args.reuse_runs:
        stored = json.loads((Path(DEFAULT_OUTPUT_DIR) / "minibus_stop_criteria.json").read_text())
        keys = ("design", "load_case", "end", *MEASURED)
        measured = [{k: r[k] for k in keys} for r in stored["rows"]]
        pairs, runs = stored["summary"]["pairs"], stored["summary"].get("runs") or _runs(stored)
        from_runs = stored["summary"]["remainder_measured"]
    else:
        x = deflections(diag_designs(), args.pairs)
        measured, pairs = measured_rows(x), args.pairs
        runs = _runs({"machine": machine_info()})
        from_runs = measured_remainder(x, reference)
    summary: dict[str, object] = {
        "what": f"stop gains by criterion vs {pairs} antithetic pairs of {RECORD_S:.0f} s "
        "runs; spectral stop cells by criterion vs the stored reference",
        "reference": str(reference_path),
        "reference_commit": reference["machine"]["packages"].get("suspenv_commit"),
        "pairs": pairs,
        "runs": runs,
        "gap_m": GAP,
        "k_stop_N_m": K_STOP,
        "criteria": spectral_cells(reference),
        "orders": ORDERS,
        "remainder": remainder_cells(reference),
        "remainder_measured": from_runs,
    }
    command = "python -m benchmarks.minibus_stop_criteria"
    write_result(
        "minibus_stop_criteria",
        element_statistics(measured),
        summary,
        command + (" --reuse-runs" if args.reuse_runs else ""),
        args.output_dir,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
