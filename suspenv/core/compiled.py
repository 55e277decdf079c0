"""Compiled loops (numba), compiled at their first call and cached per machine.

A module with a compiled loop keeps it as plain Python functions (the same code runs
without numba) and exposes it as a :class:`Lazy` loop, compiled at its first call with
:func:`compile_in`, so importing suspenv does not pay numba's import and compile time.
``cache=True``: the machine code is written next to the module (or to numba's user cache)
and loaded by later processes (about 0.3 s instead of several seconds).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Sequence
from typing import Any

#: numba is installed: compiled loops can run
AVAILABLE = importlib.util.find_spec("numba") is not None


def compile_in(space: dict[str, Any], helpers: Sequence[str], main: Callable) -> Callable:
    """``main`` compiled, with the functions ``helpers`` of the module namespace ``space``
    replaced by their compiled versions there (where the compiled ``main`` finds them).

    ``error_model="numpy"``: a division by zero gives inf or nan (which the callers
    report as a failed evaluation) instead of raising inside the loop.
    """
    import numba

    jit = numba.njit(cache=True, error_model="numpy")
    for name in helpers:  # (a helper another module compiled already stays as it is)
        f = space[name]
        space[name] = f if hasattr(f, "py_func") else jit(f)
    return jit(main)


class Lazy:
    """The loop ``main`` of the module namespace ``space``, compiled (with its
    ``helpers``) at the first call; without numba, ``main`` itself runs."""

    def __init__(self, space: dict[str, Any], helpers: Sequence[str], main: Callable) -> None:
        self._space, self._helpers, self._main = space, tuple(helpers), main
        self._loop: Callable | None = None
        self.__doc__ = f":func:`{main.__name__}`, compiled at its first call."

    def __call__(self, *args: Any) -> Any:
        if self._loop is None:
            self._loop = (
                compile_in(self._space, self._helpers, self._main) if AVAILABLE else self._main
            )
        return self._loop(*args)
