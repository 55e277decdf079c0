"""The benchmark suite: named, versioned problem instances with what a benchmarker needs.

An instance is a problem with fixed options, a budget and what is known of its optimum.
Like COCO's, instances of one function differ by a seed (here: the truth of an
identification problem and its sensor noise, a minibus road); ``instance`` is that seed.
Every instance states its dimension, objectives, constraints and budget, and one of:

- ``optimum``: the known optimum ``f_opt`` of the scalar quality and a design ``x_opt``
  reaching it (closed form: Sphere; the target geometry: planar; the truth: the K&C
  problem without concealed effects);
- ``target``: the quality of the known truth where the optimum itself is not known (an
  identification with tolerances or noise: the truth's value is a reachable level, and
  noise can be fitted below it);
- ``front``: a reference front for several objectives, analytic (ZDT1) or computed once
  with a large budget and shipped with its provenance (:mod:`suspenv.suite.fronts`).

``SUITE_VERSION`` changes whenever an instance's definition changes, so results are
compared only within one version.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import did_you_mean
from suspenv.core.problem import Problem
from suspenv.registry import make_problem

#: changes with any change of an instance's definition (problem, options, budget, optimum)
SUITE_VERSION = "2026.11-2"


@dataclass(frozen=True)
class Known:
    """What is known of an instance's optimum (see the module docstring)."""

    kind: str  # "optimum", "target" or "front"
    f: float | None = None  # f_opt or the truth's quality (lower is better)
    x: tuple[float, ...] | None = None  # a design reaching f (physical units)
    front: str | None = None  # name of the reference front (suspenv.suite.fronts)
    source: str = ""  # where it comes from, in words

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "x": None if self.x is None else list(self.x)}


@dataclass(frozen=True)
class Function:
    """A suite function: a problem with options; ``instance_options(i)`` varies them by
    instance (COCO's instance number), ``known(problem)`` says what is known."""

    name: str
    problem: str
    options: Mapping[str, Any]
    budget: int
    description: str
    known: Callable[[Problem], Known]
    instance_options: Callable[[int], dict[str, Any]] = field(default=lambda _: {})
    instances: tuple[int, ...] = (1,)
    noisy: bool = False

    def options_for(self, instance: int) -> dict[str, Any]:
        if instance not in self.instances:
            raise ValidationError(
                f"suite function {self.name!r} has instances {list(self.instances)}, but got "
                f"instance={instance!r}"
            )
        return {**dict(self.options), **self.instance_options(instance)}


@dataclass(frozen=True)
class Instance:
    """One instance, built: its problem and what is known of its optimum."""

    function: Function
    instance: int
    problem: Problem
    known: Known

    @property
    def name(self) -> str:
        return f"{self.function.name}/i{self.instance}"

    def describe(self) -> dict[str, Any]:
        """The instance's card: what a benchmarker needs, as plain data."""
        p = self.problem
        return {
            "name": self.name,
            "suite_version": SUITE_VERSION,
            "function": self.function.name,
            "instance": self.instance,
            "problem": self.function.problem,
            "options": self.function.options_for(self.instance),
            "dimension": p.space.dim,
            "objectives": len(p.objective_names),
            "constraints": len(p.constraint_names),
            "budget": self.function.budget,
            "noisy": self.function.noisy,
            "quality": p.quality_name,
            "known": self.known.as_dict(),
            "description": self.function.description,
        }


def _sphere(p: Problem) -> Known:
    x = tuple(0.3 for _ in range(p.space.dim))  # Sphere: f = sum((x - 0.3)^2)
    return Known("optimum", 0.0, x, source="closed form: f = sum((x - 0.3)^2), minimum at 0.3")


def _at(p: Problem, x: np.ndarray, kind: str, source: str) -> Known:
    batch = p.evaluate(np.asarray(x, dtype=float)[None, :])
    if not batch.ok[0]:
        raise ValidationError(f"suite: the known design of {p.name} fails: {batch.messages[0]}")
    q = p.quality(batch.objectives)
    if q is None:
        raise ValidationError(f"suite: {p.name} has no scalar quality for a known {kind}")
    f = float(q[0])
    return Known(kind, f, tuple(float(v) for v in x), source=source)


def _planar(p: Problem) -> Known:
    geometry = getattr(p, "target_geometry", None)
    if geometry is None:
        raise ValidationError("suite: the planar function needs a target geometry")
    points = geometry.points_mm()
    x = np.array([points[n.split(".")[0]][0 if n.endswith(".y") else 1] for n in p.space.names])
    return _at(p, x, "optimum", "the target geometry's own hard points (curve error 0)")


def _kc_exact(p: Problem) -> Known:
    return _at(
        p,
        p.space.reference(),
        "optimum",
        "no concealed effect: the truth is the reference vehicle, every objective 0",
    )


def _kc_truth(p: Problem) -> Known:
    hook = getattr(p, "truth_design", None)
    if not callable(hook):
        raise ValidationError(f"suite: {p.name} has no truth design")
    truth = hook()
    return _at(
        p,
        truth,
        "target",
        "the quality of the truth (mean of the test vehicle's two sides); the optimum is "
        "not known: tolerances differ left and right, and noise can be fitted below it",
    )


def _front(name: str, source: str) -> Callable[[Problem], Known]:
    def known(p: Problem) -> Known:
        return Known("front", front=name, source=source)

    return known


#: the suite, by function name
FUNCTIONS: dict[str, Function] = {
    f.name: f
    for f in (
        Function(
            "sphere-10d",
            "Sphere",
            {"dim": 10},
            2000,
            "sum of squares in [-1, 1]^10 (framework check; every strategy should solve it)",
            _sphere,
        ),
        Function(
            "zdt1-6d",
            "ZDT1",
            {"dim": 6},
            3000,
            "ZDT1, 2 objectives, convex front f2 = 1 - sqrt(f1)",
            _front("zdt1", "analytic: f2 = 1 - sqrt(f1), x[1:] = 0"),
        ),
        Function(
            "planar-curves",
            "PlanarLinkage",
            {},
            1500,
            "double wishbone, 6 hard-point coordinates, camber and half-track curves of a "
            "target geometry",
            _planar,
        ),
        Function(
            "kc-exact",
            "KCIdentification",
            {"concealed": []},
            2250,
            "McPherson K&C identification, 49 parameters, 40 objectives, no concealed effect",
            _kc_exact,
        ),
        Function(
            "kc-tolerance",
            "KCIdentification",
            {"concealed": ["tolerance"]},
            2250,
            "K&C identification of a test car built within tolerances (noise-free); the "
            "instance is the car's seed",
            _kc_truth,
            instance_options=lambda i: {"truth_seed": i},
            instances=(1, 2, 3, 4, 5),
        ),
        Function(
            "kc-noisy",
            "KCIdentification",
            {"concealed": ["tolerance", "noise"]},
            2250,
            "the same cars measured with sensor noise; the instance seeds car and noise",
            _kc_truth,
            instance_options=lambda i: {"truth_seed": i},
            instances=(1, 2, 3, 4, 5),
            noisy=True,
        ),
        Function(
            "carside",
            "CarSideImpact",
            {},
            5000,
            "car side impact (RE suite CRE31): 7 thicknesses, 3 objectives, 10 constraints",
            _front("carside", "NSGA-II with a large budget, see the front's provenance"),
        ),
        Function(
            "minibus",
            "MinibusRideHandling",
            {},
            6000,
            "minibus suspension, 8 variables, 5 objectives over two loads, constraints",
            _front("minibus", "NSGA-II with a large budget, see the front's provenance"),
        ),
    )
}


def function(name: str) -> Function:
    """The suite function ``name`` (an error with suggestions when unknown)."""
    try:
        return FUNCTIONS[name]
    except KeyError:
        hint = did_you_mean(name, FUNCTIONS, n=2)
        raise ValidationError(
            f"unknown suite function {name!r}{hint} (known: {', '.join(FUNCTIONS)})"
        ) from None


def parse_instance(text: str) -> tuple[str, int | None]:
    """``"kc-noisy/i3"`` -> ("kc-noisy", 3); ``"kc-noisy"`` -> ("kc-noisy", None)."""
    name, sep, rest = text.partition("/")
    if not sep:
        return name, None
    if not rest.startswith("i") or not rest[1:].isdigit():
        raise ValidationError(
            f"an instance is written NAME/iN, e.g. 'kc-noisy/i3', but got {text!r}"
        )
    return name, int(rest[1:])


def build(name: str, instance: int = 1) -> Instance:
    """Build an instance (its problem, and what is known of its optimum)."""
    f = function(name)
    problem = make_problem(f.problem, **f.options_for(instance))
    return Instance(f, instance, problem, f.known(problem))


def selection(names: list[str] | None = None) -> list[tuple[str, int]]:
    """(function, instance) pairs: every instance of the named functions (all by
    default); a name may pick one instance with ``NAME/iN``."""
    out: list[tuple[str, int]] = []
    for text in names or list(FUNCTIONS):
        name, inst = parse_instance(text)
        f = function(name)
        if inst is not None:
            f.options_for(inst)  # checks the instance exists
        out += [(name, i) for i in ((inst,) if inst is not None else f.instances)]
    return out
