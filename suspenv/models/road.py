"""ISO 8608 random road profiles (two correlated wheel tracks) and discrete obstacles.

Frame and units: distance x along the road (m, + in the direction of travel), road
elevation z (m, + up), spatial frequency n (cycle/m), temporal frequency f (Hz).
PSDs are one-sided: the variance is the integral of the PSD over n >= 0.

ISO 8608 (identical to GB/T 7031): Gd(n) = Gd(n0) (n/n0)^-w with n0 = 0.1 cycle/m and
w = 2; the class *mean* values of Gd(n0) are used (A = 16e-6 m^3 ... H = 262144e-6
m^3; each class spans half to double its mean).

Profiles are synthesised as a sum of harmonics with random phases on the FFT grid
(one inverse real FFT): exact PSD in expectation on every line, periodic over the
generated length, so delays (the rear axle sees the front track ``L`` later) are
exact phase shifts. Left/right tracks of an isotropic w = 2 road have coherency
``rho(n) = 2 pi n B K1(2 pi n B)`` (B track width, K1 the modified Bessel function of
the second kind); per line ``Z_R = A (rho e^{j phi} + sqrt(1 - rho^2) e^{j psi})``
gives that coherency exactly.

Also the road of a random-road ride run (:class:`RandomRoad`) and the wheel inputs a
two-axle vehicle reads from a profile (:func:`profile_inputs`, :func:`in_phase_inputs`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import k1 as bessel_k1

from suspenv.core.errors import ValidationError
from suspenv.core.options import positive

#: reference spatial frequency of ISO 8608 (cycle/m)
N0 = 0.1
#: class means of Gd(n0) in m^3 (ISO 8608 Table; geometric centre of each class)
ROAD_CLASS_GD0: dict[str, float] = {c: 16e-6 * 4.0**i for i, c in enumerate("ABCDEFGH")}
#: ISO 8608 classification band (cycle/m)
CLASS_BAND: tuple[float, float] = (0.011, 2.83)


def class_gd0(road_class: str | float) -> float:
    """Gd(n0) (m^3) of a class letter "A".."H" (its mean) or a number passed through."""
    if isinstance(road_class, str):
        key = road_class.strip().upper()
        if key not in ROAD_CLASS_GD0:
            raise ValidationError(
                f"road class must be one of {sorted(ROAD_CLASS_GD0)}, but got {road_class!r}"
            )
        return ROAD_CLASS_GD0[key]
    value = float(road_class)
    if not value > 0:
        raise ValidationError(f"`Gd(n0) > 0` must hold, but got {value}")
    return value


def gd0_class(gd0: float) -> str:
    """ISO 8608 class whose range (half to double its mean) holds Gd(n0) (m^3)."""
    letters = "ABCDEFGH"
    i = int(np.round(np.log(gd0 / ROAD_CLASS_GD0["A"]) / np.log(4.0)))
    if i < 0:
        return "A (smoother than class A's range)"
    if i >= len(letters):
        return "H (rougher than class H's range)"
    return letters[i]


def displacement_psd(
    n: np.ndarray, road_class: str | float = "B", waviness: float = 2.0
) -> np.ndarray:
    """One-sided spatial displacement PSD Gd(n) (m^3) at spatial frequencies n (cycle/m)."""
    n = np.asarray(n, dtype=float)
    with np.errstate(divide="ignore"):
        return class_gd0(road_class) * (n / N0) ** (-waviness)


def temporal_psd(
    f: np.ndarray, speed: float, road_class: str | float = "B", waviness: float = 2.0
) -> np.ndarray:
    """One-sided temporal displacement PSD Gq(f) = Gd(f/v)/v (m^2/Hz) at speed v (m/s)."""
    return displacement_psd(np.asarray(f, dtype=float) / speed, road_class, waviness) / speed


def track_coherence(n: np.ndarray, track: float) -> np.ndarray:
    """Left/right coherency rho(n) = 2 pi n B K1(2 pi n B) of an isotropic w = 2 road."""
    x = 2.0 * np.pi * np.asarray(n, dtype=float) * track
    with np.errstate(invalid="ignore"):
        rho = np.where(x > 0, x * bessel_k1(np.maximum(x, 1e-300)), 1.0)
    return np.clip(rho, 0.0, 1.0)


@dataclass(frozen=True)
class RoadProfile:
    """Two wheel tracks sampled on a uniform grid; periodic over their sampled length.

    Attributes:
        dx: sample spacing (m).
        left, right: elevation (m), shape (N,).
        spectra: complex line amplitudes (2, N//2 + 1) of left/right (irfft convention),
            kept so delayed copies and slopes are exact.
    """

    dx: float
    left: np.ndarray
    right: np.ndarray
    spectra: np.ndarray

    def shifted(self, distance: float) -> tuple[np.ndarray, np.ndarray]:
        """Tracks delayed by ``distance`` (m): z(x - distance), exact on the periodic profile."""
        n = np.fft.rfftfreq(self.left.shape[0], self.dx)
        phase = np.exp(-2j * np.pi * n * distance)
        out = np.fft.irfft(self.spectra * phase, n=self.left.shape[0], axis=-1)
        return out[0], out[1]

    def enveloped(self, contact_length: float) -> RoadProfile:
        """The profile averaged over a tyre contact length (m): moving mean, exact spectrally.

        A moving average of length ``l`` multiplies each line by sinc(n l), so a point
        contact rides the smoothed profile a real footprint feels.
        """
        if contact_length < 0:
            raise ValidationError(f"`contact_length >= 0` must hold, but got {contact_length}")
        n = np.fft.rfftfreq(self.left.shape[0], self.dx)
        spectra = self.spectra * np.sinc(n * contact_length)
        z = np.fft.irfft(spectra, n=self.left.shape[0], axis=-1)
        return RoadProfile(dx=self.dx, left=z[0], right=z[1], spectra=spectra)

    def slopes(self, distance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Spatial derivatives dz/dx (-) of the (delayed) tracks, spectrally exact."""
        n = np.fft.rfftfreq(self.left.shape[0], self.dx)
        factor = 2j * np.pi * n * np.exp(-2j * np.pi * n * distance)
        out = np.fft.irfft(self.spectra * factor, n=self.left.shape[0], axis=-1)
        return out[0], out[1]


def generate_profile(
    length: float,
    dx: float,
    road_class: str | float = "B",
    seed: int | None = 0,
    track: float | None = 1.5,
    band: tuple[float, float] = CLASS_BAND,
    waviness: float = 2.0,
) -> RoadProfile:
    """Random ISO 8608 profile of two tracks ``track`` m apart (None: independent tracks).

    Lines outside ``band`` (cycle/m) and above the grid's Nyquist frequency are zero.
    The line amplitude is ``sqrt(2 Gd(n_k) dn)``, so the expected one-sided PSD on
    every line is Gd(n_k) and the variance is sum(Gd dn) (the class formula's integral).
    """
    if not (length > 0 and dx > 0 and length >= 4 * dx):
        raise ValidationError(f"`length >= 4 dx > 0` must hold, but got (length={length}, dx={dx})")
    n_pts = int(round(length / dx))
    n = np.fft.rfftfreq(n_pts, dx)
    dn = 1.0 / (n_pts * dx)
    inside = (n >= band[0]) & (n <= band[1]) & (n > 0)
    if n_pts % 2 == 0:
        inside[-1] = False  # the Nyquist line carries no phase; leave it out
    amp = np.zeros_like(n)
    amp[inside] = np.sqrt(2.0 * displacement_psd(n[inside], road_class, waviness) * dn)
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.0, 2 * np.pi, n.shape)
    psi = rng.uniform(0.0, 2 * np.pi, n.shape)
    left = amp * np.exp(1j * phi)
    if track is None:
        right = amp * np.exp(1j * psi)
    else:
        rho = track_coherence(n, track)
        right = amp * (rho * np.exp(1j * phi) + np.sqrt(1.0 - rho**2) * np.exp(1j * psi))
    spectra = np.vstack([left, right]) * (n_pts / 2.0)
    z = np.fft.irfft(spectra, n=n_pts, axis=-1)
    return RoadProfile(dx=dx, left=z[0], right=z[1], spectra=spectra)


def welch_psd(
    z: np.ndarray, dx: float, segment_length: float = 200.0
) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD (m^3 for a spatial signal) of z sampled every dx (m)."""
    from scipy.signal import welch

    nper = min(int(round(segment_length / dx)), np.shape(z)[-1])
    return welch(z, fs=1.0 / dx, nperseg=nper, axis=-1)


# ------------------------------------------------------------------ random road run
@dataclass(frozen=True)
class RandomRoad:
    """Settings of a random-road ride run (:mod:`suspenv.rigs.ride` gives the defaults)."""

    road_class: str | float = "B"
    speed_kmh: float = 80.0
    duration_s: float = 10.0
    settle_s: float = 1.0
    sample_rate: float = 100.0
    seed: int = 0
    #: tyre contact length (m) for enveloping, or None for a point contact
    enveloping: float | None = None

    def __post_init__(self) -> None:
        if not (self.speed_kmh > 0 and self.duration_s > 0 and self.settle_s >= 0):
            raise ValidationError(
                "random road needs `speed_kmh > 0`, `duration_s > 0`, `settle_s >= 0`, but "
                f"got ({self.speed_kmh}, {self.duration_s}, {self.settle_s})"
            )
        if not self.sample_rate >= 50:
            raise ValidationError(
                f"`sample_rate >= 50` Hz must hold (wheel hop ~12 Hz), but got {self.sample_rate}"
            )

    @property
    def speed(self) -> float:
        """m/s"""
        return self.speed_kmh / 3.6

    @property
    def dt(self) -> float:
        return 1.0 / self.sample_rate

    @property
    def n_settle(self) -> int:
        return int(round(self.settle_s * self.sample_rate))

    @property
    def n_steps(self) -> int:
        return self.n_settle + int(round(self.duration_s * self.sample_rate))


def profile_inputs(
    prof: RoadProfile, speed: float, m: int, n_settle: int, wheelbase: float
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel inputs (m, 4) on the half-step grid (``prof.dx`` apart) from a periodic
    two-track profile: elevation (m) and rate (m/s) at ``speed`` (m/s), columns FL, FR,
    RL, RR (the rear tracks ``wheelbase`` behind), the profile's start reached after
    ``n_settle`` steps."""
    rl, rr = prof.shifted(wheelbase)
    sfl, sfr = prof.slopes()
    srl, srr = prof.slopes(wheelbase)
    idx = (np.arange(m) - 2 * n_settle) % prof.left.size
    z = np.stack([prof.left, prof.right, rl, rr], axis=1)[idx]
    zd = speed * np.stack([sfl, sfr, srl, srr], axis=1)[idx]
    return z, zd


def in_phase_inputs(
    track: np.ndarray, dx: float, speed: float, n_steps: int, wheelbase: float
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel inputs (2N+1, 4) on the half-step grid from one measured (not periodic)
    ``track`` (m) under both sides: elevation (m, relative to the first sample) and rate
    (m/s) at ``speed`` (m/s), columns FL, FR, RL, RR; the rear axle starts ``wheelbase``
    (m) further along the track (its first metres are driven on by the rear wheels only
    after the front ones). Grid step ``dx`` (m) = speed * dt / 2."""
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


# ------------------------------------------------------------------ obstacles
def triangular_bump(x: np.ndarray, start: float, base: float = 0.4, height: float = 0.06):
    """Elevation (m) of a symmetric triangular bump of ``base`` and ``height`` (m).

    GB/T 4970 pulse input, commonly 400 mm base and 60 mm high.
    """
    positive("triangular_bump", "base", base)
    positive("triangular_bump", "height", height)
    u = (np.asarray(x, dtype=float) - start) / (base / 2.0)
    return height * np.clip(1.0 - np.abs(u - 1.0), 0.0, None)


def contact_length_filter(z: np.ndarray, dx: float, contact_length: float) -> np.ndarray:
    """Moving average of z (m) over the tyre contact length (m): the simplest enveloping.

    A point-contact tyre follows every sharp edge; averaging over the footprint length
    rounds short obstacles as a real tyre does. Length < dx returns z unchanged.
    """
    k = int(round(contact_length / dx))
    if k <= 1:
        return np.asarray(z, dtype=float).copy()
    kernel = np.ones(k) / k
    return np.convolve(np.asarray(z, dtype=float), kernel, mode="same")
