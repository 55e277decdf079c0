"""BLAS thread policy.

suspenv's linear algebra is many *small* dense problems (49x49 covariance matrices,
batched 10x10 Newton steps). Multi-threaded BLAS makes these slower, and far slower on a
loaded machine (measured: ``eigh`` of 49x49 took ~17 ms with 2 OpenBLAS threads under load
vs ~1 ms with one). suspenv therefore limits BLAS to one thread per process at import and
scales out with processes (``--workers``) instead. Set ``SUSPENV_BLAS_THREADS=N`` to choose
another limit, or ``SUSPENV_BLAS_THREADS=0`` to leave the BLAS library alone.
"""

from __future__ import annotations

import os

_limiter = None


def limit_blas_threads() -> int | None:
    """Apply the policy above; returns the limit set (None when left alone)."""
    global _limiter
    raw = os.environ.get("SUSPENV_BLAS_THREADS", "1")
    try:
        n = int(raw)
    except ValueError:
        raise ValueError(f"SUSPENV_BLAS_THREADS must be an integer >= 0, but got {raw!r}") from None
    if n <= 0:
        return None
    # effective for libraries not loaded yet, and inherited by worker processes
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, str(n))
    import numpy  # noqa: F401 - load the BLAS libraries so they can be limited
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_limits

    _limiter = threadpool_limits(limits=n, user_api="blas")
    return n
