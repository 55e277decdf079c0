"""The typed seam between the diagnosis and the models it fits: structural protocols.

The diagnosis (fit, evidence, refits, the loop) reads a model and a recording only
through the members listed here; nothing probes for optional attributes. Models live
below the diagnosis (``suspenv.models``, ``suspenv.rigs.knc_axle``) and satisfy
these protocols structurally: they import nothing from this module.

:class:`DiagnosableModel` is generic in the recording type a model reads (``R``, a
:class:`RecordingLike`) and the effect type it holds (``E``, an :class:`EffectLike`),
so a model typed against the concrete :class:`suspenv.measurements.Recording` and its
own effect class is a ``DiagnosableModel[Recording, Effect]``; a bare
``DiagnosableModel`` accepts any.

Units: SI throughout; ``theta`` in the units of each parameter (the model's
``parameter_units`` where it has them).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, TypeVar, runtime_checkable

import numpy as np

from suspenv.measurements.recording import RecordingLike


@runtime_checkable
class EffectLike(Protocol):
    """One element added to a base model: its kind (an effects-library kind), its name
    (unique in the model; parameters are named ``"<name>.<parameter>"``), where it acts
    (``""``: the model's own default location), a copy with other parameter values and
    a JSON-friendly record (:class:`suspenv.models.effects.Effect` is one)."""

    @property
    def kind(self) -> str: ...

    @property
    def name(self) -> str: ...

    @property
    def location(self) -> str: ...

    def with_params(self, values: Mapping[str, Any]) -> EffectLike: ...

    def to_dict(self) -> dict[str, Any]: ...


R_contra = TypeVar("R_contra", bound=RecordingLike, contravariant=True)
E = TypeVar("E", bound=EffectLike)


@runtime_checkable
class DiagnosableModel(Protocol[R_contra, E]):
    """A model the diagnosis can fit, extend by effects and test.

    Members:
        family: model family (``"damper"``, ``"quarter_car_rig"``, ``"knc_axle"``, ...).
        location: where the force effects of a one-location component act, in words
            (``"damper"``, ``"guide"``); ``""`` where effects name their own location.
        parameter_names: names of ``theta``, base parameters first, then
            ``"<effect name>.<parameter>"``.
        output_channels: channels :meth:`simulate` can predict.
        effects: the effects in the model, in ``theta`` order.
        effect_defaults: per effect kind, shape constants this model fixes for the
            effects it adds (e.g. a friction regularisation width its integrator needs);
            empty where the effects library's defaults hold.
        candidate_effects: the candidates a diagnosis considers by default
            (``kind`` or ``kind@location``).
    """

    @property
    def family(self) -> str: ...

    @property
    def location(self) -> str: ...

    @property
    def parameter_names(self) -> tuple[str, ...]: ...

    @property
    def output_channels(self) -> tuple[str, ...]: ...

    @property
    def effects(self) -> tuple[E, ...]: ...

    @property
    def effect_defaults(self) -> Mapping[str, Mapping[str, float]]: ...

    @property
    def candidate_effects(self) -> tuple[str, ...]: ...

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of ``theta``, each ``(p,)``."""
        ...

    def initial_guess(self, rec: R_contra) -> np.ndarray:
        """A start point ``(p,)`` for fitting ``rec``, inside the bounds."""
        ...

    def simulate(self, theta: np.ndarray, rec: R_contra) -> dict[str, np.ndarray]:
        """Predicted output channels of ``rec``: ``(N,)`` each for ``theta`` ``(p,)``,
        ``(B, N)`` for a batch ``(B, p)``. Raises ``EvaluationError`` where a single
        ``theta`` cannot be simulated (a batch row that fails becomes NaN)."""
        ...

    def unpack(self, theta: np.ndarray) -> tuple[dict[str, np.ndarray], list[E]]:
        """Base parameter values by name and the effects with their values from ``theta``."""
        ...

    def with_effects(self, effects: Sequence[E]) -> DiagnosableModel[R_contra, E]:
        """The same model (same options) with another list of effects."""
        ...

    def difference_step(self, theta: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Positive forward-difference step ``(p,)`` per parameter at ``theta`` (the fit
        steps backwards where the step would leave the upper bound ``hi``)."""
        ...

    def refine_start(
        self,
        theta0: np.ndarray,
        recordings: Sequence[R_contra],
        masks: Sequence[np.ndarray | None] | None,
    ) -> np.ndarray | None:
        """A cheap model-specific improvement of the start point ``theta0`` (kept by the
        fit only where it lowers the simulation residual); None: no refinement."""
        ...

    def jacobian_model(self) -> DiagnosableModel[R_contra, E]:
        """A cheaper twin (same parameters) for the finite-difference Jacobians of the
        iterations; the model itself where there is none."""
        ...

    def force_view(self, theta: np.ndarray, rec: R_contra) -> dict[str, np.ndarray] | None:
        """The model's internal force seen through a measured equation, for residual
        signatures (``measured``, ``predicted`` [N], ``x`` [m], ``v`` [m/s], ``jacobian``
        ``(N, p)``); None where the model has no such view or ``rec`` lacks its channels."""
        ...
