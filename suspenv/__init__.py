"""suspenv: vehicle suspension problems as fast, honest black-box optimisation problems.

Layers (one job each): ``models`` (what the hardware is), ``rigs`` (what we do to it),
``metrics`` (what we measure), ``problems`` (what we want), ``envs`` (Gymnasium face),
``strategies`` (optimisers behind one ask/tell seam), ``runs`` (the loop, the evaluation
archive, configs and run directories), ``methods`` (whole methods such as the Tey et al.
pipeline), ``measurements`` (recorded time histories and their loaders), ``diagnosis``
(when simulation and recordings disagree), ``reports`` (Markdown and figures), ``cli``.
"""

from suspenv.threads import limit_blas_threads

limit_blas_threads()

# every registered problem is a Gymnasium env ``suspenv/<Name>-v0`` as soon as suspenv is
# imported (registration is lazy: no problem module is imported here)
from suspenv import envs as _envs  # noqa: E402, F401
from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem  # noqa: E402
from suspenv.registry import list_problems, make_problem  # noqa: E402

__version__ = "0.1.0"
__all__ = [
    "DesignSpace",
    "EvaluationBatch",
    "Parameter",
    "Problem",
    "list_problems",
    "make_problem",
    "__version__",
]
