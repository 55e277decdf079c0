"""Diagnosis of a measured road profile against the ISO 8608 model.

Frame and units: distance x along the road (m, + in the direction of travel),
elevation z (m, + up), spatial frequency n (cycle/m); PSDs are one-sided (m^3).
ISO 8608: Gd(n) = Gd(n0) (n / n0)^-w, n0 = 0.1 cycle/m, standard waviness w = 2.

Method (one criterion, stated once):

* The profile is put on a uniform grid and first-differenced (pre-whitening: the
  slope of a w = 2 road is nearly white, so the periodogram has no leakage from the
  strong long waves); its one-sided periodogram ``I_k`` at the Fourier lines inside
  ``band`` is modelled as ``S(n) = 4 sin^2(pi n dx) Gd(n0) (n/n0)^-w`` times an
  Exp(1) variable (Whittle likelihood; independent lines).
* Two fits: free (Gd(n0), w) and the standard (Gd(n0), w = 2). Standard errors from
  the Whittle Fisher information, ``cov = (X^T X)^-1`` with columns ``[1, -ln(n/n0)]``
  in (ln Gd(n0), w).
* Test: likelihood ratio ``2 (l_free - l_w2)`` against chi^2 with 1 dof, and the BIC
  change. "Waviness steeper (shallower) than ISO 8608's 2" is named when the p-value
  is below ``alpha`` **and** the BIC falls; otherwise the standard model stands.
* Class: the ISO 8608 class whose range (half to double its mean) holds Gd(n0).
* Held-out check: the fits of one profile (or the first half) predict the
  periodogram of the other profile (or the second half); the held-out Whittle
  log-likelihood per line of both models is compared.
* Ride consequence: Wk-weighted RMS vertical acceleration of the reference minibus
  (:mod:`suspenv.models.minibus.ride_model`) on synthetic two-track roads with the
  fitted spectrum vs the standard-waviness fit, averaged over road seeds, and on the
  measured profile itself (both wheel tracks in phase).

The Welch PSD (Hann, 50 % overlap, linear detrend) is computed for plots only.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import optimize, signal, stats

from suspenv.core.errors import ValidationError
from suspenv.measurements import Recording
from suspenv.measurements.sources.road_profile import load_profile_txt, profile_recording
from suspenv.rigs.road import N0, ROAD_CLASS_GD0, RoadProfile, generate_profile

#: default fitted band (cycle/m): long waves of a ~500 m profile up to 1 cycle/m (below
#: the 2 cycle/m Nyquist line of a 0.25 m grid, where interpolation and profiler
#: filtering bend the spectrum)
DEFAULT_BAND = (0.02, 1.0)
STANDARD_WAVINESS = 2.0


def synthetic_profile(
    length: float,
    dx: float = 0.25,
    gd0: float = ROAD_CLASS_GD0["B"],
    waviness: float = 2.0,
    seed: int = 0,
    name: str | None = None,
) -> Recording:
    """A Gaussian random profile with Gd(n) = gd0 (n/n0)^-waviness (test/benchmark input).

    Complex Gaussian line amplitudes (a true Gaussian process, so periodograms
    scatter as Exp(1)) on a grid four times longer than ``length``; a window of
    ``length`` is cut out, so the profile is not periodic (as a measured one).
    """
    n_long = int(round(4 * length / dx))
    n = np.fft.rfftfreq(n_long, dx)
    dn = 1.0 / (n_long * dx)
    rng = np.random.default_rng(seed)
    psd = np.zeros_like(n)
    psd[1:] = gd0 * (n[1:] / N0) ** (-waviness)
    coef = np.sqrt(psd * dn / 4.0) * (
        rng.standard_normal(n.size) + 1j * rng.standard_normal(n.size)
    )
    coef[-1] = coef[-1].real if n_long % 2 == 0 else coef[-1]
    z = np.fft.irfft(coef * n_long, n=n_long)
    m = int(round(length / dx))
    start = int(rng.integers(0, n_long - m))
    x = dx * np.arange(m)
    return profile_recording(
        x, z[start : start + m], name or f"synthetic_w{waviness:g}_s{seed}", dx, source="synthetic"
    )


def _profile(rec: Recording) -> tuple[np.ndarray, float]:
    rec.require(outputs=("elevation",), units={"elevation": "m"})
    z = rec.outputs["elevation"]
    dx = float(rec.meta.get("dx") or np.median(np.diff(rec.inputs.get("distance", rec.time))))
    return z, dx


# ------------------------------------------------------------------ spectra
def welch_spatial_psd(
    z: np.ndarray, dx: float, segment_length: float = 64.0
) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD (m^3) in spatial frequency (cycle/m); Hann, 50 %, linear detrend."""
    nper = min(int(round(segment_length / dx)), len(z))
    return signal.welch(np.asarray(z, float), fs=1.0 / dx, nperseg=nper, detrend="linear")


def slope_periodogram(z: np.ndarray, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """(n, I): one-sided periodogram of the first difference of z (m^3), lines 1..N/2-1."""
    d = np.diff(np.asarray(z, float))
    d = d - d.mean()
    N = d.size
    spec = np.fft.rfft(d)
    n = np.fft.rfftfreq(N, dx)
    I_ = 2.0 * dx / N * np.abs(spec) ** 2
    keep = slice(1, N // 2 if N % 2 == 0 else None)
    return n[keep], I_[keep]


def difference_gain(n: np.ndarray, dx: float) -> np.ndarray:
    """|1 - exp(-2 pi i n dx)|^2 = 4 sin^2(pi n dx): PSD gain of first differencing."""
    return 4.0 * np.sin(np.pi * n * dx) ** 2


# ------------------------------------------------------------------ fit
@dataclass
class PsdFit:
    """A Whittle fit of Gd(n) = gd0 (n/n0)^-w over ``band`` (SI: m^3, cycle/m)."""

    gd0: float
    gd0_ci95: tuple[float, float]
    waviness: float
    waviness_se: float
    loglik: float
    n_lines: int
    band: tuple[float, float]
    fixed_waviness: bool

    @property
    def road_class(self) -> str:
        return road_class(self.gd0)

    def psd(self, n: np.ndarray) -> np.ndarray:
        return self.gd0 * (np.asarray(n, float) / N0) ** (-self.waviness)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["road_class"] = self.road_class
        return d


def road_class(gd0: float) -> str:
    """ISO 8608 class whose range (half to double its mean) holds Gd(n0) (m^3)."""
    letters = "ABCDEFGH"
    i = int(np.round(np.log(gd0 / ROAD_CLASS_GD0["A"]) / np.log(4.0)))
    if i < 0:
        return "A (smoother than class A's range)"
    if i >= len(letters):
        return "H (rougher than class H's range)"
    return letters[i]


def _lines(rec_or_z: Any, dx: float | None, band: tuple[float, float]):
    if isinstance(rec_or_z, Recording):
        z, dx = _profile(rec_or_z)
    else:
        z = np.asarray(rec_or_z, float)
    if dx is None:
        raise ValidationError("dx must be given with a bare elevation array")
    n, I_ = slope_periodogram(z, dx)
    lo, hi = band
    if not 0 < lo < hi:
        raise ValidationError(f"`0 < low < high` must hold for the band, but got ({lo}, {hi})")
    sel = (n >= lo) & (n <= hi)
    if sel.sum() < 8:
        raise ValidationError(
            f"the band {band} cycle/m must hold >= 8 Fourier lines of the profile, but holds "
            f"{int(sel.sum())} (length {len(z) * dx:.1f} m, dx {dx} m)"
        )
    return n[sel], I_[sel] / difference_gain(n[sel], dx)


def _whittle(n: np.ndarray, ratio: np.ndarray, gd0: float, w: float) -> float:
    """Whittle log-likelihood of lines ``ratio`` = I / gain against Gd(n) (the gain's
    log is a constant that cancels in every comparison and is left out)."""
    s = gd0 * (n / N0) ** (-w)
    return float(-np.sum(np.log(s) + ratio / s))


def _gd0_hat(n: np.ndarray, ratio: np.ndarray, w: float) -> float:
    return float(np.mean(ratio * (n / N0) ** w))


def fit_psd(
    rec: Any,
    dx: float | None = None,
    band: tuple[float, float] = DEFAULT_BAND,
    waviness: float | None = None,
) -> PsdFit:
    """Whittle fit of (Gd(n0), w) to a profile (``waviness`` given: w fixed at it)."""
    n, ratio = _lines(rec, dx, band)

    def nll(w: float) -> float:
        return -_whittle(n, ratio, _gd0_hat(n, ratio, w), w)

    if waviness is None:
        res = optimize.minimize_scalar(
            nll, bounds=(0.2, 6.0), method="bounded", options={"xatol": 1e-6}
        )
        w = float(res.x)
    else:
        w = float(waviness)
    gd0 = _gd0_hat(n, ratio, w)
    X = np.column_stack([np.ones_like(n), -np.log(n / N0)])
    cov = np.linalg.inv(X.T @ X)
    if waviness is not None:
        cov = np.array([[1.0 / n.size, 0.0], [0.0, 0.0]])
    se_a = float(np.sqrt(cov[0, 0]))
    return PsdFit(
        gd0=gd0,
        gd0_ci95=(gd0 * float(np.exp(-1.96 * se_a)), gd0 * float(np.exp(1.96 * se_a))),
        waviness=w,
        waviness_se=float(np.sqrt(cov[1, 1])),
        loglik=_whittle(n, ratio, gd0, w),
        n_lines=int(n.size),
        band=(float(band[0]), float(band[1])),
        fixed_waviness=waviness is not None,
    )


def heldout_loglik(fit: PsdFit, rec: Any, dx: float | None = None) -> float:
    """Whittle log-likelihood per line of another profile under ``fit`` (no refit)."""
    n, ratio = _lines(rec, dx, fit.band)
    return _whittle(n, ratio, fit.gd0, fit.waviness) / n.size


# ------------------------------------------------------------------ diagnosis
@dataclass
class WavinessTest:
    """Free fit vs the standard's w = 2: LR statistic, p-value, BIC change."""

    lr_statistic: float
    p_value: float
    delta_bic: float
    significant: bool
    direction: str  # "steeper", "shallower" or ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def waviness_test(free: PsdFit, standard: PsdFit, alpha: float = 0.01) -> WavinessTest:
    lr = max(2.0 * (free.loglik - standard.loglik), 0.0)
    p = float(stats.chi2.sf(lr, 1))
    dbic = -lr + np.log(free.n_lines)
    sig = bool(p < alpha and dbic < 0)
    direction = ""
    if sig:
        direction = "steeper" if free.waviness > STANDARD_WAVINESS else "shallower"
    return WavinessTest(lr, p, float(dbic), sig, direction)


@dataclass
class RoadDiagnosis:
    """Outcome of :func:`diagnose_road`; ``to_dict()`` is the machine-readable report."""

    recording: str
    family: str
    verdict: str
    named: list[dict[str, Any]]
    free: PsdFit
    standard: PsdFit
    test: WavinessTest
    heldout: dict[str, Any]
    ride: dict[str, Any]
    octave_bands: list[dict[str, float]]
    seconds: float
    welch: tuple[np.ndarray, np.ndarray] = field(repr=False, default=None)  # type: ignore[assignment]
    recordings: list[Recording] = field(repr=False, default_factory=list)

    @property
    def named_kinds(self) -> list[str]:
        return [h["kind"] for h in self.named]

    def to_dict(self) -> dict[str, Any]:
        return {
            "recording": self.recording,
            "family": self.family,
            "verdict": self.verdict,
            "named": self.named,
            "free_fit": self.free.to_dict(),
            "standard_fit": self.standard.to_dict(),
            "test": self.test.to_dict(),
            "heldout": self.heldout,
            "ride": self.ride,
            "octave_bands": self.octave_bands,
            "seconds": self.seconds,
        }


def octave_table(rec: Recording, free: PsdFit, standard: PsdFit) -> list[dict[str, float]]:
    """Per octave band of the fitted band: mean periodogram / model, both fits."""
    n, ratio = _lines(rec, None, free.band)
    rows, lo = [], free.band[0]
    while lo < free.band[1]:
        sel = (n >= lo) & (n < 2 * lo)
        if sel.sum() >= 2:
            rows.append(
                {
                    "n_low": float(lo),
                    "n_high": float(2 * lo),
                    "lines": int(sel.sum()),
                    "measured_over_free": float(np.mean(ratio[sel] / free.psd(n[sel]))),
                    "measured_over_standard": float(np.mean(ratio[sel] / standard.psd(n[sel]))),
                }
            )
        lo *= 2
    return rows


def _halves(rec: Recording) -> tuple[Recording, Recording]:
    k = rec.n_samples // 2
    return (
        rec.select(slice(0, k), f"{rec.name}:first_half"),
        rec.select(slice(k, None), f"{rec.name}:second_half"),
    )


def diagnose_road(
    recording: Recording | str | Path,
    heldout: Recording | str | Path | None = None,
    band: tuple[float, float] = DEFAULT_BAND,
    alpha: float = 0.01,
    ride: bool = True,
    ride_speed_kmh: float = 80.0,
    ride_seeds: tuple[int, ...] = (0, 1, 2),
) -> RoadDiagnosis:
    """Diagnose a measured road profile against ISO 8608 (see the module docstring).

    Args:
        recording: a profile Recording (or a ``profile_*.txt`` path).
        heldout: another profile for the held-out check (default: the second half of
            ``recording``; the fit for that check then uses the first half).
        band: fitted spatial-frequency band (cycle/m).
        alpha: significance level of the likelihood-ratio test.
        ride: also compute the ride consequence (a few short ride-model runs).
    """
    t0 = time.perf_counter()
    rec = recording if isinstance(recording, Recording) else load_profile_txt(recording)
    free = fit_psd(rec, band=band)
    std = fit_psd(rec, band=band, waviness=STANDARD_WAVINESS)
    test = waviness_test(free, std, alpha)

    if heldout is None:
        fit_part, held = _halves(rec)
        how = f"fit on the first half of {rec.name}, validate on its second half"
    else:
        held = heldout if isinstance(heldout, Recording) else load_profile_txt(heldout)
        fit_part = rec
        how = f"fit on {rec.name}, validate on {held.name}"
    f_free = fit_psd(fit_part, band=band)
    f_std = fit_psd(fit_part, band=band, waviness=STANDARD_WAVINESS)
    held_free = fit_psd(held, band=band)
    ll_free = heldout_loglik(f_free, held)
    ll_std = heldout_loglik(f_std, held)
    z = (held_free.waviness - f_free.waviness) / np.hypot(held_free.waviness_se, f_free.waviness_se)
    heldout_info = {
        "description": how,
        "fit_waviness": f_free.waviness,
        "fit_waviness_se": f_free.waviness_se,
        "heldout_waviness": held_free.waviness,
        "heldout_waviness_se": held_free.waviness_se,
        "waviness_agreement_z": float(z),
        "heldout_loglik_per_line_free": ll_free,
        "heldout_loglik_per_line_standard": ll_std,
        "heldout_loglik_gain_per_line": ll_free - ll_std,
        "heldout_lines": held_free.n_lines,
        "heldout_test": waviness_test(
            held_free, fit_psd(held, band=band, waviness=STANDARD_WAVINESS), alpha
        ).to_dict(),
    }

    named = []
    if test.significant:
        words = f"waviness {test.direction} than ISO 8608's 2 (w = {free.waviness:.2f} " + (
            f"+- {free.waviness_se:.2f})"
        )
        named.append(
            {
                "kind": f"waviness_{test.direction}",
                "family": "road_spectrum",
                "words": words,
                "params": {
                    "waviness": {"value": free.waviness, "stderr": free.waviness_se},
                    "gd0": {"value": free.gd0, "ci95": list(free.gd0_ci95)},
                },
            }
        )
        verdict = (
            f"{words}; class {free.road_class} by Gd(n0) = {free.gd0 * 1e6:.1f}e-6 m^3 "
            f"(LR = {test.lr_statistic:.1f}, p = {test.p_value:.2g}, dBIC = {test.delta_bic:.1f})"
        )
    else:
        verdict = (
            f"no significant waviness deviation from ISO 8608's 2 (w = {free.waviness:.2f} +- "
            f"{free.waviness_se:.2f}, p = {test.p_value:.2g}); class {std.road_class} by "
            f"Gd(n0) = {std.gd0 * 1e6:.1f}e-6 m^3"
        )
    ride_info: dict[str, Any] = {}
    if ride:
        ride_info = ride_consequence(free, std, rec, ride_speed_kmh, ride_seeds)
        if ride_info:
            verdict += (
                f". Ride: Wk-weighted RMS at {ride_speed_kmh:g} km/h front "
                f"{ride_info['aw_front_measured_spectrum']:.3f} vs "
                f"{ride_info['aw_front_standard']:.3f} m/s^2 on the w = 2 fit "
                f"({100 * (ride_info['ratio_front'] - 1):+.0f} %)"
            )
    return RoadDiagnosis(
        recording=rec.name,
        family="road_profile",
        verdict=verdict,
        named=named,
        free=free,
        standard=std,
        test=test,
        heldout=heldout_info,
        ride=ride_info,
        octave_bands=octave_table(rec, free, std),
        seconds=time.perf_counter() - t0,
        welch=welch_spatial_psd(*_profile(rec)),
        recordings=[rec, held],
    )


# ------------------------------------------------------------------ ride consequence
def _inputs_from_profile(
    prof: RoadProfile, speed: float, dt: float, n_settle: int, n_steps: int, wheelbase: float
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel inputs (2N+1, 4) on the half-step grid from a periodic two-track profile."""
    period = prof.left.size
    m = 2 * n_steps + 1
    rl, rr = prof.shifted(wheelbase)
    sfl, sfr = prof.slopes()
    srl, srr = prof.slopes(wheelbase)
    idx = (np.arange(m) - 2 * n_settle) % period
    z = np.stack([prof.left, prof.right, rl, rr], axis=1)[idx]
    zd = speed * np.stack([sfl, sfr, srl, srr], axis=1)[idx]
    return z, zd


def _in_phase_inputs(
    track: np.ndarray, dx: float, speed: float, n_steps: int, wheelbase: float
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel inputs (2N+1, 4) with one track under both sides; the rear axle starts
    ``wheelbase`` further along the track (its first metres are driven on by the rear
    wheels only after the front ones). Grid step ``dx`` = speed * dt / 2."""
    m = 2 * n_steps + 1
    lag = wheelbase / dx
    x = np.arange(m, dtype=float) + np.ceil(lag)
    front = np.interp(x, np.arange(track.size), track)
    rear = np.interp(x - lag, np.arange(track.size), track)
    slope = np.gradient(track, dx)
    sf = np.interp(x, np.arange(track.size), slope)
    sr = np.interp(x - lag, np.arange(track.size), slope)
    z = np.stack([front, front, rear, rear], axis=1)
    zd = speed * np.stack([sf, sf, sr, sr], axis=1)
    return z - z[0], zd


def ride_consequence(
    free: PsdFit,
    standard: PsdFit,
    measured: Recording | None = None,
    speed_kmh: float = 80.0,
    seeds: tuple[int, ...] = (0, 1, 2),
    duration_s: float = 10.0,
    sample_rate: float = 100.0,
) -> dict[str, Any]:
    """Weighted RMS (m/s^2) of the reference minibus (study pick, no load) on roads with
    the fitted spectrum vs the standard-waviness fit (mean over ``seeds``), and on the
    measured profile itself with both tracks in phase vs a w = 2 road in phase."""
    from suspenv.metrics.iso2631 import weighted_rms_fft
    from suspenv.models.minibus import REFERENCE_MINIBUS, STUDY_PICK, vehicle_parameters
    from suspenv.models.minibus.ride_model import RideModel

    veh = REFERENCE_MINIBUS
    model = RideModel(vehicle_parameters(STUDY_PICK[None, :], "no_load", veh))
    v = speed_kmh / 3.6
    dt = 1.0 / sample_rate
    n_settle = int(sample_rate)
    n_rec = int(round(duration_s * sample_rate))
    n_steps = n_settle + n_rec
    dx = v * dt / 2.0
    length = 2 * n_rec * dx

    def aw(prof: RoadProfile) -> tuple[float, float]:
        z, zd = _inputs_from_profile(prof, v, dt, n_settle, n_steps, veh.wheelbase)
        rec = model.simulate(z, zd, dt, discard=n_settle)
        return (
            float(weighted_rms_fft(rec.acc_front, sample_rate, "Wk")[0]),
            float(weighted_rms_fft(rec.acc_rear, sample_rate, "Wk")[0]),
        )

    out: dict[str, Any] = {"speed_kmh": speed_kmh, "seeds": list(seeds), "design": "study pick"}
    res: dict[str, list[tuple[float, float]]] = {"measured_spectrum": [], "standard": []}
    for s in seeds:
        for key, fit in (("measured_spectrum", free), ("standard", standard)):
            prof = generate_profile(length, dx, fit.gd0, s, veh.track_front, waviness=fit.waviness)
            res[key].append(aw(prof))
    for key, vals in res.items():
        arr = np.array(vals)
        out[f"aw_front_{key}"] = float(arr[:, 0].mean())
        out[f"aw_rear_{key}"] = float(arr[:, 1].mean())
        out[f"aw_front_{key}_seed_std"] = float(arr[:, 0].std(ddof=1)) if len(arr) > 1 else 0.0
        out[f"aw_rear_{key}_seed_std"] = float(arr[:, 1].std(ddof=1)) if len(arr) > 1 else 0.0
    out["ratio_front"] = out["aw_front_measured_spectrum"] / out["aw_front_standard"]
    out["ratio_rear"] = out["aw_rear_measured_spectrum"] / out["aw_rear_standard"]
    if measured is not None:
        z_m, dx_m = _profile(measured)
        span = (len(z_m) - 1) * dx_m
        n_fit = int(np.floor(span / dx))
        if n_fit > 2 * (n_settle + 8):
            # the measured track resampled to the simulation's half-step grid, in phase on
            # both sides; periodic continuation is not needed (runs cover the profile)
            xs = dx * np.arange(n_fit)
            zm = np.interp(xs, dx_m * np.arange(len(z_m)), z_m)
            zm = zm - np.linspace(zm[0], zm[-1], zm.size)
            std_prof = generate_profile(
                n_fit * dx, dx, standard.gd0, seeds[0] if seeds else 0, None, waviness=2.0
            )
            n_run = min((n_fit - 1) // 2 - int(np.ceil(veh.wheelbase / dx)) - 2, 3 * n_steps)
            a_m: list[float] = []
            a_s: list[float] = []
            for track, acc in ((zm, a_m), (std_prof.left, a_s)):
                z, zd = _in_phase_inputs(track, dx, v, n_run, veh.wheelbase)
                r = model.simulate(z, zd, dt, discard=n_settle)
                acc += [
                    float(weighted_rms_fft(r.acc_front, sample_rate, "Wk")[0]),
                    float(weighted_rms_fft(r.acc_rear, sample_rate, "Wk")[0]),
                ]
            out["aw_front_measured_profile_in_phase"] = a_m[0]
            out["aw_rear_measured_profile_in_phase"] = a_m[1]
            out["aw_front_standard_in_phase"] = a_s[0]
            out["aw_rear_standard_in_phase"] = a_s[1]
    return out
