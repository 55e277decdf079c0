"""Build hook: the compiled loops a K&C evaluation runs, built ahead of time (numba's pycc)
as the optional extension ``suspenv.core._kernels`` (see suspenv/core/compiled.py). Without a
C compiler the build goes on without it and the loops are compiled at their first call."""

import importlib.util
import sys
from pathlib import Path

from setuptools import setup

ROOT = Path(__file__).parent
# loaded alone: the build environment has numba and numpy, not suspenv's other dependencies
spec = importlib.util.spec_from_file_location(
    "suspenv.core.compiled", ROOT / "suspenv/core/compiled.py"
)
assert spec is not None and spec.loader is not None
compiled = sys.modules[spec.name] = importlib.util.module_from_spec(spec)
spec.loader.exec_module(compiled)

try:
    kernels = compiled.extension(ROOT)
except Exception as exc:  # noqa: BLE001 - the package works without them (compiled at first call)
    print(f"suspenv: compiled loops not built ahead of time ({exc}); they compile at first use")
    kernels = None
setup(ext_modules=[kernels] if kernels is not None else [])
