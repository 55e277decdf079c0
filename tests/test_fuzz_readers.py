"""Property-based tests of the file readers: whatever the bytes, a reader returns a valid
object or raises ``ValidationError`` (never another exception, never a traceback).

Recording readers (:func:`suspenv.measurements.read_recording`: ``.npz``, ``.mat``,
``.csv``, ``.dat``; road profiles ``.txt``) get random archives, headers, arrays, units and
text; the vehicle-file reader (:func:`suspenv.models.mcpherson.vehicle_file.load_vehicle`)
gets random TOML documents and perturbed copies of the reference vehicle. Every file is
small and the read limit is 1 MiB, so the whole module runs in seconds.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from suspenv.core.errors import ValidationError
from suspenv.measurements import Recording, read_recording
from suspenv.measurements.sources.road_profile import load_profile_txt
from suspenv.measurements.units import SI_UNITS
from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, VehicleFile, load_vehicle

LIMIT = 2**20
#: CI replays a fixed set of examples; elsewhere every run explores new ones
FUZZ = settings(
    max_examples=60,
    deadline=None,
    database=None,
    derandomize=bool(os.environ.get("CI")),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def read_or_refuse(path: Path) -> None:
    """The property: a valid Recording (SI units, finite, increasing time) or a
    ValidationError; any other exception fails the test."""
    try:
        rec = read_recording(path, max_bytes=LIMIT)
    except ValidationError:
        return
    assert isinstance(rec, Recording)
    assert rec.n_samples >= 2 and np.all(np.diff(rec.time) > 0)
    for name, values in {**rec.inputs, **rec.outputs}.items():
        assert rec.units[name] in SI_UNITS
        assert values.shape == rec.time.shape and np.all(np.isfinite(values))


# ------------------------------------------------------------------ building blocks
UNITS = st.one_of(
    st.sampled_from(
        [
            "m",
            "mm",
            "in",
            "N",
            "lbf",
            "kN",
            "s",
            "ms",
            "Sec",
            "m/s",
            "in/s",
            "m/s^2",
            "deg",
            "rad",
            "-",
            "1",
            "V",
            "furlong",
            "",
            " N ",
            "LBF",
            "g",
        ]
    ),
    st.text(max_size=4),
)
NAMES = st.sampled_from(["displacement", "velocity", "force", "position", "x", "time", ""])
NUMBERS = st.floats(allow_nan=True, allow_infinity=True, width=64)
JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 5) | st.floats() | st.text(max_size=4),
    lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=4), c, max_size=3),
    max_leaves=6,
)


@st.composite
def channel_arrays(draw: Any, n: int) -> np.ndarray:
    kind = draw(
        st.sampled_from(
            ["good", "good", "good", "int", "bool", "text", "complex", "2d", "short", "empty"]
        )
    )
    if kind == "text":
        return np.array(draw(st.lists(st.text(max_size=3), min_size=1, max_size=n + 1)))
    if kind == "complex":
        return np.zeros(n, complex) + 1j
    if kind == "2d":
        return np.zeros((n, 2))
    if kind == "empty":
        return np.zeros(0)
    size = max(n - 1, 0) if kind == "short" else n
    dtype = {"int": np.int16, "bool": np.bool_}.get(kind, np.float64)
    elements = NUMBERS if dtype is np.float64 else None
    return draw(hnp.arrays(dtype, size, elements=elements))


#: units a reader converts (or keeps), per channel kind
GOOD_UNITS = {
    "time": ["s", "ms", "sec"],
    "displacement": ["m", "mm", "in", "cm"],
    "velocity": ["m/s", "mm/s", "in/s"],
    "force": ["N", "lbf", "kN"],
}
ARCHIVE_FAULTS = [
    "unit",
    "drop_key",
    "replace_key",
    "array",
    "drop_array",
    "meta_text",
    "meta_array",
    "no_meta",
    "time",
    "repeat",
    "non_finite",
    "huge",
    "extra_member",
]


@st.composite
def recording_archives(draw: Any) -> dict[str, Any]:
    """A valid archive (converted units included) with up to three faults applied."""
    n = draw(st.integers(2, 40))
    inputs = draw(st.lists(st.sampled_from(["displacement", "velocity"]), unique=True, max_size=2))
    outputs = ["force"] if draw(st.integers(0, 4)) else []
    units = {k: draw(st.sampled_from(GOOD_UNITS[k])) for k in ["time", *inputs, *outputs]}
    header: dict[str, Any] = {
        "format": "suspenv-recording",
        "version": 1,
        "name": draw(st.text(max_size=6)),
        "test": draw(st.sampled_from(["dyno_sine", "knc_parallel", "pulse", "x"])),
        "inputs": inputs,
        "outputs": outputs,
        "units": units,
        "meta": draw(
            st.dictionaries(st.sampled_from(["rig", "steps", "amplitude", "a"]), JSON, max_size=3)
        ),
    }
    values = st.floats(-1e3, 1e3)
    arrays: dict[str, Any] = {
        "time": np.cumsum(draw(hnp.arrays(np.float64, n, elements=st.floats(1e-3, 1.0))))
    }
    for prefix, names in (("in", inputs), ("out", outputs)):
        for name in names:
            arrays[f"{prefix}.{name}"] = draw(hnp.arrays(np.float64, n, elements=values))
    channels = sorted(arrays)
    draft = _Draft(n, inputs, outputs, units, header, arrays)
    meta: Any = json.dumps(header)
    for fault in draw(st.lists(st.sampled_from(ARCHIVE_FAULTS), unique=True, max_size=3)):
        key = draw(st.sampled_from(sorted(header)))
        chan = draw(st.sampled_from(channels))
        _apply_fault(draw, fault, draft, key, chan)
        meta = _meta_after(draw, fault, header)
    if meta is not None:
        arrays["__meta__"] = np.array(meta)
    return arrays


@dataclass
class _Draft:
    """An archive being drawn: what its faults change (in place) and what they read."""

    n: int
    inputs: list[str]
    outputs: list[str]
    units: dict[str, str]
    header: dict[str, Any]
    arrays: dict[str, Any]


def _apply_fault(draw: Any, fault: str, draft: _Draft, key: str, chan: str) -> None:
    """Apply one fault of :data:`ARCHIVE_FAULTS` to the header, units or arrays of
    ``draft`` (``key``: a header key, ``chan``: an array name; the meta faults act on
    the header's text: :func:`_meta_after`)."""
    header, arrays, n = draft.header, draft.arrays, draft.n
    if fault == "unit":
        draft.units[draw(st.sampled_from(sorted(draft.units)))] = draw(UNITS)
    elif fault == "drop_key":
        header.pop(key, None)
    elif fault == "replace_key":
        header[key] = draw(JSON)
    elif fault == "array":
        arrays[chan] = draw(channel_arrays(n))
    elif fault == "drop_array":
        arrays.pop(chan, None)
    elif fault == "repeat":
        header["inputs"] = [*draft.inputs, *draft.inputs, *draft.outputs]
    elif fault == "time":
        arrays["time"] = draw(hnp.arrays(np.float64, n, elements=NUMBERS))
    elif fault in ("non_finite", "huge") and chan in arrays and arrays[chan].dtype == float:
        arrays[chan] = arrays[chan] * (np.nan if fault == "non_finite" else 1e300)
    elif fault == "extra_member":
        arrays["extra"] = draw(channel_arrays(n))


def _meta_after(draw: Any, fault: str, header: dict[str, Any]) -> Any:
    """The archive's ``__meta__`` after ``fault``: the header as JSON, or text that is
    not JSON, an array that is not text, or None (no meta member)."""
    if fault == "meta_text":
        return draw(st.text(max_size=20))
    if fault == "meta_array":
        return np.zeros(3)
    if fault == "no_meta":
        return None
    return json.dumps(header)


# ------------------------------------------------------------------ recording readers
@FUZZ
@given(archive=recording_archives(), compressed=st.booleans())
def test_npz_reader_returns_a_recording_or_refuses(work, archive, compressed):
    path = work / "r.npz"
    save = np.savez_compressed if compressed else np.savez
    with open(path, "wb") as fh:
        save(fh, **archive)
    read_or_refuse(path)


@FUZZ
@given(
    data=st.binary(max_size=400),
    suffix=st.sampled_from([".npz", ".mat", ".csv", ".dat", ".txt"]),
    zipped=st.booleans(),
)
def test_any_bytes_are_refused_or_read(work, data, suffix, zipped):
    path = work / f"b{suffix}"
    if zipped:  # a zip archive whose members are random bytes (some named as arrays)
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w") as zf:
            zf.writestr("time.npy", data)
            zf.writestr("__meta__.npy", data[::-1])
        data = buf.getvalue()
    path.write_bytes(data)
    if suffix == ".txt":
        with contextlib.suppress(ValidationError):
            load_profile_txt(path, max_bytes=LIMIT)
    else:
        read_or_refuse(path)


EMPS_COLUMNS = ["time_exp", "q_ref", "q_meas", "v_est", "u_in", "u_tot"]
CSV_CELLS = st.one_of(
    st.floats(-10, 10).map(repr),
    st.sampled_from(["nan", "inf", "-inf", "", "1e999", "a"]),
)


@FUZZ
@given(
    columns=st.one_of(
        st.just(EMPS_COLUMNS),
        st.permutations(EMPS_COLUMNS),
        st.lists(st.sampled_from([*EMPS_COLUMNS, "x", ""]), min_size=1, max_size=7),
    ),
    rows=st.integers(0, 60),
    dt=st.sampled_from([0.005, 0.005, 0.001, 0.0, -0.005, 1e-300]),
    noise=st.lists(st.tuples(st.integers(0, 60), st.integers(0, 7), CSV_CELLS), max_size=3),
)
def test_emps_csv_reader_returns_a_recording_or_refuses(work, columns, rows, dt, noise):
    columns = list(columns)
    table = [[repr(0.1 * math.sin(i / 5.0) + j) for j in range(len(columns))] for i in range(rows)]
    if "time_exp" in columns:
        for i, row in enumerate(table):
            row[columns.index("time_exp")] = repr(i * dt)
    for i, j, cell in noise:
        if i < rows and j < len(columns):
            table[i][j] = cell
    text = ",".join(columns) + "\n" + "".join(",".join(r) + "\n" for r in table)
    path = work / "DATA_EMPS_SC.csv"
    path.write_text(text)
    read_or_refuse(path)


DYNO_UNITS = st.one_of(
    st.sampled_from([("in", "lbf", "Sec"), ("mm", "N", "s"), ("m", "kN", "ms")]),
    st.tuples(UNITS, UNITS, UNITS),
)


@FUZZ
@given(
    units=DYNO_UNITS,
    blocks=st.sampled_from([0, 1, 1, 2, 3]),
    rows=st.one_of(st.integers(0, 12), st.integers(12, 40), st.integers(12, 40)),
    cells=st.lists(st.tuples(st.integers(0, 200), st.text(max_size=6)), max_size=2),
    header=st.sampled_from(["Stroke\tLoad\tTime"] * 4 + ["Stroke\tLoad", "Load\tStroke\tTime"]),
)
def test_dyno_reader_returns_a_recording_or_refuses(work, units, blocks, rows, cells, header):
    lines: list[str] = []
    k = 0
    for _ in range(blocks):
        lines += ["", "Data Acquisition 1  Time: 0", header, "\t".join(units)]
        for _ in range(rows):
            lines.append(f"{0.5 * math.sin(k / 7):.6f}\t{30 * math.cos(k / 7):.4f}\t{k / 1024:.6f}")
            k += 1
    for i, text in cells:
        if i < len(lines):
            lines[i] = text
    path = work / "dyno.dat"
    path.write_text("\r\n".join(lines) + "\r\n", encoding="latin-1", errors="replace")
    read_or_refuse(path)


MAT_VALUE = st.one_of(
    hnp.arrays(np.float64, st.integers(0, 30), elements=NUMBERS),
    hnp.arrays(np.float64, st.tuples(st.integers(0, 30), st.integers(1, 4)), elements=NUMBERS),
    hnp.arrays(np.int32, st.integers(0, 5)),
    st.text(max_size=5),
)


@st.composite
def mat_files(draw: Any) -> dict[str, Any]:
    """The variables of an EMPS or MR-damper file, with up to two replaced or dropped."""
    n = draw(st.integers(2, 60))
    t = np.arange(n) * draw(st.sampled_from([1e-3, 5e-3, 0.0]))
    stroke = 0.1 * np.sin(np.arange(n) / 4.0)
    if draw(st.booleans()):
        variables: dict[str, Any] = {"t": t, "qm": stroke, "qg": stroke, "vir": np.cos(t)}
        if draw(st.booleans()):
            variables["gtau"] = np.array([[35.0]])
    else:
        variables = {"Tout": t, "x_F": np.c_[10 * stroke, stroke, 100 * stroke], "f": 1.5}
    for _ in range(draw(st.integers(0, 2))):
        key = draw(st.sampled_from([*sorted(variables), "kp", "pulses_N"]))
        if draw(st.booleans()):
            variables.pop(key, None)
        else:
            variables[key] = draw(MAT_VALUE)
    return variables


@FUZZ
@given(variables=mat_files(), compressed=st.booleans())
def test_mat_readers_return_a_recording_or_refuse(work, variables, compressed):
    path = work / "m.mat"
    scipy.io.savemat(path, variables, do_compression=compressed)
    if not variables:
        path.write_bytes(b"")
    read_or_refuse(path)


@FUZZ
@given(
    rows=st.lists(st.lists(NUMBERS, min_size=1, max_size=3), max_size=40),
    dx=st.sampled_from([0.25, 1e-9, 0.0]),
)
def test_profile_reader_returns_a_recording_or_refuses(work, rows, dx):
    path = work / "profile.txt"
    path.write_text("".join(" ".join(repr(v) for v in r) + "\n" for r in rows))
    try:
        rec = load_profile_txt(path, dx=dx, max_bytes=LIMIT)
    except ValidationError:
        return
    assert np.all(np.isfinite(rec.outputs["elevation"]))


# ------------------------------------------------------------------ vehicle files
def toml_key(k: str) -> str:
    return json.dumps(k)


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + "}"


def toml_document(doc: dict[str, Any]) -> str:
    """A TOML text of ``doc``: scalars first, then tables, then arrays of tables."""
    head = [
        f"{toml_key(k)} = {toml_value(v)}"
        for k, v in doc.items()
        if not isinstance(v, dict)
        and not (isinstance(v, list) and v and all(isinstance(t, dict) for t in v))
    ]
    body = []
    for k, v in doc.items():
        if isinstance(v, dict):
            body.append(f"[{toml_key(k)}]")
            body += [f"{toml_key(a)} = {toml_value(b)}" for a, b in v.items()]
        elif isinstance(v, list) and v and all(isinstance(t, dict) for t in v):
            for t in v:
                body.append(f"[[{toml_key(k)}]]")
                body += [f"{toml_key(a)} = {toml_value(b)}" for a, b in t.items()]
    return "\n".join(head + body) + "\n"


DESIGN_KEYS = ["strut_top_z", "strut_top_q", "static_toe", "arb_torsion", "lca_front_kx"]
CONSTANT_KEYS = ["wheel_centre", "spring_rate", "front_share", "wheel_radius", "spring_rate_x"]
EFFECT_KEYS = ["kind", "location", "name", "f_c", "sigma", "ratio", "x_ref", "fc"]
SCALARS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**6), 10**6),
    st.booleans(),
    st.sampled_from(["dahl_hysteresis", "coulomb_friction", "lower_arm", "strut", "x"]),
    st.lists(st.floats(-1e3, 1e3), max_size=4),
)
TABLE = lambda keys: st.dictionaries(st.sampled_from(keys), SCALARS, max_size=4)  # noqa: E731
DOCS = st.fixed_dictionaries(
    {},
    optional={
        "name": st.one_of(st.text(max_size=10), SCALARS),
        "description": st.text(max_size=10),
        "design": st.one_of(TABLE(DESIGN_KEYS), SCALARS),
        "design_right": TABLE(DESIGN_KEYS),
        "constants": TABLE(CONSTANT_KEYS),
        "effects": st.one_of(st.lists(TABLE(EFFECT_KEYS), max_size=2), SCALARS),
        "desing": TABLE(DESIGN_KEYS),
    },
)


def vehicle_or_refusal(path: Path) -> None:
    try:
        v = load_vehicle(path)
    except ValidationError:
        return
    assert isinstance(v, VehicleFile)
    assert np.all(np.isfinite(v.left)) and np.all(np.isfinite(v.right))


@FUZZ
@given(doc=DOCS)
def test_random_vehicle_documents_are_read_or_refused(work, doc):
    path = work / "vehicle.toml"
    path.write_text(toml_document(doc))
    vehicle_or_refusal(path)


REFERENCE_LINES = REFERENCE_FILE.read_text().splitlines()
TOKENS = st.sampled_from(
    ["inf", "-inf", "nan", "1e308", "-1e999", '"x"', "true", "[1, 2]", "0", "-5", "{a = 1}", "="]
)


@FUZZ
@given(
    edits=st.lists(
        st.tuples(
            st.integers(0, len(REFERENCE_LINES) - 1),
            st.sampled_from(["value", "delete", "duplicate", "rename", "insert"]),
            TOKENS,
            st.text(max_size=8),
        ),
        min_size=1,
        max_size=3,
    )
)
def test_perturbed_reference_vehicle_is_read_or_refused(work, edits):
    lines = list(REFERENCE_LINES)
    for i, how, token, text in edits:
        i = min(i, len(lines) - 1)
        line = lines[i]
        if how == "value" and "=" in line:
            lines[i] = line.split("=", 1)[0] + "= " + token
        elif how == "delete":
            del lines[i]
        elif how == "duplicate":
            lines.insert(i, line)
        elif how == "rename" and "=" in line:
            lines[i] = line[:1] + text.replace("\n", "") + line[1:]
        elif how == "insert":
            lines.insert(i, text)
        if not lines:
            lines = [""]
    path = work / "perturbed.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8", errors="surrogatepass")
    vehicle_or_refusal(path)


def test_unknown_names_get_did_you_mean(tmp_path):
    path = tmp_path / "v.toml"
    for text, expected in (
        ("[desing]\nstatic_toe = 0.0\n", r"unknown key 'desing' \(did you mean 'design'\?\)"),
        ("[design]\nstrut_top_q = 1.0\n", r"unknown parameter 'strut_top_q' \(did you mean"),
        ("[constants]\nspring_rat = 25.0\n", r"unknown constant 'spring_rat' \(did you mean"),
        (
            "[[effects]]\nkind = 'dahl_hysterisis'\nlocation = 'lower_arm'\n",
            r"`kind` must be one of .*'dahl_hysterisis'; did you mean 'dahl_hysteresis'",
        ),
        (
            "[[effects]]\nkind = 'dahl_hysteresis'\nlocation = 'lower_arms'\n",
            r"`location` must be one of .*'lower_arms'; did you mean",
        ),
        (
            "[[effects]]\nkind = 'dahl_hysteresis'\nlocation = 'lower_arm'\nfc = 80.0\n",
            r"unknown parameter 'fc' \(did you mean 'f_c'\?\)",
        ),
        ("[design]\nstatic_toe = nan\n", r"\[design\]: `static_toe` must be a finite number.*=nan"),
        ("[constants]\nwheel_centre = [0, -745, inf]\n", r"`wheel_centre` must be a finite number"),
    ):
        path.write_text(text)
        with pytest.raises(ValidationError, match=expected):
            load_vehicle(path)
