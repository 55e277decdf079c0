"""The pointwise laws of the force effects, by kind, for numpy, plain floats and numba.

Each law is written once, in its family module (:mod:`.friction`, :mod:`.stiffness`,
:mod:`.damper_curves`, :mod:`.viscoelastic`, :mod:`.hysteresis`), with numpy's ufuncs
only and no checks (:meth:`~suspenv.models.effects.Effect.force` checks the parameters
once). So one function serves every caller: numpy arrays (the series forms of
:class:`~suspenv.models.effects.Effect`, the batch time integrator; plain broadcasting),
and, as :data:`FLOATS` (the same code with math's functions for numpy's, several times
faster on one number), plain floats (the scalar time integrator) and numba (the compiled
rig loop :mod:`suspenv.models.components.rig_kernel`).
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable
from typing import Any

from suspenv.models.effects import damper_curves, friction, hysteresis, stiffness, viscoelastic

#: stateless force kind -> (law, its inputs: deflection ``"x"`` [m], rate ``"v"`` [m/s]
#: or both ``"xv"``, the kind's parameters in the law's order); the compiled rig loop
#: numbers the kinds in this order (``rig_kernel.LAW_CODES``)
STATELESS: dict[str, tuple[Callable[..., Any], str, tuple[str, ...]]] = {
    "coulomb_friction": (friction.coulomb_smooth, "v", ("f_c", "v_eps")),
    "stribeck_friction": (friction.stribeck_friction, "v", ("f_c", "f_s", "v_s", "v_eps")),
    "directional_friction": (friction.coulomb_directional, "v", ("f_pos", "f_neg", "v_eps")),
    "low_speed_deficit": (friction.low_speed_deficit, "v", ("f_d", "v_band")),
    "bump_stop": (stiffness.bump_stop, "x", ("gap", "k_stop", "p")),
    "rebound_stop": (stiffness.rebound_stop, "x", ("gap", "k_stop", "p")),
    "bump_and_rebound_stops": (
        stiffness.bump_and_rebound_stops,
        "x",
        ("gap_bump", "k_bump", "gap_rebound", "k_rebound", "p"),
    ),
    "cubic_stiffness": (stiffness.cubic_stiffness, "x", ("k3", "x_0")),
    "progressive_stiffness": (stiffness.progressive_spring, "x", ("k_p", "x0")),
    "gas_spring": (stiffness.gas_spring, "x", ("f_0", "k_gas")),
    "force_offset": (stiffness.force_offset, "x", ("offset",)),
    "kelvin_voigt": (viscoelastic.kelvin_voigt, "xv", ("k", "c")),
    "damper_asymmetry": (damper_curves.extra_rebound_damping, "v", ("dc_rebound",)),
    "digressive_damping": (damper_curves.damper_digressive, "v", ("c_low", "v_knee")),
    "asymmetric_digressive_damping": (
        damper_curves.damper_digressive_asymmetric,
        "v",
        ("c_bump", "v_knee_bump", "c_rebound", "v_knee_rebound"),
    ),
}

_LAWS = tuple(law for law, _, _ in STATELESS.values())
#: the state rates and the laws they call
_STATE_LAWS = (
    friction.stribeck_level,
    friction.lugre_dzdt,
    friction.lugre_force,
    hysteresis.dahl_dzdt,
    hysteresis.bouc_wen_dzdt,
    viscoelastic.maxwell_dfdt,
)


def _sign(a: float) -> float:
    """``np.sign`` of a float."""
    return float((a > 0.0) - (a < 0.0))


def _for_floats() -> types.ModuleType:
    """The laws with math's functions (and ``abs``, ``max``, ``min``, :func:`_sign`) in
    place of numpy's, by name; a law calling another one of its module finds the float one."""
    scalar = types.ModuleType("scalar_math")  # a module: numba resolves its attributes
    vars(scalar).update(tanh=math.tanh, exp=math.exp, abs=abs, maximum=max, minimum=min)
    vars(scalar)["sign"] = _sign
    floats = types.ModuleType(f"{__name__}.FLOATS")  # a module: numba resolves it too
    spaces: dict[str, dict[str, Any]] = {}
    for law in (*_LAWS, *_STATE_LAWS):
        space = spaces.setdefault(law.__module__, dict(law.__globals__, np=scalar))
        copy = types.FunctionType(law.__code__, space, law.__name__, law.__defaults__)
        space[law.__name__] = vars(floats)[law.__name__] = copy
    return floats


#: the laws for numpy, by name (``ARRAYS.coulomb_smooth(v, f_c, v_eps)``) ...
ARRAYS = types.SimpleNamespace(**{f.__name__: f for f in (*_LAWS, *_STATE_LAWS)})
#: ... and for plain floats: the scalar time integrator's, and the compiled rig loop's
FLOATS = _for_floats()
#: the functions the compiled rig loop calls, for numba (``compiled.Lazy``'s jitable)
JITABLE = (*(f for f in vars(FLOATS).values() if callable(f)), _sign)
