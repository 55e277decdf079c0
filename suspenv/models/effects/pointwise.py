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

Input checks happen once, when the element is built (:meth:`Effect.check`); the laws
(:mod:`.laws`) do no checking so they can sit in an inner loop.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import laws
from suspenv.models.effects.effect import Effect
from suspenv.models.effects.laws import STATELESS


def _bw(m: Any, z: Any, v: Any, p: dict[str, Any]) -> Any:
    xy, b = p["x_y"], p["shape"]
    return m.bouc_wen_dzdt(z, v, 1.0 / xy, b / xy, (1.0 - b) / xy, p["n"])


def _lugre(p: dict[str, Any]) -> tuple[Any, ...]:
    return p["sigma0"], p["f_c"], p["f_s"], p["v_s"]


#: stateful elements: kind -> (dz/dt(m, x, v, z, p), F(m, x, v, z, p)) of the laws ``m``
#: (:data:`.laws.ARRAYS` or :data:`.laws.FLOATS`) and the parameters ``p``
STATEFUL: dict[str, tuple[Callable[..., Any], Callable[..., Any]]] = {
    "dahl_hysteresis": (
        lambda m, x, v, z, p: m.dahl_dzdt(z, v, p["sigma"], p["f_c"]),
        lambda m, x, v, z, p: z + 0.0 * v,
    ),
    "bouc_wen_hysteresis": (
        lambda m, x, v, z, p: _bw(m, z, v, p),
        lambda m, x, v, z, p: p["f_y"] * z + 0.0 * v,
    ),
    "maxwell_viscoelastic": (
        lambda m, x, v, z, p: m.maxwell_dfdt(z, v, p["k_m"], p["c_m"]),
        lambda m, x, v, z, p: z + 0.0 * v,
    ),
    "lugre_friction": (
        lambda m, x, v, z, p: m.lugre_dzdt(z, v, *_lugre(p)),
        lambda m, x, v, z, p: m.lugre_force(z, v, p["sigma0"], p["sigma1"], *_lugre(p)[1:]),
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
        self.effect = effect.check()
        # scalars as Python floats (fast arithmetic in scalar loops), arrays as float arrays
        self.params: dict[str, Any] = {
            k: float(v) if np.ndim(v) == 0 else np.asarray(v, dtype=float)
            for k, v in effect.params.items()
        }
        # plain floats in, plain floats out where every parameter is one (:data:`.laws.FLOATS`)
        self._floats = all(isinstance(v, float) for v in self.params.values())
        self.n_states = 1 if effect.kind in STATEFUL else 0
        level = {"dahl_hysteresis": "f_c", "lugre_friction": "f_s"}.get(effect.kind)
        # (laws, x, v, z, params) -> force / state derivative; None: no state
        self._force: Callable[..., Any]
        self._dzdt: Callable[..., Any] | None
        if (
            level
            and np.all(np.asarray(self.params[level]) <= 0)
            and (effect.kind != "lugre_friction" or np.all(np.asarray(self.params["f_c"]) <= 0))
        ):
            # zero friction level: the element is absent (its state stays at zero)
            self._dzdt = lambda m, x, v, z, p: 0.0 * v
            self._force = lambda m, x, v, z, p: 0.0 * v
        elif self.n_states:
            self._dzdt, self._force = STATEFUL[effect.kind]
        else:
            law, inputs, names = STATELESS[effect.kind]
            values = [self.params[n] for n in names]
            name = law.__name__
            self._force = {
                "x": lambda m, x, v, z, p: getattr(m, name)(x, *values),
                "v": lambda m, x, v, z, p: getattr(m, name)(v, *values),
                "xv": lambda m, x, v, z, p: getattr(m, name)(x, v, *values),
            }[inputs]
            self._dzdt = None

    def _laws(self, x: Any, v: Any, z: Any) -> Any:
        """The laws for these inputs: :data:`.laws.FLOATS` for plain floats."""
        if self._floats and type(x) is float and type(v) is float:
            return laws.FLOATS if z is None or type(z) is float else laws.ARRAYS
        return laws.ARRAYS

    def force(self, x: np.ndarray, v: np.ndarray, z: np.ndarray | None = None) -> np.ndarray:
        """Force [N] at deflection ``x`` [m], rate ``v`` [m/s] and state ``z``."""
        return self._force(self._laws(x, v, z), x, v, z, self.params)

    def dzdt(self, x: np.ndarray, v: np.ndarray, z: np.ndarray) -> np.ndarray:
        """State derivative (zero-size behaviour: returns 0 for stateless elements)."""
        if self._dzdt is None:
            return np.zeros_like(np.asarray(v, dtype=float))
        return self._dzdt(self._laws(x, v, z), x, v, z, self.params)
