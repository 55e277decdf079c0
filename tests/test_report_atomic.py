"""Report writers write atomically: a figure or a report file interrupted at the rename
(``os.replace`` raising, as a full disk or a kill would leave it) keeps its previous
content whole and leaves no temporary file; and no writer of the report, diagnosis or
tey2014 pipelines writes directly (``Path.write_text`` / ``Figure.savefig``), so every
one of them goes through :func:`suspenv.core.atomic.atomic_path`."""

from __future__ import annotations

import ast
import errno
import os
from pathlib import Path

import pytest

from suspenv.core.atomic import write_file
from suspenv.core.errors import InfrastructureError
from suspenv.models.planar.geometry import geometry_to_toml
from suspenv.problems.planar import PlanarLinkage
from suspenv.reports._mpl import pyplot, save_figure

ROOT = Path(__file__).resolve().parents[1] / "suspenv"
#: the writers that must not write directly (the figure helper itself is the exception)
WRITERS = [
    *sorted((ROOT / "reports" / "diagnosis").glob("*.py")),
    *(
        ROOT / "reports" / f"{n}.py"
        for n in (
            "tey2014",
            "minibus",
            "minibus_ride",
            "planar",
            "kc_identification",
            "suspension",
            "identify",
            "knc_rig",
        )
    ),
    *sorted((ROOT / "methods" / "tey2014").glob("*.py")),
    ROOT.parent / "tools" / "knc_signs.py",
]


def _interrupt(monkeypatch):
    def fail(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)


def test_an_interrupted_figure_keeps_the_old_one_whole(tmp_path, monkeypatch):
    plt = pyplot()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    path = save_figure(fig, tmp_path / "curves.png", dpi=50)
    old = path.read_bytes()
    assert old.startswith(b"\x89PNG")  # the suffix chose the format on the temporary name
    ax.plot([0, 1], [1, 0])
    _interrupt(monkeypatch)
    with pytest.raises(InfrastructureError, match="curves.png.*no space left"):
        save_figure(fig, path, dpi=80)
    plt.close(fig)
    assert path.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["curves.png"]


def test_an_interrupted_report_file_leaves_no_half_written_file(tmp_path, monkeypatch):
    text = geometry_to_toml(PlanarLinkage().baseline)  # what the planar report writes
    _interrupt(monkeypatch)
    with pytest.raises(InfrastructureError, match="planar_best.toml"):
        write_file(tmp_path / "planar_best.toml", text)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("path", WRITERS, ids=lambda p: str(p.relative_to(ROOT.parent)))
def test_no_writer_writes_directly(path):
    """A direct ``.write_text``/``.write_bytes``/``.savefig`` call or ``open(.., "w")``
    in a writer module would bypass the atomic rename."""
    bad = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        if isinstance(f, ast.Attribute) and f.attr in {"write_text", "write_bytes", "savefig"}:
            bad.append(f"{path.name}:{node.lineno} .{f.attr}(")
        if isinstance(f, ast.Name) and f.id == "open" and len(node.args) > 1:
            bad.append(f"{path.name}:{node.lineno} open(")
    assert not bad, "direct writes (use suspenv.core.atomic.write_file / save_figure):\n" + (
        "\n".join(bad)
    )
