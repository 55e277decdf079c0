"""The loops built ahead of time (suspenv.core._kernels) and their guard against stale source.

References: each built loop is compared with its own plain-Python definition (the same
arithmetic, run by the interpreter) on random inputs, to rounding; the stale-source guard
is checked on a module written here.
"""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

from suspenv.core import compiled


def _built_or_skip(module: str, attribute: str):
    lazy = getattr(importlib.import_module(module), attribute)
    loop = compiled._built(lazy._space, lazy._helpers, lazy._main)
    if loop is None:
        pytest.skip("suspenv.core._kernels not built from this source (JIT at first call)")
    return lazy, loop


def test_export_name_changes_with_the_source(tmp_path, monkeypatch):
    """Any edit of a loop's source file gives another export name, so a stale build is
    never called (the loop is compiled at its first call instead)."""
    path = tmp_path / "loop_mod.py"
    path.write_text("def f(x):\n    return x + 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    mod = importlib.import_module("loop_mod")
    before = compiled.export_name(vars(mod), (), mod.f)
    path.write_text("def f(x):\n    return x + 2\n")
    assert compiled.export_name(vars(mod), (), mod.f) != before
    assert before.startswith("loop_mod_f_")
    del sys.modules["loop_mod"]


@pytest.mark.skipif(not compiled.AVAILABLE, reason="numba missing")
def test_the_jit_cache_is_keyed_to_the_helpers_files_and_flags(tmp_path, monkeypatch):
    """numba keys its on-disk cache to the compiled function's own file and argument
    types only: the stamp :func:`compiled._stamp` adds changes with an edit of a helper in
    another file and with the helper's flags, so that machine code of another vintage is
    compiled again instead of loaded beside code compiled now."""
    import numba

    helper = tmp_path / "stamp_helper.py"
    helper.write_text("def h(x):\n    return x * 2.0 + 1.0\n")
    (tmp_path / "stamp_loop.py").write_text(
        "from stamp_helper import h\n\n\ndef main(x):\n    return h(x)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))

    def stamp(contract: bool):
        for name in ("stamp_helper", "stamp_loop"):
            sys.modules.pop(name, None)
        space = vars(importlib.import_module("stamp_loop"))
        compiled.jit_helpers(space, ("h",), True, contract=("h",) if contract else ())
        loop = numba.njit(cache=True)(space["main"])
        compiled._stamp(loop)
        return loop._cache._cache_file._source_stamp

    plain = stamp(False)
    assert stamp(False) == plain  # the same sources and flags: the cache is used
    assert stamp(True) != plain
    helper.write_text("def h(x):\n    return x * 2.0 + 3.0\n")
    assert stamp(False) != plain
    for name in ("stamp_helper", "stamp_loop"):
        sys.modules.pop(name, None)


@pytest.mark.skipif(not compiled.AVAILABLE, reason="numba missing")
@pytest.mark.parametrize("contract", [False, True])
def test_contract_fuses_a_multiply_and_add(tmp_path, monkeypatch, contract):
    """A helper named in ``contract`` rounds ``a * b + c`` once (reference: the exact
    rational result rounded by ``fractions``); others round the product first."""
    from fractions import Fraction

    from llvmlite import binding

    if not binding.get_host_cpu_features().get("fma", False):
        pytest.skip("no fused multiply-add on this CPU")
    name = f"mad_{int(contract)}"
    (tmp_path / f"{name}.py").write_text("def mad(a, b, c):\n    return a * b + c\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    space = vars(importlib.import_module(name))
    compiled.jit_helpers(space, ("mad",), False, contract=("mad",) if contract else ())
    a = b = 1.0 + 2.0**-30  # a * b = 1 + 2^-29 + 2^-60: the last term lost when rounded
    fused = float(Fraction(a) * Fraction(b) - 1)
    assert fused == 2.0**-29 + 2.0**-60
    assert space["mad"](a, b, -1.0) == (fused if contract else 2.0**-29)
    del sys.modules[name]


def test_jit_setting_ignores_the_build(monkeypatch):
    monkeypatch.setenv("SUSPENV_COMPILED", "jit")
    lazy = importlib.import_module("suspenv.models.effects.kernels").recurrence
    assert compiled._built(lazy._space, lazy._helpers, lazy._main) is None


def test_every_ahead_loop_names_a_lazy_loop():
    for module, loops in compiled.AHEAD.items():
        mod = importlib.import_module(module)
        for attribute in loops:
            assert isinstance(getattr(mod, attribute), compiled.Lazy), (module, attribute)


def test_a_built_loop_refuses_a_column_order_array():
    """pycc's wrapper does not check the layout its C-contiguous signature declares, so
    a column-order array would be read as C-ordered: the loop refuses it by name."""
    lazy, _ = _built_or_skip("suspenv.models.effects.kernels", "recurrence")
    rng = np.random.default_rng(3)
    a, b, z0 = rng.normal(size=(4, 50)), rng.uniform(-1, 1, (4, 50)), rng.normal(size=4)
    out = np.empty((4, 51))
    lazy(a, b, z0, out)  # C-ordered: runs
    with pytest.raises(ValueError, match="recurrence: argument 0 must be a C-contiguous"):
        lazy(np.asfortranarray(a), b, z0, out)


def test_array_arguments_of_a_signature():
    """The arguments checked: those of the array types with their dtype and number of
    dimensions (read off the signatures by hand), not the scalars between them."""
    f8, i8 = np.dtype(np.float64), np.dtype(np.int64)
    assert compiled._array_arguments(
        compiled.AHEAD["suspenv.models.effects.kernels"]["recurrence"]
    ) == ((0, f8, 2), (1, f8, 2), (2, f8, 1), (3, f8, 2))
    circle = compiled.AHEAD["suspenv.models.minibus.handling_kernel"]["circle_loop"]
    assert compiled._array_arguments(circle) == ((0, f8, 2), (1, f8, 2), (5, f8, 2))
    assert compiled._array_arguments("int64(float64[:, ::1], int64[::1], float64)") == (
        (0, f8, 2),
        (1, i8, 1),
    )
    response = compiled.AHEAD["suspenv.models.minibus.handling_kernel"]["response_loop"]
    assert compiled._array_arguments(response)[2:] == (
        (2, np.dtype(np.complex128), 1),
        (3, np.dtype(np.complex128), 3),
    )


@pytest.mark.parametrize(
    ("wrong", "match"),
    [
        (lambda a: a.astype(np.float32), "2-D float64 array .* got a 2-D float32"),
        (lambda a: a[:, :, None], "2-D float64 array .* got a 3-D float64"),
    ],
)
def test_a_built_loop_refuses_another_dtype_or_dimension(wrong, match):
    """pycc's wrapper does not check the dtype or the number of dimensions either (a
    float32 array is read as float64, past its end): the loop refuses both by name."""
    lazy, _ = _built_or_skip("suspenv.models.effects.kernels", "recurrence")
    a, b, z0 = np.zeros((4, 50)), np.zeros((4, 50)), np.zeros(4)
    with pytest.raises(ValueError, match="recurrence: argument 0 must be a C-contiguous " + match):
        lazy(wrong(a), b, z0, np.empty((4, 51)))


def test_a_built_loop_refuses_a_column_order_array_after_its_scalars():
    """The last argument of the steady circle's loop (its output, after three scalars)
    is checked too: refused before the loop runs."""
    lazy, _ = _built_or_skip("suspenv.models.minibus.handling_kernel", "circle_loop")
    rows, table = np.zeros((3, 17)), np.zeros((4, 8))
    with pytest.raises(ValueError, match="_circle_loop: argument 5 must be a C-contiguous"):
        lazy(rows, table, 0.1, 2, 1.0, np.asfortranarray(np.zeros((3, 2))))


def test_built_recurrence_matches_python():
    lazy, loop = _built_or_skip("suspenv.models.effects.kernels", "recurrence")
    rng = np.random.default_rng(3)
    a, b, z0 = rng.normal(size=(4, 50)), rng.uniform(-1, 1, (4, 50)), rng.normal(size=4)
    got, want = np.empty((4, 51)), np.empty((4, 51))
    loop(a, b, z0, got)
    lazy._main(a, b, z0, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_built_rotation_loops_match_python():
    rng = np.random.default_rng(4)
    w, R = rng.normal(size=(6, 3)), rng.normal(size=(6, 3, 3))
    lazy, loop = _built_or_skip("suspenv.models.mcpherson.rotation_kernel", "_turned_loop")
    got, want = np.empty((6, 3, 3)), np.empty((6, 3, 3))
    loop(w, R, got)
    lazy._main(w, R, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    lazy, loop = _built_or_skip("suspenv.models.mcpherson.rotation_kernel", "_relative_log_loop")
    Q = np.linalg.qr(rng.normal(size=(2, 6, 3, 3)))[0]
    got, want = np.empty((6, 3)), np.empty((6, 3))
    loop(Q[0], Q[1], got)
    lazy._main(Q[0], Q[1], want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_every_ahead_signature_has_the_loops_arity():
    """A signature out of step with its loop would fail the build (which then goes on
    without the built loops): each names as many arguments as the loop takes."""
    import inspect

    for module, loops in compiled.AHEAD.items():
        mod = importlib.import_module(module)
        for attribute, signature in loops.items():
            main = getattr(mod, attribute)._main
            inner = signature[signature.index("(") + 1 : signature.rindex(")")]
            depth, count = 0, 1
            for ch in inner:
                depth += ch == "["
                depth -= ch == "]"
                count += ch == "," and depth == 0
            assert count == len(inspect.signature(main).parameters), (module, attribute)


@pytest.mark.skipif(not compiled.AVAILABLE, reason="numba missing")
def test_the_ahead_loops_load_in_the_build_environment(tmp_path) -> None:
    # setup.py builds the loops in pip's isolated build environment, which holds numba
    # and numpy but none of suspenv's other dependencies, suspenv's packages stubbed
    # (``compiled._exports``); a kernel module that imports one there (through another
    # suspenv package's __init__) makes the build skip the extension silently, and every
    # loop then compiles at its first call
    others = {
        re.split(r"[ <>=!~;\[]", r)[0].lower().replace("-", "_")
        for r in metadata.requires("suspenv") or []
        if "extra ==" not in r
    } - {"numpy", "numba"}
    script = tmp_path / "build_env.py"
    script.write_text(
        "import importlib.abc, importlib.util, sys\n"
        "from pathlib import Path\n"
        "root, blocked = Path(sys.argv[1]), set(sys.argv[2:])\n"
        "class Isolated(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.partition('.')[0] in blocked:\n"
        "            raise ImportError(f'not in the build environment: {name}')\n"
        "sys.meta_path.insert(0, Isolated())\n"
        "spec = importlib.util.spec_from_file_location(\n"
        "    'suspenv.core.compiled', root / 'suspenv/core/compiled.py')\n"
        "mod = sys.modules[spec.name] = importlib.util.module_from_spec(spec)\n"
        "spec.loader.exec_module(mod)\n"
        "assert mod._exports(root) is not None\n"
    )
    root = Path(compiled.__file__).resolve().parents[2]
    done = subprocess.run(
        [sys.executable, str(script), str(root), *sorted(others)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert others and done.returncode == 0, done.stderr[-2000:]
