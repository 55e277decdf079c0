"""Force laws of the concealed effects and the label vocabulary.

A one-dimensional element (damper, MR damper, the guide's resistance, a quarter car's
suspension) is described by its stroke ``x`` [m] and stroke rate ``v`` [m/s] in the
element's own sign (for a damper and a suspension positive in compression) and returns a
force [N] that is positive when it resists a positive stroke (a damper pushed in pushes
back; a suspension compressed pushes body and wheel apart; the guide's resistance acts
against positive motion). :class:`ForceLaw` is

    F = f0 + k x + c v + E(x, v, s)

with the base part ``f0 + k x + c v`` and at most one effect ``E`` with internal states
``s`` (``ds/dt = g(x, v, s)``). Effects (params in SI):

* ``friction`` -- ``tanh``: Coulomb smoothed, ``Fc tanh(v / vs)``; ``stribeck``:
  ``Fc (1 + (fs_ratio - 1) exp(-(v / vst)^2)) tanh(v / vs)`` (Stribeck 1902 curve, Armstrong-
  Helouvry et al. 1994); ``lugre``: LuGre (Canudas de Wit, Olsson, Astrom, Lischinsky
  1995) written in force units ``w = sigma0 z``:
  ``dw/dt = sigma0 (v - |v| w / g(v))``, ``F = w + tau_b dw/dt``, ``g`` the Stribeck
  curve, ``sigma0 = Fc / x_pre``; ``bingham``: field-dependent yield of an MR damper
  (Stanway, Sproston, Stevens 1987), ``Fc tanh(v / vs)`` with ``Fc = fy0 + fy1 V``;
* ``hysteresis`` -- Bouc-Wen (Bouc 1967, Wen 1976; Spencer et al. 1997 for MR dampers):
  ``F = alpha z``, ``dz/dt = A v - beta |v| |z|^(n-1) z - gamma v |z|^n`` [z in m];
* ``digressive`` -- a blow-off curve replacing the base slope ``c`` above a knee:
  ``tanh``: ``F - c v = -(c - c_hi)(v - vk tanh(v / vk))``; ``two_slope``:
  ``-(c - c_hi) sign(v) max(|v| - vk, 0)``;
* ``damper_asymmetry`` -- an extra ``dc v`` on one side (``side`` +1 compression, -1
  rebound);
* ``viscoelastic`` -- a Maxwell element (spring ``km`` in series with a dashpot,
  relaxation time ``tau``) in parallel: ``dFm/dt = km v - Fm / tau``;
* ``progressive`` -- ``k3 x^3``;
* ``end_stop`` -- ``ks (x - gap)`` beyond ``gap`` on the chosen side(s);
* out of library: ``cubic_damper`` ``c3 v^3``; ``velocity_dead_zone`` the base viscous
  force vanishes for ``|v| < vdz`` (``-c clip(v, -vdz, vdz)``, continuous);
  ``backlash`` and ``time_delay`` are handled by the devices and the sensor chain.

Each effect has one magnitude parameter (:data:`SCALE_PARAM`) that the case builder
calibrates; for the force laws above the effect force is proportional to it, except the
dead zone width.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

IN_LIBRARY = (
    "friction",
    "hysteresis",
    "digressive",
    "damper_asymmetry",
    "viscoelastic",
    "progressive",
    "end_stop",
    "sensor_offset",
    "sensor_gain",
    "sensor_lag",
)
OUTSIDE = ("cubic_damper", "velocity_dead_zone", "backlash", "time_delay")

#: effect label -> its magnitude parameter
SCALE_PARAM = {
    "friction": "Fc",
    "hysteresis": "alpha",
    "digressive": "dc",
    "damper_asymmetry": "dc",
    "viscoelastic": "km",
    "progressive": "k3",
    "end_stop": "ks",
    "cubic_damper": "c3",
    "velocity_dead_zone": "vdz",
    "backlash": "gap",
    "sensor_offset": "offset",
    "sensor_gain": "gain_error",
    "sensor_lag": "tau",
    "time_delay": "delay",
}

#: what each effect's parameterisation is, for the truth file
MODEL_TEXT = {
    ("friction", "tanh"): "Coulomb friction smoothed with tanh, Fc tanh(v/vs)",
    ("friction", "stribeck"): "Stribeck curve (Armstrong-Helouvry et al. 1994), tanh-smoothed",
    ("friction", "lugre"): "LuGre (Canudas de Wit, Olsson, Astrom, Lischinsky 1995) with "
    "Stribeck curve, bristle force w = sigma0 z",
    ("friction", "bingham"): "Bingham yield force of an MR damper (Stanway et al. 1987), "
    "fy(V) tanh(v/vs), fy = fy0 + fy1 V",
    ("hysteresis", "bouc_wen"): "Bouc-Wen (Bouc 1967; Wen 1976), alpha z",
    ("hysteresis", "bouc_wen_mr"): "Bouc-Wen term of the Spencer et al. (1997) MR damper "
    "model, alpha(V) z with alpha = alpha0 + alpha1 V",
    ("digressive", "tanh"): "digressive: F = c_hi v + (c - c_hi) vk tanh(v/vk)",
    ("digressive", "two_slope"): "digressive two-slope valve curve, knee at vk",
    ("damper_asymmetry", "one_side"): "extra viscous coefficient dc on one stroke side",
    ("viscoelastic", "maxwell"): "Maxwell element (spring km in series with a dashpot "
    "km tau) in parallel",
    ("progressive", "cubic"): "cubic spring k3 x^3",
    ("end_stop", "linear"): "one-sided linear stop stiffness beyond a gap",
    ("cubic_damper", "cubic"): "cubic damping c3 v^3",
    ("velocity_dead_zone", "dead_band"): "viscous force c (v - clip(v, -vdz, vdz))",
    ("backlash", "free_play"): "free play of total width 2 gap in series, regularised "
    "contact stiffness",
    ("sensor_offset", "constant"): "constant offset of the measured channel",
    ("sensor_gain", "constant"): "gain error (1 + gain_error) of the measured channel",
    ("sensor_lag", "first_order"): "first-order lag tau y' + y = u of the measured channel",
    ("time_delay", "pure"): "pure transport delay of the measured channel",
}

STATEFUL = {("friction", "lugre"), ("hysteresis", "bouc_wen"), ("hysteresis", "bouc_wen_mr")}
STATEFUL |= {("viscoelastic", "maxwell")}


@dataclass
class ForceLaw:
    """``F = f0 + k x + c v + E(x, v, s)`` [N]; see the module docstring.

    Attributes:
        f0 [N], k [N/m], c [N s/m]: base part.
        label: effect label or None; variant: its parameterisation; p: its parameters (SI).
    """

    f0: float
    k: float
    c: float
    label: str | None = None
    variant: str = ""
    p: dict[str, float] = field(default_factory=dict)

    @property
    def n_states(self) -> int:
        return 1 if (self.label, self.variant) in STATEFUL else 0

    def base(self, x: np.ndarray | float, v: np.ndarray | float) -> np.ndarray | float:
        """The base force ``f0 + k x + c v`` [N]."""
        return self.f0 + self.k * x + self.c * v

    def state_rate(self, x: float, v: float, s: np.ndarray) -> np.ndarray:
        """``ds/dt`` of the effect's states (empty for a memoryless effect)."""
        if not self.n_states:
            return np.zeros(0)
        p, z = self.p, float(s[0])
        if self.label == "friction":
            fc = p["Fc"]
            g = fc + fc * (p["fs_ratio"] - 1.0) * math.exp(-((v / p["vst"]) ** 2))
            return np.array([(fc / p["x_pre"]) * (v - abs(v) * z / g)])
        if self.label == "hysteresis":
            az = abs(z)
            dz = p["A"] * v - (p["beta"] * abs(v) * z + p["gamma"] * v * az) * az ** (p["n"] - 1)
            return np.array([dz])
        return np.array([p["km"] * v - z / p["tau"]])  # Maxwell

    def _g(self, v: np.ndarray | float) -> np.ndarray | float:
        p = self.p
        fc = p["Fc"]
        return fc + fc * (p["fs_ratio"] - 1.0) * np.exp(-((np.asarray(v) / p["vst"]) ** 2))

    def _lugre_rate(self, v: np.ndarray | float, w: np.ndarray | float) -> np.ndarray | float:
        p = self.p
        sigma0 = p["Fc"] / p["x_pre"]
        return sigma0 * (v - np.abs(v) * w / self._g(v))

    def effect(
        self, x: np.ndarray | float, v: np.ndarray | float, s: np.ndarray | float = 0.0
    ) -> np.ndarray:
        """The effect force ``E`` [N] (arrays broadcast; ``s`` the state samples)."""
        x, v, s = np.asarray(x, dtype=float), np.asarray(v, dtype=float), np.asarray(s)
        p, lab, var = self.p, self.label, self.variant
        zero = np.zeros(np.broadcast(x, v).shape)
        if lab == "friction":
            if var in ("tanh", "bingham"):
                return zero + p["Fc"] * np.tanh(v / p["vs"])
            if var == "stribeck":
                return zero + np.asarray(self._g(v)) * np.tanh(v / p["vs"])
            return zero + s + p["tau_b"] * np.asarray(self._lugre_rate(v, s))  # LuGre
        if lab == "hysteresis":
            return zero + p["alpha"] * s
        if lab == "digressive":
            if var == "tanh":
                return -p["dc"] * (v - p["vk"] * np.tanh(v / p["vk"]))
            return -p["dc"] * np.sign(v) * np.maximum(np.abs(v) - p["vk"], 0.0)
        if lab == "damper_asymmetry":
            return p["dc"] * v * (p["side"] * v > 0)
        if lab == "viscoelastic":
            return zero + s
        if lab == "progressive":
            return zero + p["k3"] * x**3
        if lab == "end_stop":
            out = zero.copy()
            if p["bump"]:
                out = out + p["ks"] * np.maximum(x - p["gap"], 0.0)
            if p["rebound"]:
                out = out - p["ks"] * np.maximum(-x - p["gap"], 0.0)
            return out
        if lab == "cubic_damper":
            return zero + p["c3"] * v**3
        if lab == "velocity_dead_zone":
            return zero - self.c * np.clip(v, -p["vdz"], p["vdz"])
        return zero

    def effect1(self, x: float, v: float, s: float = 0.0) -> float:
        """:meth:`effect` at one point, with Python floats (the ODE right-hand side)."""
        p, lab, var = self.p, self.label, self.variant
        if lab == "friction":
            if var in ("tanh", "bingham"):
                return p["Fc"] * math.tanh(v / p["vs"])
            fc = p["Fc"]
            g = fc + fc * (p["fs_ratio"] - 1.0) * math.exp(-((v / p["vst"]) ** 2))
            if var == "stribeck":
                return g * math.tanh(v / p["vs"])
            return s + p["tau_b"] * (fc / p["x_pre"]) * (v - abs(v) * s / g)  # LuGre
        if lab in ("hysteresis",):
            return p["alpha"] * s
        if lab == "digressive":
            if var == "tanh":
                return -p["dc"] * (v - p["vk"] * math.tanh(v / p["vk"]))
            return -p["dc"] * math.copysign(max(abs(v) - p["vk"], 0.0), v)
        if lab == "damper_asymmetry":
            return p["dc"] * v if p["side"] * v > 0 else 0.0
        if lab == "viscoelastic":
            return s
        if lab == "progressive":
            return p["k3"] * x**3
        if lab == "end_stop":
            out = 0.0
            if p["bump"] and x > p["gap"]:
                out += p["ks"] * (x - p["gap"])
            if p["rebound"] and -x > p["gap"]:
                out -= p["ks"] * (-x - p["gap"])
            return out
        if lab == "cubic_damper":
            return p["c3"] * v**3
        if lab == "velocity_dead_zone":
            return -self.c * min(max(v, -p["vdz"]), p["vdz"])
        return 0.0

    def total1(self, x: float, v: float, s: float = 0.0) -> float:
        """:meth:`total` at one point, with Python floats."""
        return self.f0 + self.k * x + self.c * v + self.effect1(x, v, s)

    def total(
        self, x: np.ndarray | float, v: np.ndarray | float, s: np.ndarray | float = 0.0
    ) -> np.ndarray:
        """``base + effect`` [N]."""
        return np.asarray(self.base(x, v)) + self.effect(x, v, s)


def dead_band(delta: np.ndarray | float, gap: float) -> np.ndarray | float:
    """``delta`` minus its part inside ``[-gap, gap]`` [m]: the compression of a contact
    with free play ``gap`` on each side."""
    return np.sign(delta) * np.maximum(np.abs(delta) - gap, 0.0)


def contact(delta: float, gap: float, width: float) -> float:
    """A smooth 0-1 contact indicator: ~1 once ``|delta| > gap``, over a width [m]."""
    return 0.5 * (1.0 + math.tanh((abs(delta) - gap) / width))
