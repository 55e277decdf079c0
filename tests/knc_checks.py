"""Shared pieces of the K&C solver tests: the solver's tolerances per channel, a state
away from equilibrium (so that residual comparisons are not of zeros) and the comparison
of two writings of the residual."""

from __future__ import annotations

import numpy as np

from suspenv.models.mcpherson import AxleSolver
from suspenv.models.mcpherson.solver import NS

#: solver tolerances (AxleSolver defaults): 1e-6 m, 1e-5 rad, 0.1 N (and a constraint
#: force acts on the tyre force through the stiff links, so forces get a margin)
XTOL, RTOL, FTOL = 1e-6, 1e-5, 1.0
LENGTH = ("wheel_centre", "contact", "scrub_radius", "trail", "spring_length", "pad_z")
FORCE = ("tyre_fz", "spring_force")


#: the handwheel torque: the tie-rod forces (multipliers, to FTOL) times the rack gain
#: (about 8 mm/rad) [N*m]
TORQUE_TOL = FTOL * 0.01


def channel_tolerance(name: str) -> float:
    """The solver's tolerance for rig channel ``name`` (m, N, N*m or rad)."""
    if name.startswith(LENGTH):
        return XTOL
    if name.startswith(FORCE):
        return FTOL
    if name == "handwheel_torque":
        return TORQUE_TOL
    return RTOL  # angles [rad]


def off_equilibrium(solver: AxleSolver, seed: int):
    """A converged static state moved off equilibrium by 1 mm / 1 mrad noise, with random
    wheel loads (n, 2, 9) [N, N*m], rack travel (n, 2) [m] and pads 10 mm up:
    (state, pad, ext, rack)."""
    st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    assert conv.all()
    rng = np.random.default_rng(seed)
    st = solver._apply(st, rng.normal(scale=1e-3, size=(solver.n, 2 * NS)), conv)
    ext = rng.normal(scale=300.0, size=(solver.n, 2, 9))
    rack = rng.normal(scale=2e-3, size=(solver.n, 2))
    return st, solver.pad_static + 0.01, ext, rack


def assert_same_residual(fast: np.ndarray, ref: np.ndarray) -> None:
    """Two residuals of the same state equal to round-off of load sums of a few kN (N,
    N*m rows) and of CSCALE-scaled lengths, and not a comparison of zeros."""
    assert fast.shape == ref.shape
    assert np.abs(ref).max() > 10.0  # off equilibrium: the comparison is not of zeros
    assert np.allclose(fast, ref, rtol=0, atol=1e-8), np.abs(fast - ref).max()
