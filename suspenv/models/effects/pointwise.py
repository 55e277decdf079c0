"""Effects in pointwise form, for use inside any time integrator.

A :class:`PointwiseElement` wraps a force-role :class:`Effect` so that an ODE
right-hand side can evaluate it at one instant: ``force(x, v, z)`` [N] from the
deflection ``x`` [m], its rate ``v`` [m/s] and, for elements with an internal
state, the state ``z``; ``dzdt(x, v, z)`` gives the state derivative. Stateless
elements have ``n_states == 0`` (``z`` ignored). Arrays broadcast (batch of
designs, several elements...). Signs as everywhere in :mod:`suspenv.models.effects`:
force positive when it resists positive deflection.

States: Dahl ``z`` = hysteretic force [N]; Bouc-Wen ``z`` dimensionless (``F = f_y z``);
Maxwell ``z`` = element force [N]; LuGre ``z`` = bristle deflection [m].

Input checks happen once, when the element is built; the evaluation functions do
no checking so they can sit in an inner loop.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects.effect import Effect
from suspenv.models.effects.friction import lugre_dzdt, stribeck_level
from suspenv.models.effects.hysteresis import bouc_wen_dzdt, dahl_dzdt
from suspenv.models.effects.viscoelastic import maxwell_dfdt


def _pos(a: np.ndarray | float) -> np.ndarray | float:
    if isinstance(a, float):
        return a if a > 0.0 else 0.0
    return np.maximum(a, 0.0)


def _tanh(a: np.ndarray | float) -> np.ndarray | float:
    return math.tanh(a) if isinstance(a, float) else np.tanh(a)


#: stateless force laws F(x, v, p); same formulas as the element modules
STATELESS: dict[str, Callable[..., np.ndarray]] = {
    "coulomb_friction": lambda x, v, p: p["f_c"] * _tanh(v / p["v_eps"]),
    "stribeck_friction": lambda x, v, p: (
        stribeck_level(v, p["f_c"], p["f_s"], p["v_s"]) * _tanh(v / p["v_eps"])
    ),
    "directional_friction": lambda x, v, p: (
        0.5 * (p["f_pos"] + p["f_neg"]) * _tanh(v / p["v_eps"])
        + 0.5 * (p["f_pos"] - p["f_neg"]) * np.abs(_tanh(v / p["v_eps"]))
    ),
    "bump_stop": lambda x, v, p: p["k_stop"] * _pos(x - p["gap"]) ** p["p"],
    "rebound_stop": lambda x, v, p: -p["k_stop"] * _pos(-x - p["gap"]) ** p["p"],
    "bump_and_rebound_stops": lambda x, v, p: (
        p["k_bump"] * _pos(x - p["gap_bump"]) ** p["p"]
        - p["k_rebound"] * _pos(-x - p["gap_rebound"]) ** p["p"]
    ),
    "cubic_stiffness": lambda x, v, p: p["k3"] * (x - p["x_0"]) ** 3,
    "progressive_stiffness": lambda x, v, p: p["k_p"] * np.sign(x) * _pos(np.abs(x) - p["x0"]) ** 2,
    "damper_asymmetry": lambda x, v, p: p["dc_rebound"] * np.minimum(v, 0.0),
    "digressive_damping": lambda x, v, p: p["c_low"] * v / (1.0 + np.abs(v) / p["v_knee"]),
    "asymmetric_digressive_damping": lambda x, v, p: np.where(
        v >= 0.0,
        p["c_bump"] * v / (1.0 + np.abs(v) / p["v_knee_bump"]),
        p["c_rebound"] * v / (1.0 + np.abs(v) / p["v_knee_rebound"]),
    ),
    "kelvin_voigt": lambda x, v, p: p["k"] * x + p["c"] * v,
    "low_speed_deficit": lambda x, v, p: -p["f_d"] * _tanh(v / p["v_band"]),
    "gas_spring": lambda x, v, p: p["f_0"] + p["k_gas"] * x,
    "force_offset": lambda x, v, p: p["offset"] + 0.0 * x,
}


def _bw(z, v, p):
    xy, b = p["x_y"], p["shape"]
    return bouc_wen_dzdt(z, v, 1.0 / xy, b / xy, (1.0 - b) / xy, p["n"])


#: stateful elements: kind -> (dz/dt(x, v, z, p), F(x, v, z, p))
STATEFUL: dict[str, tuple[Callable[..., np.ndarray], Callable[..., np.ndarray]]] = {
    "dahl_hysteresis": (
        lambda x, v, z, p: dahl_dzdt(z, v, p["sigma"], p["f_c"]),
        lambda x, v, z, p: z + 0.0 * v,
    ),
    "bouc_wen_hysteresis": (
        lambda x, v, z, p: _bw(z, v, p),
        lambda x, v, z, p: p["f_y"] * z + 0.0 * v,
    ),
    "maxwell_viscoelastic": (
        lambda x, v, z, p: maxwell_dfdt(z, v, p["k_m"], p["c_m"]),
        lambda x, v, z, p: z + 0.0 * v,
    ),
    "lugre_friction": (
        lambda x, v, z, p: lugre_dzdt(z, v, p["sigma0"], p["f_c"], p["f_s"], p["v_s"]),
        lambda x, v, z, p: (
            p["sigma0"] * z
            + p["sigma1"] * lugre_dzdt(z, v, p["sigma0"], p["f_c"], p["f_s"], p["v_s"])
        ),
    ),
}


def _sgn(a: float) -> float:
    return float((a > 0.0) - (a < 0.0))


def _dahl_float(x, v, z, p):
    if isinstance(v, float) and isinstance(z, float) and isinstance(p["f_c"], float):
        return p["sigma"] * v * (1.0 - z / p["f_c"] * _sgn(v))
    return dahl_dzdt(z, v, p["sigma"], p["f_c"])


#: plain-float versions of laws that use numpy functions (a scalar time integrator calls
#: them hundreds of thousands of times); same formulas, arrays fall back to numpy
FLOAT_STATELESS: dict[str, Callable[..., Any]] = {
    "damper_asymmetry": lambda x, v, p: p["dc_rebound"] * (v if v < 0.0 else 0.0),
    "digressive_damping": lambda x, v, p: p["c_low"] * v / (1.0 + abs(v) / p["v_knee"]),
    "asymmetric_digressive_damping": lambda x, v, p: (
        p["c_bump"] * v / (1.0 + v / p["v_knee_bump"])
        if v >= 0.0
        else p["c_rebound"] * v / (1.0 - v / p["v_knee_rebound"])
    ),
    "progressive_stiffness": lambda x, v, p: p["k_p"] * _sgn(x) * _pos(abs(x) - p["x0"]) ** 2,
    "stribeck_friction": lambda x, v, p: (
        (p["f_c"] + (p["f_s"] - p["f_c"]) * math.exp(-((v / p["v_s"]) ** 2)))
        * math.tanh(v / p["v_eps"])
    ),
}


#: force kinds whose memory is a reversal point, not a smooth state: path form only
PATH_ONLY = ("berg_hysteresis",)


class PointwiseElement:
    """One force effect evaluated at an instant (see module docstring)."""

    def __init__(self, effect: Effect):
        if effect.spec.role != "force":
            raise ValidationError(
                f"effect {effect.name!r} ({effect.kind}) has role {effect.spec.role!r}; "
                "only force effects have a pointwise form"
            )
        if effect.kind not in STATELESS and effect.kind not in STATEFUL:
            raise ValidationError(
                f"effect kind {effect.kind!r} has no pointwise form (path-only kinds: {PATH_ONLY})"
            )
        self.effect = effect
        # scalars as Python floats (fast arithmetic in scalar loops), arrays as float arrays
        self.params: dict[str, Any] = {
            k: float(v) if np.ndim(v) == 0 else np.asarray(v, dtype=float)
            for k, v in effect.params.items()
        }
        self.n_states = 1 if effect.kind in STATEFUL else 0
        level = {"dahl_hysteresis": "f_c", "lugre_friction": "f_s"}.get(effect.kind)
        # (x, v, z, params) -> force / state derivative; no state derivative when stateless
        self._force: Callable[[Any, Any, Any, dict[str, Any]], Any]
        self._dzdt: Callable[[Any, Any, Any, dict[str, Any]], Any] | None
        if (
            level
            and np.all(np.asarray(self.params[level]) <= 0)
            and (effect.kind != "lugre_friction" or np.all(np.asarray(self.params["f_c"]) <= 0))
        ):
            # zero friction level: the element is absent (its state stays at zero)
            self._dzdt = lambda x, v, z, p: 0.0 * v
            self._force = lambda x, v, z, p: 0.0 * v
        elif self.n_states:
            self._dzdt, self._force = STATEFUL[effect.kind]
            if effect.kind == "dahl_hysteresis":
                self._dzdt = _dahl_float
                self._force = lambda x, v, z, p: z if isinstance(z, float) else z + 0.0 * v
        else:
            law = STATELESS[effect.kind]
            fast = FLOAT_STATELESS.get(effect.kind)
            scalar_params = all(isinstance(v, float) for v in self.params.values())
            if fast is not None and scalar_params:
                self._force = lambda x, v, z, p: (
                    fast(x, v, p) if isinstance(x, float) and isinstance(v, float) else law(x, v, p)
                )
            else:
                self._force = lambda x, v, z, p: law(x, v, p)
            self._dzdt = None

    def force(self, x: np.ndarray, v: np.ndarray, z: np.ndarray | None = None) -> np.ndarray:
        """Force [N] at deflection ``x`` [m], rate ``v`` [m/s] and state ``z``."""
        return self._force(x, v, z, self.params)

    def dzdt(self, x: np.ndarray, v: np.ndarray, z: np.ndarray) -> np.ndarray:
        """State derivative (zero-size behaviour: returns 0 for stateless elements)."""
        if self._dzdt is None:
            return np.zeros_like(np.asarray(v, dtype=float))
        return self._dzdt(x, v, z, self.params)

    def initial_state(self, shape: tuple[int, ...] = ()) -> np.ndarray:
        """Relaxed initial state (zeros) of the given batch shape."""
        return np.zeros(shape)


def pointwise(effect: Effect) -> PointwiseElement:
    """The pointwise (time-integration) form of a force effect."""
    return PointwiseElement(effect)
