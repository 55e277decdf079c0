"""The identified car's K&C sheet: each standard metric measured (where the data have
the test), identified, with a 95 % interval, or predicted (a test not measured).

Metrics and their units and signs: :data:`suspenv.metrics.knc_report.ALL_ITEMS` (the
travel and steering numbers of ``docs/knc.md``) and the compliance numbers of
:func:`suspenv.metrics.knc_report.compliance_report`; ``/work/shared/spec/knc_sheet.md``
lists what a sheet holds.

Interval (delta method): the metric's gradient ``g`` with respect to the fitted values
(the fit's unit cube, forward differences of :data:`~suspenv.rigs.knc_fit.FD_STEP`,
all ``dim + 1`` designs in one batched rig call per test group) and the fit's covariance
``C`` (:func:`suspenv.methods.curves.identifiability.unit_covariance`: ``s^2 (J'J)^-1``): the
standard error is ``sqrt(g' C g)``, the 95 % interval +-1.96 of it. ``C`` is the larger
(per metric) of that and the cluster-robust sandwich over the measured loops (one test
and wheel, every channel: :func:`~suspenv.methods.curves.identifiability.sandwich_covariance`):
a misfit of a loop's physics (hysteresis of another shape, a fit stopped short) is
correlated over every channel recorded through it and biases the metrics the loops
disagree on, which ``s^2``, one factor for every direction, does not see. The sandwich
is estimated from ``G`` loop scores only (8 to 10 on a car, 2 per test): its interval
takes a small-sample quantile (:func:`sandwich_quantile`); a test fewer (one held out)
widens it. The gradient is taken on the model without its path-dependent elements (a
hysteresis loop's mean moves with the design as the elastic curve does); the value
itself on the whole model. A
metric that the measured curves do not determine gets a wide interval, not a false one.
Loop widths (hysteresis) get no interval (that model has no loop).
The right-minus-left asymmetry gets its own interval from the difference of the two
wheels' gradients (errors the sides share cancel).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from suspenv.diagnosis.knc.family import PATH_DEPENDENT
from suspenv.methods.curves.curve_fit import CurveFit
from suspenv.methods.curves.identifiability import sandwich_covariance
from suspenv.rigs.knc_fit import FD_STEP

#: rig tests the sheet runs on the identified model
SHEET_TESTS = (
    "parallel",
    "opposite",
    "steering",
    "lateral",
    "longitudinal",
    "traction",
    "aligning",
    "lateral_opposed",
    "aligning_opposed",
)
#: two-sided 95 % quantile of the normal distribution
Z95 = 1.959963984540054


@dataclass
class SheetRow:
    """One metric: per wheel (left, right) values in its unit."""

    name: str
    unit: str
    test: str
    sign: str
    identified: np.ndarray  # (2,)
    half_width: np.ndarray  # (2,) 95 % half-width (delta method)
    measured: np.ndarray | None  # (2,) or None (the test was not measured)
    needs: str = ""  # why the measured value is missing
    asymmetry_half_width: float = 0.0  # 95 % half-width of right - left (delta method)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "unit": self.unit,
            "test": self.test,
            "sign": self.sign,
            "identified": self.identified.tolist(),
            "ci95_half_width": self.half_width.tolist(),
            "measured": None if self.measured is None else self.measured.tolist(),
            "status": "measured" if self.measured is not None else "predicted",
            "needs": self.needs,
            "asymmetry": float(self.identified[1] - self.identified[0]),
            "asymmetry_ci95_half_width": self.asymmetry_half_width,
        }


def sheet_values(results: dict[str, Any], constants: Any = None) -> dict[str, np.ndarray]:
    """Every sheet metric the results allow: name -> (n, 2)."""
    from suspenv.metrics.knc_report import compliance_report, knc_report

    return {**knc_report(results, constants), **compliance_report(results)}


def _run(fit: CurveFit, X: np.ndarray, effects: Any, steps: int) -> dict[str, Any]:
    """The sheet's tests of designs X: the measured travel amplitude, the rig's loads."""
    travel = {"amplitude": fit.model.travel_amplitude}
    return fit.model.run(X, SHEET_TESTS, steps, effects, travel)


def sandwich_quantile(clusters: int) -> float:
    """The 95 % half-width in standard errors of a cluster-robust sandwich over
    ``clusters`` scores: ``sqrt(G / (G - 1)) t_0.975(G - 1)`` (the finite-sample factor
    and Student's t of the ``G - 1`` degrees of freedom the scores leave); tends to
    :data:`Z95` as ``G`` grows."""
    from scipy.stats import t

    g = max(int(clusters), 2)
    return float(np.sqrt(g / (g - 1)) * t.ppf(0.975, g - 1))


def _half_widths(
    g: np.ndarray, gd: np.ndarray, covs: tuple[tuple[np.ndarray, float], ...]
) -> tuple[np.ndarray, float]:
    """95 % half-widths of the two wheels' values (gradients ``g`` (dim, 2)) and of their
    difference (``gd`` (dim,)): the largest over the (covariance, quantile) pairs ``covs``."""
    var = np.max([q * q * np.einsum("ik,ij,jk->k", g, c, g) for c, q in covs], axis=0)
    var_d = np.max([q * q * float(gd @ c @ gd) for c, q in covs])  # NaN stays NaN
    return np.sqrt(np.maximum(var, 0.0)), float(np.sqrt(np.maximum(var_d, 0.0)))


def knc_sheet(
    fit: CurveFit, cov_unit: np.ndarray, measured: dict[str, Any] | None = None
) -> list[SheetRow]:
    """The sheet of the fitted car ``fit`` with the fit's unit-cube covariance
    ``cov_unit`` (dim, dim); ``measured``: {test: KCResult} of the measurement (its
    loops on a grid), whose metrics are shown beside the identified ones."""
    from suspenv.metrics.knc_report import ALL_ITEMS, COMPLIANCE_ITEMS, report_needs

    loops = {n for n in COMPLIANCE_ITEMS if "_loop_width_" in n}

    model = fit.model
    steps = max(t.steps for t in model.tests)
    x = model.full(fit.x)
    value = sheet_values(_run(fit, x, model.effects_at(fit.x), steps), model.constants)
    h = np.where(fit.u + FD_STEP <= 1.0, FD_STEP, -FD_STEP)
    U = np.tile(fit.u, (model.dim + 1, 1))
    U[1:] += np.diag(h)
    elastic = tuple(e for e in model.effects_at(fit.x) if e.kind not in PATH_DEPENDENT)
    grads = sheet_values(_run(fit, model.designs(U), elastic, steps), model.constants)
    meas = sheet_values(measured, model.constants) if measured else {}
    needs = report_needs(measured) if measured else {}
    items = {**ALL_ITEMS, **COMPLIANCE_ITEMS}
    rows = []
    loops_rows = model.loops()
    covs = (
        (cov_unit, Z95),
        (
            sandwich_covariance(fit.jacobian, fit.residual, loops_rows),
            sandwich_quantile(len(loops_rows)),
        ),
    )
    for name, v in value.items():
        # (dim, 2); a metric that a finite-difference design cannot give leaves its
        # interval unknown (NaN), never narrowed by a zero gradient
        g = (grads[name][1:] - grads[name][0]) / h[:, None]
        gd = g[:, 1] - g[:, 0]  # right - left: the sides' common errors cancel
        hw, hw_d = _half_widths(g, gd, covs)
        if name in loops:  # the gradient's model has no loop: no interval
            hw, hw_d = np.full(2, np.nan), float("nan")
        item = items[name]
        m = meas.get(name)
        have = m is not None and bool(np.all(np.isfinite(m[0])))
        rows.append(
            SheetRow(
                name,
                item.unit,
                item.test,
                item.sign,
                v[0],
                hw,
                m[0] if have and m is not None else None,
                needs.get(name, "" if have else f"needs: the {item.test} test"),
                hw_d,
            )
        )
    return rows
