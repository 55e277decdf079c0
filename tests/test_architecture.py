"""The import structure of suspenv: the layer table, no cycles between packages, imports
that resolve, and one package that imports matplotlib.

Every module under ``suspenv/`` is parsed (``ast``, nothing is imported) and every import
statement is read, at module level and inside functions and classes. Imports under
``if TYPE_CHECKING:`` are type hints, not dependencies, and are not counted. A module's
package is the first name below ``suspenv`` (``suspenv.rigs.ride`` -> ``rigs``); the
top-level modules ``registry`` and ``threads`` are packages of their own and
``suspenv/__init__.py`` is ``suspenv``.

The one sanctioned upward call is the registry's ``"module:attribute"`` entry points
(:mod:`suspenv.registry`): runs reach pipelines, and problems, runs and methods reach the
report writers of :mod:`suspenv.reports`, by name, without importing them.
:func:`test_registry_entry_points_exist` checks every such target.
"""

from __future__ import annotations

import ast
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "suspenv"

#: every library layer (what reports may read); cli sits above it
LIBRARY = frozenset(
    {
        "core",
        "threads",
        "registry",
        "measurements",
        "models",
        "rigs",
        "metrics",
        "problems",
        "strategies",
        "envs",
        "runs",
        "methods",
        "diagnosis",
        "analysis",
        "suite",
    }
)

#: package -> the packages it may import besides itself. Bottom up:
#: core <- measurements <- models <- rigs <- metrics <- problems <- envs / strategies /
#: runs / methods; methods (whole jobs: a study, an identification) may also run the
#: diagnosis on what they leave; measurements (recorded time histories and their formats) sit right
#: above core because models simulate recordings and rigs write them; diagnosis reads
#: models, rigs, metrics, measurements; reports read every library layer; cli on top
#: (the benchmark scripts live outside the package, in benchmarks/).
ALLOWED: dict[str, frozenset[str]] = {
    "core": frozenset(),
    "threads": frozenset(),
    # names problems, strategies, pipelines and reports by "module:attribute" only
    "registry": frozenset({"core"}),
    "measurements": frozenset({"core"}),
    # the hardware; a component model simulates a recording's channels
    "models": frozenset({"core", "measurements"}),
    "rigs": frozenset({"core", "measurements", "models"}),
    "metrics": frozenset({"core", "measurements", "models", "rigs"}),
    "problems": frozenset({"core", "measurements", "models", "rigs", "metrics", "registry"}),
    "strategies": frozenset({"core"}),
    "envs": frozenset({"core", "registry", "problems"}),
    "runs": frozenset({"core", "registry", "problems", "strategies"}),
    "methods": frozenset(
        {
            "core",
            "registry",
            "measurements",
            "models",
            "rigs",
            "metrics",
            "problems",
            "strategies",
            "runs",
            "diagnosis",
        }
    ),
    "diagnosis": frozenset({"core", "models", "rigs", "metrics", "measurements"}),
    # reads run directories: groups, fixed-budget and fixed-target views, indicators
    "analysis": frozenset({"core", "registry", "runs", "problems", "suite"}),
    # named instances of registered problems, run through the runs layer
    "suite": frozenset({"core", "registry", "runs"}),
    "reports": LIBRARY,
    "cli": LIBRARY | {"reports", "suspenv"},
    # ``import suspenv``: the BLAS thread limit, the public names, the env registration
    "suspenv": frozenset({"core", "registry", "threads", "envs"}),
}


@dataclass(frozen=True)
class Import:
    """One ``suspenv`` import: where it is (file:line) and what it names."""

    path: Path
    line: int
    source: str  # importing module, dotted
    target: str  # imported module, dotted (``from a.b import c``: ``a.b``)
    names: tuple[str, ...]  # ``from ... import`` names (empty for ``import a.b``)

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def package_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _runtime_nodes(node: ast.AST) -> Iterator[ast.AST]:
    """Every node below ``node`` except the bodies of ``if TYPE_CHECKING:`` blocks."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.If) and _is_type_checking(child.test):
            for other in child.orelse:
                yield other
                yield from _runtime_nodes(other)
            continue
        yield child
        yield from _runtime_nodes(child)


@cache
def parsed() -> tuple[dict[Path, ast.Module], dict[Path, str]]:
    """Every module's syntax tree, and the modules that do not parse (path -> error)."""
    trees, broken = {}, {}
    for path in sorted(PACKAGE.rglob("*.py")):
        try:
            trees[path] = ast.parse(path.read_text(), filename=str(path))
        except SyntaxError as exc:
            broken[path] = f"{exc.msg} (line {exc.lineno})"
    return trees, broken


def imports_of(path: Path, tree: ast.Module, top: str | None = "suspenv") -> list[Import]:
    """Runtime imports of one module (relative ones resolved); ``top`` filters by name."""
    source = module_name(path)
    package = source if path.name == "__init__.py" else source.rpartition(".")[0]
    out = []
    for node in _runtime_nodes(tree):
        if isinstance(node, ast.Import):
            out += [Import(path, node.lineno, source, a.name, ()) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = tuple(a.name for a in node.names)
            out.append(Import(path, node.lineno, source, target, names))
    if top is None:
        return out
    return [i for i in out if i.target == top or i.target.startswith(top + ".")]


@cache
def all_imports() -> tuple[Import, ...]:
    trees, _ = parsed()
    return tuple(i for path, tree in trees.items() for i in imports_of(path, tree))


def test_every_module_parses() -> None:
    _, broken = parsed()
    assert not broken, "modules that do not parse (their imports are not checked):\n" + "\n".join(
        f"  {p.relative_to(ROOT)}: {msg}" for p, msg in broken.items()
    )


def test_every_package_is_in_the_layer_table() -> None:
    packages = {package_of(module_name(p)) for p in parsed()[0]}
    assert packages <= set(ALLOWED), f"add {sorted(packages - set(ALLOWED))} to ALLOWED"


def test_imports_follow_the_layer_table() -> None:
    bad = []
    for imp in all_imports():
        src, dst = package_of(imp.source), package_of(imp.target)
        if src == dst or dst in ALLOWED.get(src, frozenset()):
            continue
        allowed = ", ".join(sorted(ALLOWED.get(src, ()))) or "nothing"
        bad.append(f"{imp.where}: {src} -> {dst} ({imp.target}); {src} may import {allowed}")
    assert not bad, f"{len(bad)} imports against the layer table:\n" + "\n".join(bad)


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one package (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                part.append(w)
                if w == v:
                    break
            if len(part) > 1:
                out.append(sorted(part))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle_between_packages() -> None:
    graph: dict[str, set[str]] = {}
    where: dict[tuple[str, str], str] = {}
    for imp in all_imports():
        src, dst = package_of(imp.source), package_of(imp.target)
        if src != dst:
            graph.setdefault(src, set()).add(dst)
            where.setdefault((src, dst), imp.where)
    cycles = _cycles(graph)
    lines = []
    for part in cycles:
        edges = [f"{a} -> {b} ({where[a, b]})" for a in part for b in sorted(graph[a]) if b in part]
        lines.append(" <-> ".join(part) + ": " + "; ".join(edges))
    assert not cycles, "import cycles between packages:\n" + "\n".join(lines)


def _module_file(dotted: str) -> Path | None:
    base = ROOT.joinpath(*dotted.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


@cache
def _defined_names(path: Path) -> frozenset[str] | None:
    """Names a module defines (assignments, defs, classes, imports); None if it does not
    parse (:func:`test_every_module_parses` reports it)."""
    tree = parsed()[0].get(path)
    if tree is None:
        return None
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
    return frozenset(names)


def test_internal_imports_resolve() -> None:
    # a module moved away leaves its importers failing only when that code path runs
    bad = []
    for imp in all_imports():
        module = _module_file(imp.target)
        if module is None:
            bad.append(f"{imp.where}: no module {imp.target}")
            continue
        for name in imp.names:
            if name == "*" or _module_file(f"{imp.target}.{name}") is not None:
                continue
            defined = _defined_names(module)
            if defined is not None and name not in defined:
                bad.append(f"{imp.where}: {imp.target} has no {name}")
    assert not bad, "imports that do not resolve:\n" + "\n".join(bad)


def test_only_reports_import_matplotlib() -> None:
    bad = []
    for path, tree in parsed()[0].items():
        if package_of(module_name(path)) == "reports":
            continue
        bad += [f"{i.where}: {i.target}" for i in imports_of(path, tree, top="matplotlib")]
    assert not bad, "matplotlib imported outside suspenv.reports:\n" + "\n".join(bad)


def _registry_targets() -> list[tuple[str, str]]:
    """(table, "module:attribute") of every string entry point in suspenv/registry.py."""
    tree = ast.parse((PACKAGE / "registry.py").read_text())
    out = []
    for node in tree.body:
        if not isinstance(node, ast.AnnAssign) or not isinstance(node.value, ast.Dict):
            continue
        if isinstance(node.target, ast.Name):
            out += [
                (node.target.id, v.value)
                for v in node.value.values
                if isinstance(v, ast.Constant) and isinstance(v.value, str)
            ]
    return out


@pytest.mark.parametrize(("table", "entry"), _registry_targets())
def test_registry_entry_points_exist(table: str, entry: str) -> None:
    module, _, attr = entry.partition(":")
    path = _module_file(module)
    assert path is not None, f"{table}: {entry}: no module {module}"
    defined = _defined_names(path)
    assert defined is None or attr in defined, f"{table}: {entry}: {module} has no {attr}"


def test_readme_layout_lists_every_package():
    # the README's layout section is the map a newcomer reads: every package of the tree
    # and nothing that is not there
    text = (ROOT / "README.md").read_text()
    block = text.split("## Layout", 1)[1].split("```", 2)[1]
    listed = {
        line.split()[0].removeprefix("suspenv/")
        for line in block.splitlines()
        if line.startswith("suspenv/")
    }
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert {name for name in listed if not name.endswith(".py")} == packages
    for name in listed:
        assert (PACKAGE / name).exists(), f"README layout lists suspenv/{name}, which is absent"


def _module_edges() -> dict[tuple[str, str], str]:
    """(importing module, imported module) -> where, for runtime imports between two
    suspenv modules (``from a import b`` names the module ``a.b`` where there is one)."""
    modules = {module_name(p) for p in parsed()[0]}
    edges: dict[tuple[str, str], str] = {}
    for imp in all_imports():
        targets = {f"{imp.target}.{n}" for n in imp.names} & modules
        if not targets or len(targets) < len(imp.names):
            targets.add(imp.target)
        for target in targets & modules - {imp.source}:
            edges.setdefault((imp.source, target), imp.where)
    return edges


#: two-file import circles still being removed; shrink this list, never grow it
CIRCLES_ALLOWED: frozenset[tuple[str, str]] = frozenset()


def _two_file_circles() -> dict[tuple[str, str], str]:
    edges = _module_edges()
    return {
        (a, b): f"{edges[a, b]} and {edges[b, a]}" for a, b in edges if a < b and (b, a) in edges
    }


def test_no_two_file_import_circle() -> None:
    # two modules importing each other (at module level or inside functions) are one
    # module in two files: merge them or move what both need below both
    circles = _two_file_circles()
    new = {pair: where for pair, where in circles.items() if pair not in CIRCLES_ALLOWED}
    assert not new, "two-file import circles:\n" + "\n".join(
        f"  {a} <-> {b} ({where})" for (a, b), where in sorted(new.items())
    )
    gone = sorted(CIRCLES_ALLOWED - set(circles))
    assert not gone, f"circles removed: delete them from CIRCLES_ALLOWED: {gone}"


#: the packages of suspenv.methods, one a method: the Tey et al. (2014) method and curve
#: identification
METHOD_PACKAGES = ("tey2014", "curves")


def _method_of(module: str) -> str | None:
    """The method package of a module of suspenv.methods (None outside them)."""
    parts = module.split(".")
    return parts[2] if parts[:2] == ["suspenv", "methods"] and len(parts) > 2 else None


def test_every_method_module_is_in_its_method_package() -> None:
    # suspenv.methods holds whole methods, one package each: a module beside them
    # belongs to no method
    loose = sorted(
        str(path.relative_to(ROOT))
        for path in parsed()[0]
        if _method_of(module_name(path)) not in (None, *METHOD_PACKAGES)
    )
    assert not loose, f"modules of suspenv.methods outside {METHOD_PACKAGES}: {loose}"


def test_method_packages_import_not_each_other() -> None:
    # each method owns its modules: one reaches another's pipeline by name (the registry)
    bad = [
        f"{i.where}: {i.target}"
        for i in all_imports()
        if _method_of(i.source) and _method_of(i.target) not in (None, _method_of(i.source))
    ]
    assert not bad, "method packages importing each other:\n" + "\n".join(bad)


#: the diagnosis families' packages: the shared modules ask a family through its steps
#: (suspenv.diagnosis.family), never by importing it; only the engine builds one by name
DIAGNOSIS_FAMILIES = ("component", "knc", "ride")
FAMILY_FACTORY = "suspenv.diagnosis.engine"


def _diagnosis_part(module: str) -> str | None:
    """The part of suspenv.diagnosis a module is in: its subpackage, "" for a module of
    the package itself (None outside suspenv.diagnosis)."""
    parts = module.split(".")
    if parts[:2] != ["suspenv", "diagnosis"]:
        return None
    return parts[2] if len(parts) > 3 else ""


def test_the_shared_diagnosis_modules_import_no_family() -> None:
    bad = sorted(
        f"{imp.where}: {imp.target}"
        for imp in all_imports()
        if _diagnosis_part(imp.source) in ("", "checks")
        and imp.source != FAMILY_FACTORY
        and _diagnosis_part(imp.target) in DIAGNOSIS_FAMILIES
    )
    assert not bad, "shared diagnosis modules importing a family:\n" + "\n".join(bad)


def test_metrics_import_no_rig() -> None:
    # metrics are pure functions of rig results: a rig's result types may be named for
    # type hints only (under ``if TYPE_CHECKING:``, which all_imports leaves out)
    bad = sorted(
        f"{imp.where}: {imp.target}"
        for imp in all_imports()
        if package_of(imp.source) == "metrics" and package_of(imp.target) == "rigs"
    )
    assert not bad, "metrics importing rigs:\n" + "\n".join(bad)


def test_metrics_import_no_private_rig_name() -> None:
    # not even for type hints: every import statement of every metrics module is read,
    # those under ``if TYPE_CHECKING:`` included
    bad = [
        f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}.{alias.name}"
        for path, tree in parsed()[0].items()
        if package_of(module_name(path)) == "metrics"
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("suspenv.rigs")
        for alias in node.names
        if alias.name.startswith("_")
    ]
    assert not bad, "metrics importing private names of the rigs:\n" + "\n".join(bad)


def test_the_package_imports_no_benchmark() -> None:
    # benchmarks/ is not installed: the package may name it only in registry strings
    bad = [
        f"{i.where}: {i.target}"
        for path, tree in parsed()[0].items()
        for i in imports_of(path, tree, top="benchmarks")
    ]
    assert not bad, "suspenv importing benchmarks/:\n" + "\n".join(bad)


def _ruff_lint() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]


def test_complexity_rule_is_on_everywhere() -> None:
    # every function of the tree stays at or below McCabe 15: no global or per-file
    # exemption of ruff's C901 rule
    lint = _ruff_lint()
    assert "C901" in lint["select"] and "C901" not in lint.get("ignore", [])
    assert lint["mccabe"]["max-complexity"] == 15
    ignores = lint.get("per-file-ignores", {})
    exempt = sorted(path for path, rules in ignores.items() if "C901" in rules)
    assert not exempt, f"C901 exempted in {exempt}: split their functions instead"


#: the generators of the benchmarks' truth vehicles and components
TRUTH_GENERATORS = (
    "suspenv.rigs.knc_truth",
    "suspenv.models.mcpherson.truth",
    "suspenv.models.components.truth",
)


def test_the_diagnosis_imports_no_truth_generator() -> None:
    # the diagnosis names missing physics from recordings alone: what a benchmark needs
    # of the truth stays in benchmarks/
    bad = [
        f"{i.where}: {i.target}"
        for i in all_imports()
        if package_of(i.source) == "diagnosis" and i.target.startswith(TRUTH_GENERATORS)
    ]
    assert not bad, "the diagnosis importing a truth generator:\n" + "\n".join(bad)
