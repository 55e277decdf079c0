"""The :class:`Recording`: one test's time histories with units and metadata.

A recording holds the time vector ``time`` [s] (strictly increasing), the channels
the rig imposed (``inputs``) and the channels it measured (``outputs``), each a 1-D
array with one value per time sample, the unit of every channel (SI inside
suspenv, one of :data:`suspenv.measurements.units.SI_UNITS`: "m", "m/s", "N", ...;
any other unit is refused on construction, so nothing downstream takes lbf or mm for
SI) and free metadata (``source``, ``sampling``, ``notes``...). The file format is
described in ``docs/recordings.md``; see :mod:`suspenv.measurements.io`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Protocol, runtime_checkable

import numpy as np

from suspenv.core.sampling import increasing_steps
from suspenv.measurements.errors import RecordingError
from suspenv.measurements.units import SI_UNITS, si_unit_of


def nonfinite_run(values: np.ndarray) -> tuple[int, int] | None:
    """First run of non-finite samples as ``(start, length)``, or None."""
    bad = ~np.isfinite(values)
    if not bad.any():
        return None
    start = int(np.argmax(bad))
    rest = bad[start:]
    length = int(np.argmin(rest)) if not rest.all() else int(rest.size)
    return start, length


def real_numbers(where: str, channel: str, values: object) -> np.ndarray:
    """``values`` as a float array; real numbers only (a complex, text or object array
    is refused with ``where``, the channel and its type, never silently cast)."""
    arr = np.asarray(values)
    if arr.dtype.kind not in "biuf":
        raise RecordingError(
            f"{where}: channel {channel!r} must hold real numbers, but its values are of "
            f"type {arr.dtype}"
        )
    return np.asarray(arr, dtype=float)


def check_units(where: str, units: Mapping[str, str], expected: Mapping[str, str]) -> None:
    """Every channel of ``expected`` (name -> unit) is in ``units`` in that unit."""
    for name, unit in expected.items():
        if name not in units:
            raise RecordingError(f"{where}: missing channel {name!r} (expected unit {unit!r})")
        if units[name] != unit:
            raise RecordingError(
                f"{where}: channel {name!r} must be in {unit!r}, but its unit is {units[name]!r}"
            )


def _check_si(where: str, what: str, unit: object) -> None:
    """Refuse a unit that is not SI: a known one names its conversion, an unknown one
    lists the SI units (a recording never takes a unit it cannot vouch for as SI)."""
    if isinstance(unit, str) and unit in SI_UNITS:
        return
    si = si_unit_of(unit)
    if si is not None:
        raise RecordingError(
            f"{where}: {what} is in {unit!r}, which is not SI; a recording holds SI units "
            f"(convert with suspenv.measurements.to_si: {unit!r} -> {si!r}; load_recording "
            "converts on reading)"
        )
    raise RecordingError(
        f"{where}: {what} has the unknown unit {unit!r}; a recording holds the SI units "
        f"{sorted(SI_UNITS)}"
    )


@runtime_checkable
class RecordingLike(Protocol):
    """Time histories of one test (:class:`suspenv.measurements.Recording` is one).

    Members:
        name: identifier of the run.
        test: what was done (e.g. ``"dyno_sine"``, ``"knc_opposite"``).
        time: sample times [s], ``(N,)``, strictly increasing.
        inputs / outputs: imposed / measured channels, name -> ``(N,)`` array.
        units: channel name (and ``"time"``) -> unit string.
        meta: free metadata (``source``, ``sampling``, rig settings).
        n_samples: ``N``.
        sample_interval: median sample interval [s].
    """

    @property
    def name(self) -> str: ...

    @property
    def test(self) -> str: ...

    @property
    def time(self) -> np.ndarray: ...

    @property
    def inputs(self) -> Mapping[str, np.ndarray]: ...

    @property
    def outputs(self) -> Mapping[str, np.ndarray]: ...

    @property
    def units(self) -> Mapping[str, str]: ...

    @property
    def meta(self) -> Mapping[str, Any]: ...

    @property
    def n_samples(self) -> int: ...

    @property
    def sample_interval(self) -> float: ...


@dataclass(eq=False)
class Recording:
    """Time histories of one test (SI units), validated on construction.

    Compared by identity (``eq=False``): channels are arrays.

    Attributes:
        name: identifier of the run (e.g. ``"emps_estimation"``).
        test: what was done (e.g. ``"sine_sweep"``, ``"dyno_sine"``, ``"emps_trajectory"``).
        time: sample times [s], strictly increasing, shape ``(N,)``.
        inputs: imposed channels, name -> ``(N,)`` array.
        outputs: measured channels, name -> ``(N,)`` array.
        units: channel name (and ``"time"``) -> unit string; every channel needs one.
        meta: free metadata; conventional keys ``source``, ``sampling``, ``notes``.
    """

    name: str
    test: str
    time: np.ndarray
    inputs: dict[str, np.ndarray] = field(default_factory=dict)
    outputs: dict[str, np.ndarray] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        where = f"recording {self.name!r}"
        self.time = real_numbers(where, "time", self.time)
        self.inputs = {k: real_numbers(where, k, v) for k, v in self.inputs.items()}
        self.outputs = {k: real_numbers(where, k, v) for k, v in self.outputs.items()}
        self.units = {"time": "s", **dict(self.units)}
        self.meta = dict(self.meta)
        self.validate()

    # ------------------------------------------------------------------ checks
    def validate(self) -> None:
        """Check shapes, time monotonicity, units and finiteness; raise :class:`RecordingError`."""
        where = f"recording {self.name!r}"
        t = self.time
        if t.ndim != 1 or t.size < 2:
            raise RecordingError(
                f"{where}: `time` must be 1-D with >= 2 samples, got shape {t.shape}"
            )
        run = nonfinite_run(t)
        if run:
            raise RecordingError(
                f"{where}: channel 'time' has {run[1]} non-finite sample(s) starting at "
                f"index {run[0]} (value {t[run[0]]})"
            )
        increasing_steps(t, f"{where}: ", "time", RecordingError)
        overlap = set(self.inputs) & set(self.outputs)
        if overlap:
            raise RecordingError(f"{where}: channels {sorted(overlap)} are both input and output")
        for kind, chans in (("input", self.inputs), ("output", self.outputs)):
            for name, arr in chans.items():
                if arr.shape != t.shape:
                    raise RecordingError(
                        f"{where}: {kind} channel {name!r} must have one value per time sample "
                        f"{t.shape}, but has shape {arr.shape}"
                    )
                if name not in self.units:
                    raise RecordingError(f"{where}: {kind} channel {name!r} has no unit in `units`")
                run = nonfinite_run(arr)
                if run:
                    raise RecordingError(
                        f"{where}: {kind} channel {name!r} has a run of {run[1]} non-finite "
                        f"sample(s) starting at index {run[0]} (t={t[run[0]]:.6g} s, "
                        f"value {arr[run[0]]})"
                    )
        if self.units.get("time") != "s":
            raise RecordingError(
                f"{where}: unit of 'time' must be 's', but got {self.units['time']!r}"
            )
        for kind, chans in (("input", self.inputs), ("output", self.outputs)):
            for name in chans:
                _check_si(where, f"{kind} channel {name!r}", self.units[name])

    def require(
        self,
        inputs: Iterable[str] = (),
        outputs: Iterable[str] = (),
        units: Mapping[str, str] | None = None,
    ) -> Recording:
        """Check that channels exist (as input or output) with the expected units; return self."""
        where = f"recording {self.name!r} (test {self.test!r})"
        wanted = (("input", inputs, self.inputs), ("output", outputs, self.outputs))
        for kind, names, have in wanted:
            for name in names:
                if name not in have:
                    raise RecordingError(
                        f"{where}: missing {kind} channel {name!r}; {kind}s are {sorted(have)}"
                    )
        check_units(where, self.units, units or {})
        return self

    # ------------------------------------------------------------------ access
    @property
    def n_samples(self) -> int:
        return int(self.time.size)

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.time[-1] - self.time[0])

    @property
    def sample_interval(self) -> float:
        """Median sample interval [s]."""
        return float(np.median(np.diff(self.time)))

    # ------------------------------------------------------------------ slicing
    def select(self, index: slice | np.ndarray, name: str | None = None, **meta: Any) -> Recording:
        """A new recording made of the samples ``index`` (slice or integer/boolean array)."""
        new_meta = {**self.meta, **meta}
        return replace(
            self,
            name=name or self.name,
            time=self.time[index],
            inputs={k: v[index] for k, v in self.inputs.items()},
            outputs={k: v[index] for k, v in self.outputs.items()},
            units=dict(self.units),
            meta=new_meta,
        )

    def segment(self, t_start: float, t_stop: float, name: str | None = None) -> Recording:
        """Samples with ``t_start <= time < t_stop`` [s]."""
        mask = (self.time >= t_start) & (self.time < t_stop)
        if mask.sum() < 2:
            raise RecordingError(
                f"recording {self.name!r}: segment [{t_start}, {t_stop}) s holds {int(mask.sum())} "
                f"samples; the recording spans [{self.time[0]}, {self.time[-1]}] s"
            )
        idx = np.flatnonzero(mask)
        return self.select(
            slice(idx[0], idx[-1] + 1), name, segment=[float(t_start), float(t_stop)]
        )

    def split(self, fraction: float = 0.7) -> tuple[Recording, Recording]:
        """Contiguous (estimation, validation) split at ``fraction`` of the samples."""
        if not 0.0 < fraction < 1.0:
            raise RecordingError(f"`0 < fraction < 1` must hold, but got fraction={fraction}")
        k = int(round(fraction * self.n_samples))
        if k < 2 or self.n_samples - k < 2:
            raise RecordingError(
                f"recording {self.name!r}: split at fraction {fraction} leaves fewer than 2 "
                f"samples on one side (N={self.n_samples})"
            )
        est = self.select(slice(0, k), f"{self.name}:estimation", role="estimation")
        val = self.select(slice(k, None), f"{self.name}:validation", role="validation")
        return est, val

    def split_blocks(
        self, n_blocks: int = 5, validation: Iterable[int] = (-1,)
    ) -> tuple[Recording, Recording]:
        """Interleaved split: cut into ``n_blocks`` and use blocks ``validation`` for validation.

        The estimation part joins the other blocks (its time stays increasing, with gaps).
        """
        if n_blocks < 2:
            raise RecordingError(f"`n_blocks >= 2` must hold, but got n_blocks={n_blocks}")
        edges = np.linspace(0, self.n_samples, n_blocks + 1).astype(int)
        val_ids = {b % n_blocks for b in validation}
        block = np.searchsorted(edges, np.arange(self.n_samples), side="right") - 1
        is_val = np.isin(block, list(val_ids))
        est = self.select(~is_val, f"{self.name}:estimation", role="estimation")
        val = self.select(is_val, f"{self.name}:validation", role="validation")
        return est, val

    def decimate(self, step: int) -> Recording:
        """Every ``step``-th sample (no filtering: only for signals already band-limited)."""
        if step < 1:
            raise RecordingError(f"`step >= 1` must hold, but got step={step}")
        return self.select(slice(None, None, step), decimated=step) if step > 1 else self

    def with_outputs(self, outputs: Mapping[str, np.ndarray], name: str | None = None) -> Recording:
        """Same time and inputs with other output channels (units kept by channel name)."""
        return Recording(
            name or self.name,
            self.test,
            self.time.copy(),
            {k: v.copy() for k, v in self.inputs.items()},
            {k: np.asarray(v, dtype=float) for k, v in outputs.items()},
            dict(self.units),
            dict(self.meta),
        )
