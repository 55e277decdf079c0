"""Excitations: imposed motions and forces as functions of continuous time.

Every excitation evaluates at a scalar time (inside an ODE right-hand side) and at an
array of sample times. Units: time [s], displacement [m], velocity [m/s], acceleration
[m/s^2], force [N]. Signs are those of the device that uses the signal (a damper's
stroke is positive in compression; a road is positive upwards).

* :class:`SineBlocks` -- blocks of sines (dyno and shaking-table tests), each faded in
  and out over half a cycle with a raised cosine, separated by rests;
* :class:`MinJerkPath` -- point-to-point moves with the minimum-jerk quintic profile
  (Flash and Hogan 1985), alternating in direction, with dwells (guide reference);
* :class:`SumOfSines` -- a band-limited random signal (random phases) or a logarithmic
  swept sine, faded in and out, plus raised-cosine bumps (shaker road, actuator force).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field

import numpy as np


def _fade(tau: np.ndarray, length: float, ramp: float) -> tuple[np.ndarray, ...]:
    """Raised-cosine fade-in over ``[0, ramp]`` and fade-out over ``[length - ramp, length]``:
    the window ``w`` and its first two derivatives with respect to ``tau`` [s]."""
    w = np.ones_like(tau)
    dw = np.zeros_like(tau)
    ddw = np.zeros_like(tau)
    k = math.pi / ramp
    head = tau < ramp
    tail = tau > length - ramp
    for mask, s, sign in ((head, tau, 1.0), (tail, length - tau, -1.0)):
        if np.any(mask):
            u = s[mask]
            w[mask] = 0.5 * (1.0 - np.cos(k * u))
            dw[mask] = sign * 0.5 * k * np.sin(k * u)
            ddw[mask] = 0.5 * k * k * np.cos(k * u)
    return w, dw, ddw


@dataclass
class SineBlocks:
    """Faded sine blocks ``A sin(2 pi f tau)`` with rests between them.

    Attributes:
        blocks: ``(amplitude [m], frequency [Hz], cycles)`` per block, in order.
        rest: rest before, between and after the blocks [s].
    """

    blocks: list[tuple[float, float, int]]
    rest: float = 0.3
    starts: list[float] = field(init=False)
    lengths: list[float] = field(init=False)

    def __post_init__(self) -> None:
        self.starts, self.lengths = [], []
        t = self.rest
        for _, f, n in self.blocks:
            self.starts.append(t)
            self.lengths.append(n / f)
            t += n / f + self.rest
        self.duration = t

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Displacement [m], velocity [m/s] and acceleration [m/s^2] at times ``t`` [s]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        x, v, a = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
        for (amp, f, _), t0, length in zip(self.blocks, self.starts, self.lengths, strict=True):
            m = (t >= t0) & (t <= t0 + length)
            if not np.any(m):
                continue
            tau = t[m] - t0
            w, dw, ddw = _fade(tau, length, 0.5 / f)
            om = 2.0 * math.pi * f
            s, c = np.sin(om * tau), np.cos(om * tau)
            x[m] = amp * w * s
            v[m] = amp * (dw * s + w * om * c)
            a[m] = amp * (ddw * s + 2.0 * dw * om * c - w * om * om * s)
        return x, v, a

    def at(self, t: float) -> tuple[float, float]:
        """Displacement [m] and velocity [m/s] at one time ``t`` [s] (fast scalar path)."""
        i = bisect_right(self.starts, t) - 1
        if i < 0:
            return 0.0, 0.0
        tau = t - self.starts[i]
        length = self.lengths[i]
        if tau > length:
            return 0.0, 0.0
        amp, f, _ = self.blocks[i]
        om = 2.0 * math.pi * f
        ramp = 0.5 / f
        k = math.pi / ramp
        if tau < ramp:
            w, dw = 0.5 * (1.0 - math.cos(k * tau)), 0.5 * k * math.sin(k * tau)
        elif tau > length - ramp:
            u = length - tau
            w, dw = 0.5 * (1.0 - math.cos(k * u)), -0.5 * k * math.sin(k * u)
        else:
            w, dw = 1.0, 0.0
        s, c = math.sin(om * tau), math.cos(om * tau)
        return amp * w * s, amp * (dw * s + w * om * c)

    def describe(self) -> dict[str, object]:
        return {
            "kind": "faded sine blocks",
            "blocks": [
                {"amplitude_m": a, "frequency_hz": f, "cycles": n} for a, f, n in self.blocks
            ],
            "rest_s": self.rest,
        }


@dataclass
class MinJerkPath:
    """Minimum-jerk moves between waypoints with dwells (reference of a position loop).

    Attributes:
        waypoints: positions [m]; the path starts at ``waypoints[0]``.
        durations: duration of each move [s] (``len(waypoints) - 1`` of them).
        dwell: rest after each move and before the first [s].
    """

    waypoints: list[float]
    durations: list[float]
    dwell: list[float]
    starts: list[float] = field(init=False)

    def __post_init__(self) -> None:
        self.starts = []
        t = self.dwell[0]
        for d, rest in zip(self.durations, self.dwell[1:], strict=True):
            self.starts.append(t)
            t += d + rest
        self.duration = t

    def at(self, t: float) -> tuple[float, float, float]:
        """Position [m], velocity [m/s], acceleration [m/s^2] at one time ``t`` [s]."""
        i = bisect_right(self.starts, t) - 1
        if i < 0:
            return self.waypoints[0], 0.0, 0.0
        d = self.durations[i]
        p0, p1 = self.waypoints[i], self.waypoints[i + 1]
        s = (t - self.starts[i]) / d
        if s >= 1.0:
            return p1, 0.0, 0.0
        dp = p1 - p0
        s2 = s * s
        pos = p0 + dp * s2 * s * (10.0 - 15.0 * s + 6.0 * s2)
        vel = dp / d * 30.0 * s2 * (1.0 - s) ** 2
        acc = dp / (d * d) * 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s)
        return pos, vel, acc

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position [m], velocity [m/s], acceleration [m/s^2] at times ``t`` [s]."""
        out = np.array([self.at(float(ti)) for ti in np.atleast_1d(t)])
        return out[:, 0], out[:, 1], out[:, 2]

    def describe(self) -> dict[str, object]:
        return {
            "kind": "minimum-jerk point-to-point moves (Flash and Hogan 1985)",
            "waypoints_m": self.waypoints,
            "durations_s": self.durations,
            "dwell_s": self.dwell,
        }


@dataclass
class SumOfSines:
    """``fade(t) * sum_i a_i sin(w_i t + phi_i)`` or a log sweep, plus raised-cosine bumps.

    Attributes:
        amps, omegas, phases: sine components ([unit], [rad/s], [rad]); empty for a sweep.
        duration: length of the faded part [s]; fade ramps ``ramp`` [s].
        sweep: ``(f0 [Hz], f1 [Hz], velocity amplitude [unit/s], max amplitude [unit])`` of a
            logarithmic sweep over ``duration`` (amplitude = velocity / (2 pi f), capped), or
            None.
        bumps: ``(start [s], length [s], height [unit])``: ``h sin^2(pi (t - t0) / L)``.
        scale: a factor on everything.
    """

    amps: np.ndarray
    omegas: np.ndarray
    phases: np.ndarray
    duration: float
    ramp: float = 1.0
    sweep: tuple[float, float, float, float] | None = None
    bumps: list[tuple[float, float, float]] = field(default_factory=list)
    scale: float = 1.0

    def _fade1(self, t: float) -> float:
        if t <= 0.0 or t >= self.duration:
            return 0.0
        u = min(t, self.duration - t)
        if u >= self.ramp:
            return 1.0
        return 0.5 * (1.0 - math.cos(math.pi * u / self.ramp))

    def at(self, t: float) -> float:
        """The signal at one time ``t`` [s]."""
        val = 0.0
        w = self._fade1(t)
        if w > 0.0:
            if self.sweep is None:
                val = w * float(np.dot(self.amps, np.sin(self.omegas * t + self.phases)))
            else:
                f0, f1, vel, amax = self.sweep
                r = f1 / f0
                frac = t / self.duration
                f = f0 * r**frac
                phase = 2.0 * math.pi * f0 * self.duration / math.log(r) * (r**frac - 1.0)
                val = w * min(vel / (2.0 * math.pi * f), amax) * math.sin(phase)
        for t0, length, h in self.bumps:
            if t0 < t < t0 + length:
                val += h * math.sin(math.pi * (t - t0) / length) ** 2
        return self.scale * val

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """The signal at times ``t`` [s] (vectorised; equals :meth:`at`)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        inside = (t > 0.0) & (t < self.duration)
        u = np.minimum(t, self.duration - t)
        w = np.where(u >= self.ramp, 1.0, 0.5 * (1.0 - np.cos(math.pi * u / self.ramp)))
        w = np.where(inside, w, 0.0)
        val = np.zeros_like(t)
        if self.sweep is None:
            for lo in range(0, t.size, 4096):
                tt = t[lo : lo + 4096]
                val[lo : lo + 4096] = np.sin(np.outer(tt, self.omegas) + self.phases) @ self.amps
        else:
            f0, f1, vel, amax = self.sweep
            r = f1 / f0
            frac = t / self.duration
            f = f0 * r**frac
            phase = 2.0 * math.pi * f0 * self.duration / math.log(r) * (r**frac - 1.0)
            val = np.minimum(vel / (2.0 * math.pi * f), amax) * np.sin(phase)
        val = val * w
        for t0, length, h in self.bumps:
            m = (t > t0) & (t < t0 + length)
            val[m] += h * np.sin(math.pi * (t[m] - t0) / length) ** 2
        return self.scale * val

    def describe(self) -> dict[str, object]:
        out: dict[str, object] = {"duration_s": self.duration, "fade_s": self.ramp}
        if self.sweep is None:
            out["kind"] = "band-limited random (sum of sines, random phases)"
            out["band_hz"] = [
                float(self.omegas.min() / (2 * math.pi)),
                float(self.omegas.max() / (2 * math.pi)),
            ]
            out["components"] = int(self.amps.size)
        else:
            out["kind"] = "logarithmic swept sine, constant velocity amplitude (capped)"
            out["sweep"] = {
                "f0_hz": self.sweep[0],
                "f1_hz": self.sweep[1],
                "velocity_amplitude": self.sweep[2] * self.scale,
                "max_amplitude": self.sweep[3] * self.scale,
            }
        out["bumps"] = [
            {"start_s": a, "length_s": b, "height": c * self.scale} for a, b, c in self.bumps
        ]
        out["scale"] = self.scale
        return out


class Tabulated:
    """A signal tabulated every ``h`` [s] and read back by Catmull-Rom cubic interpolation
    (continuous first derivative, error of order ``h^4`` times the fourth derivative), a
    fast stand-in for :meth:`SumOfSines.at` inside an ODE right-hand side."""

    def __init__(self, signal: SumOfSines, t_end: float, h: float) -> None:
        self.h = h
        n = int(math.ceil(t_end / h)) + 4
        grid = (np.arange(n + 1) - 1) * h
        self.values: list[float] = signal.evaluate(grid).tolist()
        self.n = n

    def at(self, t: float) -> float:
        """The signal at one time ``t`` [s]."""
        u = t / self.h
        i = min(max(int(u), 0), self.n - 3)
        f = u - i
        p0, p1, p2, p3 = self.values[i : i + 4]
        return p1 + 0.5 * f * (
            p2 - p0 + f * (2 * p0 - 5 * p1 + 4 * p2 - p3 + f * (3 * (p1 - p2) + p3 - p0))
        )
