"""Minibus ride, end stops: the stop's equivalent gain by other linearisation criteria,
against the deflection statistics of long runs and against the stored reference.

The spectral method replaces an end stop ``F = k_stop max(x - gap, 0)`` (p = 1) on a
spring deflection x (mean m, RMS s; ``a = (gap - m)/s``) by a rate acting all the time.
Criteria of that rate (:data:`CRITERIA`; K the spring's own rate, N/m):

- ``gaussian`` (the method's: Booton, Kazakov; Stein's lemma): ``E[F'] = k_stop (1 -
  Phi(a))``, the mean-square-optimal gain for a Gaussian deflection;
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
  stop's potential), s0 set so that its variance is s^2;
- ``kazakov_variance`` (Kazakov's second criterion, equal variances of the element's
  force and of its linear stand-in): ``sqrt(Var F)/s`` for a Gaussian deflection, and
  ``kazakov_variance_closure`` the same under the closure's density.

Part 1 (``--pairs`` antithetic pairs of 120 s records, RK4 at 200 Hz, 15 mm bump stops
at 300 kN/m front and rear as :data:`benchmarks.minibus_ride_effects.STOPS`; the
designs whose stops touch most and the centre, both load cases): per spring (left and
right pooled) the deflection's mean, RMS, skewness, kurtosis, the contact probability
against the Gaussian one of that mean and RMS, the stop's measured mean-square-optimal
gain ``E[(F - E F) y]/E[y^2]`` (y = x - m) and its cross-spectral gain
``Re S_yF / S_yy`` over three bands, and every criterion's gain at the measured m, s.

Part 2 (no new runs): the spectral values of the effect sets with stops
(``bump_stops``, ``leaf_friction_and_stops``) with each criterion in place of the
method's, against the 120 s reference stored in ``minibus_ride_effects.json``.

Run: ``python -m benchmarks.minibus_stop_criteria``; writes
``docs/benchmarks/minibus_stop_criteria.json``.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from unittest import mock

import numpy as np
from scipy.signal import csd, welch
from scipy.special import ndtr

from benchmarks.common import DEFAULT_OUTPUT_DIR, write_result
from benchmarks.minibus_ride_effects import (
    RECORD_S,
    SAMPLE_RATE,
    SCENARIOS,
    STOPS,
    TARGET_PERCENT,
    designs,
    records,
)
from suspenv.metrics.ride import ride_spectral
from suspenv.models.minibus import linearisation
from suspenv.models.minibus.ride_model import RideModel
from suspenv.models.minibus.vehicle import (
    LOAD_CASES,
    REFERENCE_MINIBUS,
    stacked_vehicle_parameters,
)

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

    lo, hi = np.ones_like(s), 3.0 * np.ones_like(s)
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
    "gaussian": (_gaussian, "Gaussian `E[F']` (Booton, Kazakov; the method's)"),
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


def rate_at_gap(lz: linearisation.ElementLinearisation, end: int) -> np.ndarray:
    """The spring's own rate K (N/m; (rows, L/R)) at the stop's gap: the front wheel
    rate, the leaf's primary rate or, where its helper knee lies below the gap, the
    composite one."""
    if end == 0:
        return lz.k_front
    return lz.k1 + lz.dk * (lz.thr < GAP)


def element_row(x: np.ndarray, k: float) -> dict[str, float]:
    """Statistics and gains (kN/m) of one spring's deflections ``x`` (m; (sides, time))."""
    m = float(x.mean())
    y = x - m
    s = float(y.std())
    force = K_STOP * np.maximum(x - GAP, 0.0)
    row = {
        "mean_mm": 1e3 * m,
        "rms_mm": 1e3 * s,
        "skewness": float((y**3).mean() / s**3),
        "kurtosis": float((y**4).mean() / s**4),
        "contact_percent": float(100 * (x > GAP).mean()),
        "contact_gaussian_percent": float(100 * ndtr(-(GAP - m) / s)),
        "gain_measured_kN_m": float(((force - force.mean()) * y).mean() / s**2 / 1e3),
    }
    f, syy = welch(y, SAMPLE_RATE, nperseg=4096, axis=-1)
    _, syf = csd(y, force - force.mean(axis=-1, keepdims=True), SAMPLE_RATE, nperseg=4096)
    for lo, hi in BANDS:
        band = (f >= lo) & (f < hi)
        gain = np.real(syf[:, band].sum()) / syy[:, band].sum()
        row[f"gain_measured_{lo:g}_{hi:g}Hz_kN_m"] = float(gain / 1e3)
    for name, (fn, _) in CRITERIA.items():
        row[f"gain_{name}_kN_m"] = float(fn(np.array(k), np.array(m), np.array(s)) / 1e3)
    return row


def spectral_elements(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The spectral method's own spring deflection means and RMS values (m; (rows,
    front/rear), left side) with :data:`STOPS`, from the element RMS values of its last
    linearisation pass (:meth:`ElementLinearisation.rates`, recorded on the way)."""
    seen: list[np.ndarray] = []
    method = linearisation.ElementLinearisation.rates

    def rates(
        self: linearisation.ElementLinearisation, sig: np.ndarray, r: np.ndarray
    ) -> np.ndarray:
        seen.append(sig.copy())
        return method(self, sig, r)

    with mock.patch.object(linearisation.ElementLinearisation, "rates", rates):
        ride_spectral(X, effects=STOPS)
    sig = seen[-1]
    lz = linearisation.ElementLinearisation(
        RideModel(stacked_vehicle_parameters(X, LOAD_CASES), effects=STOPS)
    )
    sd = [sig[:, linearisation.SIG_FRONT], sig[:, linearisation.SIG_LEAF]]
    m = [lz.spring_mean(end, sig[:, 2 * end : 2 * end + 2], sd[end]) for end in (0, 1)]
    return np.stack([m[0][:, 0], m[1][:, 0]], 1), np.stack([sd[0][:, 0], sd[1][:, 0]], 1)


def element_statistics(pairs: int) -> list[dict[str, object]]:
    """Part 1 rows: per design of :data:`DIAG_DESIGNS`, load case and end."""
    names, X_all = designs()
    X = X_all[[names.index(d) for d in DIAG_DESIGNS]]
    lz = linearisation.ElementLinearisation(
        RideModel(stacked_vehicle_parameters(X, LOAD_CASES), effects=STOPS)
    )
    m_sp, s_sp = spectral_elements(X)
    x, K = deflections(X, pairs), np.stack([rate_at_gap(lz, 0)[:, 0], rate_at_gap(lz, 1)[:, 0]], 1)
    n = len(DIAG_DESIGNS)
    rows: list[dict[str, object]] = []
    for i in range(x.shape[0]):
        for j, end in enumerate(("front", "rear")):
            head: dict[str, object] = {
                "design": DIAG_DESIGNS[i % n],
                "load_case": LOAD_CASES[i // n],
                "end": end,
            }
            spectral = {
                "spectral_mean_mm": 1e3 * float(m_sp[i, j]),
                "spectral_rms_mm": 1e3 * float(s_sp[i, j]),
                "spectral_contact_percent": float(100 * ndtr(-(GAP - m_sp[i, j]) / s_sp[i, j])),
            }
            rows.append(
                {**head, **element_row(x[i, 2 * j : 2 * j + 2], float(K[i, j])), **spectral}
            )
    return rows


def _patched_stop_terms(gain: Gain) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """``ElementLinearisation._stop_terms`` with the method's mean force and ``gain`` in
    place of its rate (for the benchmark's stops: one bump stop per end at ``GAP``,
    ``K_STOP``)."""
    method = linearisation.ElementLinearisation._stop_terms

    def stop_terms(
        self: linearisation.ElementLinearisation, end: int, m: np.ndarray, sd: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        force = method(self, end, m, sd)[0]
        return force, gain(np.broadcast_to(rate_at_gap(self, end), m.shape), m, sd)

    return stop_terms


def spectral_cells(reference: dict) -> dict[str, dict[str, object]]:
    """Part 2: per criterion, each stop cell's deviation (%) from the stored reference."""
    names, X = designs()
    n = len(names)
    ref = [
        r for r in reference["rows"] if r["effects"] in ("bump_stops", "leaf_friction_and_stops")
    ]
    out: dict[str, dict[str, object]] = {}
    for name, (gain, label) in CRITERIA.items():
        with mock.patch.object(
            linearisation.ElementLinearisation, "_stop_terms", _patched_stop_terms(gain)
        ):
            sp = {
                s: ride_spectral(X, effects=SCENARIOS[s])
                for s in ("bump_stops", "leaf_friction_and_stops")
            }
        cells = {}
        for r in ref:
            i = names.index(r["design"]) + n * LOAD_CASES.index(r["load_case"])
            value = sp[r["effects"]][f"aw_{r['end']}"][i]
            key = f"{r['effects']}/{r['design']}/{r['load_case']}/{r['end']}"
            cells[key] = float(100 * (value / r["time_120s"] - 1))
        err = np.array(list(cells.values()))
        ok = {k: abs(e) <= TARGET_PERCENT for k, e in cells.items()}
        out[name] = {
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
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=PAIRS, help="antithetic record pairs")
    parser.add_argument("--output-dir", default=None, help="default docs/benchmarks")
    args = parser.parse_args(argv)
    reference_path = Path(DEFAULT_OUTPUT_DIR) / "minibus_ride_effects.json"
    reference = json.loads(reference_path.read_text())
    rows = element_statistics(args.pairs)
    summary: dict[str, object] = {
        "what": f"stop gains by criterion vs {args.pairs} antithetic pairs of {RECORD_S:.0f} s "
        "runs; spectral stop cells by criterion vs the stored reference",
        "reference": str(reference_path),
        "reference_commit": reference["machine"]["packages"].get("suspenv_commit"),
        "pairs": args.pairs,
        "gap_m": GAP,
        "k_stop_N_m": K_STOP,
        "criteria": spectral_cells(reference),
    }
    write_result(
        "minibus_stop_criteria",
        rows,
        summary,
        "python -m benchmarks.minibus_stop_criteria",
        args.output_dir,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
