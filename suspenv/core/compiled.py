"""Compiled loops (numba): built ahead of time at install, else compiled at their first call.

A module with a compiled loop keeps it as plain Python functions (the same code runs
without numba) and exposes it as a :class:`Lazy` loop. The loops a K&C evaluation and the
minibus problem's handling measures run (:data:`AHEAD`) are compiled when the package is
built (``setup.py`` calls :func:`extension`: numba's ``pycc`` makes the extension module
``suspenv.core._kernels``), so a fresh install's first evaluation compiles nothing. Each
compiled loop is exported under a name carrying the hash of its source files
(:func:`export_name`): a loop whose source changed since the build (an editable install
being edited) is not found there and is compiled at its first call instead with numba's
JIT (``cache=True``: the machine code is written next to the module, or to numba's user
cache folder when the package folder is read-only, and loaded by later processes).
Without numba, ``main`` itself runs. ``SUSPENV_COMPILED=jit`` ignores the built loops
(the benchmark's baseline). ``python suspenv/core/compiled.py`` rebuilds the extension of
a source tree in place (e.g. a worktree whose loops changed) without reinstalling the
package.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import platform
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

#: numba is installed: compiled loops can run
AVAILABLE = importlib.util.find_spec("numba") is not None

#: the loops built ahead of time: module -> {Lazy attribute: numba signature}
AHEAD: dict[str, dict[str, str]] = {}

#: the instruction set the built loops target on x86-64 (AVX2 and FMA: the vectorised
#: Newton steps and Jacobian inverses of the K&C sweep; generic x86-64 is about a fifth
#: slower there), and the CPU features it needs: on a machine without them the built
#: loops are not used (:func:`_built`) and the loops compile at their first call
AOT_CPU = "x86-64-v3"
AOT_FEATURES = ("avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe")


def _arr(dtype: str, ndim: int) -> str:
    """numba's type of a C-contiguous array."""
    return f"{dtype}[{', '.join([':'] * (ndim - 1) + ['::1'])}]"


def _signatures() -> None:
    f, i = (lambda n: _arr("float64", n)), (lambda n: _arr("int64", n))
    # r, R, lam, pad, ext, rack, extra, pack, off, k_bar_shear, cscale (residual_kernel)
    rows = [f(4), f(5), f(3), f(2), f(3), f(2), f(3), f(3), i(1), "float64", "float64"]
    jac = rows + ["float64", f(6), i(2), i(1), i(2), i(1), f(3)]
    AHEAD["suspenv.models.mcpherson.residual_kernel"] = {
        "residual": f"void({', '.join([*rows, f(3)])})",
        "jacobian": f"void({', '.join(jac)})",
    }
    AHEAD["suspenv.models.mcpherson.rotation_kernel"] = {
        "_turned_loop": f"void({f(2)}, {f(3)}, {f(3)})",
        "_relative_log_loop": f"void({f(3)}, {f(3)}, {f(2)})",
    }
    # pack, off, k_bar_shear, cscale, ref0, pad0, pad_off, ext, rack, tol, maxit, h,
    # exp_h, moves, move_start, scatter, scatter_start, limits, lo, outputs (sweep_kernel)
    sweep = [f(3), i(1), "float64", "float64", f(4), f(2), f(3), f(4), f(3), f(1), "int64"]
    sweep += ["float64", f(3), i(2), i(1), i(2), i(1), f(1), "int64", f(6), f(7), f(5), i(1)]
    AHEAD["suspenv.models.mcpherson.sweep_kernel"] = {"sweep": f"void({', '.join(sweep)})"}
    # r, R, pads, s0, Rw, kt, kB, table, F (the objectives of the swept states)
    knc = [f(6), f(7), f(4), f(3), f(2), f(2), f(3), i(2), f(2)]
    AHEAD["suspenv.metrics.knc_kernel"] = {"objectives": f"void({', '.join(knc)})"}
    AHEAD["suspenv.models.effects.kernels"] = {
        "recurrence": f"void({f(2)}, {f(2)}, {f(1)}, {f(2)})",
    }
    # d, b, e, c, grid, out; lam, V, B, grid, f, f_max, out; rows, table, h, bits, scale,
    # out; rows, ay, tyre, grid, radius, passes, out; rows, u, cf, cr, A, B; A, B, s, X
    # (handling_kernel)
    axle = [f(2), f(2), f(2), "float64", f(1)]
    c = _arr("complex128", 2)
    AHEAD["suspenv.models.minibus.handling_kernel"] = {
        "capacity_loop": f"void({', '.join([*axle, f(2)])})",
        "yaw_loop": f"void({c}, {_arr('complex128', 3)}, {f(2)}, {f(1)}, {f(1)}, float64, {f(2)})",
        "circle_loop": f"void({f(2)}, {f(2)}, float64, int64, float64, {f(2)})",
        "sweep_loop": f"void({f(2)}, {f(1)}, {f(1)}, {f(1)}, float64, int64, {f(3)})",
        "linear_loop": f"void({f(2)}, {f(2)}, {f(2)}, {f(2)}, {f(4)}, {f(3)})",
        "response_loop": f"void({f(3)}, {f(2)}, {_arr('complex128', 1)}, {_arr('complex128', 3)})",
    }
    # A0, minv, D, rates, A; A, lam, V (twice); lam, V, B, co, lo, w, dr, di, wt, out; sig,
    # damp, knee, leaf, passes, out; new, r, tol; lam, V, B, co, w, dr, di, wt, damp, knee,
    # leaf, passes, tol, r (spectral_kernel)
    c3 = _arr("complex128", 3)
    AHEAD["suspenv.models.minibus.spectral_kernel"] = {
        "halves_matrix": f"void({f(3)}, {f(3)}, {f(4)}, {f(2)}, {f(3)})",
        "eigen": f"void({f(3)}, {c}, {c3})",
        "general_eigen": f"void({f(3)}, {c}, {c3})",
        "modal_mean_square": f"void({c}, {c3}, {c3}, {f(3)}, int64, {f(1)}, {f(1)}, {f(1)}, "
        f"{f(2)}, {f(3)})",
        "damper_leaf_rates": f"void({f(2)}, {f(3)}, {f(2)}, {f(3)}, int64, {f(2)})",
        "take_rates": f"int64({f(2)}, {f(2)}, float64)",
        "split_update": f"int64({c}, {c3}, {c3}, {f(3)}, {f(1)}, {f(1)}, {f(1)}, {f(2)}, "
        f"{f(3)}, {f(2)}, {f(3)}, int64, float64, {f(2)})",
    }


_signatures()


def export_name(
    space: dict[str, Any], helpers: Sequence[str], main: Callable, jitable: Sequence[Callable] = ()
) -> str:
    """The name of ``main``'s built loop: module, function and the hash of the source
    files of ``main``, its ``helpers`` and ``jitable`` (any edit of them gives another name)."""
    digest = hashlib.sha256()
    for f in (main, *(space[h] for h in helpers), *jitable):
        f = getattr(f, "py_func", f)
        digest.update(Path(sys.modules[f.__module__].__file__ or "").read_bytes())
    return f"{main.__module__.rsplit('.', 1)[-1]}_{main.__name__}_{digest.hexdigest()[:12]}"


def _built(
    space: dict[str, Any], helpers: Sequence[str], main: Callable, jitable: Sequence[Callable] = ()
) -> Callable | None:
    """``main``'s loop from ``suspenv.core._kernels`` (None: not built, or built from other
    source)."""
    if os.environ.get("SUSPENV_COMPILED") == "jit" or not _runs_built_loops():
        return None
    try:
        kernels = importlib.import_module("suspenv.core._kernels")
    except ImportError:
        return None
    return getattr(kernels, export_name(space, helpers, main, jitable), None)


def _target_cpu() -> str:
    """The CPU model the built loops target: :data:`AOT_CPU` on x86-64, else the
    architecture's generic model."""
    return AOT_CPU if platform.machine().lower() in ("x86_64", "amd64") else ""


def _runs_built_loops() -> bool:
    """This machine runs the built loops: it has the features of :func:`_target_cpu`
    (llvmlite's view of the CPU; False without llvmlite)."""
    if not _target_cpu():
        return True
    try:
        from llvmlite import binding  # type: ignore[import-untyped]
    except ImportError:
        return False
    features = binding.get_host_cpu_features()
    return all(features.get(f, False) for f in AOT_FEATURES)


def jit_helpers(
    space: dict[str, Any],
    helpers: Sequence[str],
    cache: bool,
    inline: Sequence[str] = (),
    bare: Sequence[str] = (),
    contract: Sequence[str] = (),
) -> None:
    """Replace the functions ``helpers`` of the namespace ``space`` by their compiled
    versions (numba, written to its on-disk cache when ``cache``), there and in the
    modules that define the helpers (where the helpers calling each other find them); a
    helper compiled already stays as it is. The helpers named in ``inline`` are inlined
    into their callers by numba (``inline="always"``: no call, and no reference counting
    of the arrays they are passed; small helpers of hot loops). Those named in ``bare``
    are compiled without numba's reference counting (``_nrt=False``: no atomic
    increment and decrement for every array, view and tuple of arrays they handle;
    helpers of the hot loops that allocate no array and return none, their callers
    owning every array they are passed). Those named in ``contract`` may fuse a multiply
    and an add into one instruction (LLVM's ``contract``: one rounding instead of two,
    the same arithmetic otherwise; the helpers inlined into them take it too)."""
    import numba

    plain = [getattr(space[name], "py_func", space[name]) for name in helpers]
    spaces = [space] + [vars(sys.modules[f.__module__]) for f in plain]
    done = {id(v.py_func): v for ns in spaces for v in ns.values() if hasattr(v, "py_func")}
    for name, f in zip(helpers, plain, strict=True):
        if id(f) not in done:
            flags: dict[str, Any] = {"fastmath": {"contract"}} if name in contract else {}
            if name in inline:
                own = numba.njit(inline="always", error_model="numpy", **flags)
            else:
                flags["_nrt"] = name not in bare  # (numba's private flag)
                own = numba.njit(cache=cache, error_model="numpy", **flags)
            done[id(f)] = own(f)
    for ns in spaces:
        for key, value in list(ns.items()):
            if id(value) in done and not hasattr(value, "py_func"):
                ns[key] = done[id(value)]


def jitable(functions: Sequence[Callable]) -> None:
    """Declare ``functions`` to numba as callable from compiled code (numba's
    ``register_jitable``) while they stay plain Python functions for their other callers
    (e.g. the force laws of :mod:`suspenv.models.effects.laws`)."""
    from numba.extending import register_jitable

    for f in functions:
        register_jitable(error_model="numpy")(f)


class Lazy:
    """The loop ``main`` of the module namespace ``space``: the built one where there is
    one, else compiled (with its ``helpers``, those named in ``inline`` inlined, those
    named in ``bare`` without reference counting, those named in ``contract`` with fused
    multiply-adds: :func:`jit_helpers`; the functions of other modules it calls in
    ``jitable``: :func:`jitable`) at the first call; without numba, ``main`` itself runs."""

    def __init__(
        self,
        space: dict[str, Any],
        helpers: Sequence[str],
        main: Callable,
        inline: Sequence[str] = (),
        bare: Sequence[str] = (),
        jitable: Sequence[Callable] = (),
        contract: Sequence[str] = (),
    ) -> None:
        self._space, self._helpers, self._main = space, tuple(helpers), main
        self._inline, self._bare, self._jitable = tuple(inline), tuple(bare), tuple(jitable)
        self._contract = tuple(contract)
        self._loop: Callable | None = None
        # a built loop's array arguments (position, dtype, number of dimensions): checked
        # at each call
        self._arrays: tuple[tuple[int, np.dtype, int], ...] = ()
        self.__doc__ = f":func:`{main.__name__}`, compiled at its first call."

    def __call__(self, *args: Any) -> Any:
        loop = self._loop
        if loop is None:
            loop = self._loop = self._load()
        for i, dtype, ndim in self._arrays:
            a = args[i]
            # (a builtin dtype is one object: ``is`` answers first, ``==`` the others)
            if not (
                (a.dtype is dtype or a.dtype == dtype) and a.ndim == ndim and a.flags.c_contiguous
            ):
                raise _refused(self._main.__name__, i, a, dtype, ndim)
        return loop(*args)

    def _load(self) -> Callable:
        """The built loop (its array arguments, those of its signature in :data:`AHEAD`,
        kept to be checked at each call), else ``main`` compiled, else ``main`` itself."""
        built = _built(self._space, self._helpers, self._main, self._jitable)
        if built is None:
            return self._compiled() if AVAILABLE else self._main
        module = sys.modules[self._main.__module__]
        loops = AHEAD[module.__name__].items()
        self._arrays = next(_array_arguments(s) for a, s in loops if getattr(module, a) is self)
        return built

    def _compiled(self) -> Callable:
        """``main`` compiled by numba's JIT, its helpers replaced by their compiled
        versions first (:func:`jit_helpers`). ``error_model="numpy"``: a division by zero
        gives inf or nan (which the callers report as a failed evaluation) instead of
        raising inside the loop."""
        import numba

        jitable(self._jitable)
        jit_helpers(self._space, self._helpers, True, self._inline, self._bare, self._contract)
        loop = numba.njit(cache=True, error_model="numpy")(self._main)
        for f in (loop, *(self._space[h] for h in self._helpers)):
            _stamp(f, self._jitable)
        return loop


def _stamp(dispatcher: Any, jitable: Sequence[Callable] = ()) -> None:
    """Key numba's on-disk cache of ``dispatcher`` (no cache: nothing to do) to all that
    its machine code is built from. numba checks only the file of the function it
    compiles, and only the argument types: a helper edited in another module, or compiled
    with other flags (a helper's flags are those of the first loop compiling it), would
    leave machine code of another vintage in the cache, to be loaded beside
    specialisations compiled now (e.g. one for read-only arrays: two codes of one loop
    that differ in rounding). The stamp adds the digest of the source files and flags of
    every function the dispatcher reaches (:func:`_reached`) and of the ``jitable``
    functions' files: any change compiles the loop again."""
    cache = getattr(dispatcher, "_cache", None)
    index = getattr(cache, "_cache_file", None)
    if cache is None or index is None:
        return
    digest = hashlib.sha256()
    reached: dict[int, Any] = {}
    _reached(dispatcher, reached)
    plain = [getattr(f, "py_func", f) for f in (*reached.values(), *jitable)]
    files = {sys.modules[f.__module__].__file__ or "" for f in plain}
    for path in sorted(files):
        digest.update(Path(path).read_bytes())
    for f in reached.values():
        flags = getattr(f, "targetoptions", None)
        if flags is not None:
            items = sorted((k, sorted(v) if isinstance(v, (set, frozenset)) else v)
                           for k, v in flags.items())  # fmt: skip
            digest.update(f"{f.py_func.__module__}.{f.py_func.__name__}{items!r}".encode())
    index._source_stamp = (cache._impl.locator.get_source_stamp(), digest.hexdigest())


def _reached(f: Any, seen: dict[int, Any]) -> None:
    """``f`` and the functions it names among its module's globals, transitively (their
    plain functions or compiled dispatchers), into ``seen`` (by the id of the plain
    function)."""
    plain = getattr(f, "py_func", f)
    if id(plain) in seen or not hasattr(plain, "__code__"):
        return
    seen[id(plain)] = f
    codes = [plain.__code__]
    while codes:
        code = codes.pop()
        codes += [c for c in code.co_consts if hasattr(c, "co_names")]
        for name in code.co_names:
            if name in plain.__globals__:
                _reached(plain.__globals__[name], seen)


def _array_arguments(signature: str) -> tuple[tuple[int, np.dtype, int], ...]:
    """The array arguments of a numba signature ``"ret(arg, ...)"``: position, dtype
    and number of dimensions of each."""
    inner = signature[signature.index("(") + 1 : signature.rindex(")")]
    arguments = [a.strip() for a in re.split(r",(?![^\[]*\])", inner)]
    return tuple(
        (i, np.dtype(a[: a.index("[")]), a.count(",") + 1)
        for i, a in enumerate(arguments)
        if "[" in a
    )


def _refused(name: str, i: int, a: np.ndarray, dtype: np.dtype, ndim: int) -> ValueError:
    """A built loop declares C-contiguous arrays of one dtype and number of dimensions
    (:func:`_arr`) but ``pycc``'s wrapper checks none of them: a strided or column-order
    array would be read as if it were C-ordered, another dtype or number of dimensions
    read as the declared one (wrong numbers, or memory outside the array). The error
    refusing argument ``i`` by name instead."""
    return ValueError(
        f"compiled loop {name}: argument {i} must be a C-contiguous {ndim}-D {dtype} array "
        f"(np.ascontiguousarray), but got a {a.ndim}-D {a.dtype} one with strides {a.strides}"
    )


def extension(root: Path) -> Any:
    """The setuptools extension ``suspenv.core._kernels`` with the loops of :data:`AHEAD`,
    compiled by numba's ``pycc`` from the sources under ``root`` (None where numba has no
    ``pycc``). Called by ``setup.py`` in the build environment, which has numba and numpy
    but not suspenv's other dependencies: the kernel modules are loaded without their
    packages' ``__init__``."""
    cc = _exports(root)
    return None if cc is None else cc.distutils_extension(optional=True)


def _exports(root: Path) -> Any:
    """numba's ``pycc`` module ``_kernels`` with the loops of :data:`AHEAD` exported from
    the sources under ``root`` (None: a numba without ``pycc``)."""
    import types
    import warnings

    import numba

    try:
        from numba.pycc import CC
    except ImportError:  # a numba without pycc: the loops compile at their first call
        return None

    packages = (
        "suspenv", "suspenv.core", "suspenv.metrics", "suspenv.models",
        "suspenv.models.mcpherson", "suspenv.models.effects", "suspenv.models.minibus",
    )  # fmt: skip
    for package in packages:
        stub = types.ModuleType(package)
        stub.__path__ = [str(root.joinpath(*package.split(".")))]
        sys.modules.setdefault(package, stub)
    warnings.simplefilter("ignore", numba.NumbaPendingDeprecationWarning)
    cc = CC("_kernels")
    cc.target_cpu = _target_cpu()
    for module_name, loops in AHEAD.items():
        module = importlib.import_module(module_name)
        for attribute, signature in loops.items():
            lazy = getattr(module, attribute)
            name = export_name(lazy._space, lazy._helpers, lazy._main, lazy._jitable)
            jitable(lazy._jitable)
            jit_helpers(lazy._space, lazy._helpers, False, lazy._inline, lazy._bare, lazy._contract)
            cc.export(name, signature)(lazy._main)
    return cc


if __name__ == "__main__":  # pragma: no cover - ``python suspenv/core/compiled.py``
    # rebuild suspenv/core/_kernels*.so of this source tree in place (no reinstall)
    sys.modules.setdefault("suspenv.core.compiled", sys.modules["__main__"])
    here = Path(__file__).resolve().parent
    kernels = _exports(here.parents[1])
    if kernels is None:
        sys.exit("numba has no pycc: the loops compile at their first call")
    kernels.output_dir = str(here)
    kernels.compile()
