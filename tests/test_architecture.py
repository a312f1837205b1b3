"""The package's layering (docs/architecture.md): no import cycles and imports only downwards.

Every ``import`` of a dualpose module anywhere in a source file counts, at module level or inside a function.  The
rule is checked on the source text (AST), so it holds whatever is imported at run time.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "dualpose"

#: what each layer may import besides itself (docs/architecture.md, "The layers"); ``dualpose`` (the package root)
#: re-exports the algebra and counts as ``algebra``
BASE = {"_validation", "_native"}
#: compiled modules (no .py source): the native kernels sit at the bottom with the argument checks
EXTENSIONS = ("dualpose._native",)
ALLOWED: dict[str, set[str]] = {
    "_native": set(),
    "_validation": set(),
    "algebra": BASE,
    "registration": BASE | {"algebra"},
    "inertial": BASE | {"algebra"},
    "types": BASE | {"algebra"},
    "io": BASE | {"algebra", "types"},
    "sim": BASE | {"algebra", "types", "io"},
    "calibration": BASE | {"algebra", "types", "registration"},
    "estimation": BASE | {"algebra", "types", "registration", "calibration"},
    "evaluation": BASE | {"algebra", "types", "registration"},
    "pipelines": BASE | {"algebra", "types", "registration", "inertial", "io", "sim", "calibration", "estimation",
                         "evaluation"},
    "jobs": BASE | {"algebra", "types", "registration", "inertial", "io", "sim", "calibration", "estimation",
                    "evaluation", "pipelines"},
    "cli": BASE | {"algebra", "types", "registration", "inertial", "io", "sim", "calibration", "estimation",
                   "evaluation", "pipelines", "jobs"},
}
MAX_PUBLIC_MODULES = 12


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(SRC.rglob("*.py"))}


def _known(modules: dict[str, Path]) -> set[str]:
    return set(modules) | set(EXTENSIONS)


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The dualpose modules ``path`` imports (``from pkg import sub`` counts as importing ``pkg.sub``)."""
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == "dualpose")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "dualpose":
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                found.add(sub if sub in _known(modules) else target)
    return found - {me}


def _layer(module: str) -> str:
    parts = module.split(".")
    return "algebra" if len(parts) == 1 else parts[1]


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(path, modules) for name, path in modules.items()}


def test_every_layer_is_known(graph: dict[str, set[str]]) -> None:
    unknown = sorted({_layer(m) for m in graph} - set(ALLOWED))
    assert not unknown, f"add these layers to ALLOWED and docs/architecture.md: {unknown}"


def test_layers_import_only_downwards(graph: dict[str, set[str]]) -> None:
    bad = [
        f"{m} imports {d}"
        for m, deps in sorted(graph.items())
        for d in sorted(deps)
        if _layer(d) != _layer(m) and _layer(d) not in ALLOWED[_layer(m)]
    ]
    assert not bad, "imports against the layering:\n" + "\n".join(bad)


def test_no_import_cycles(graph: dict[str, set[str]]) -> None:
    """Tarjan's strongly connected components over the module graph; any component larger than one is a cycle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def test_nothing_but_cli_imports_cli(graph: dict[str, set[str]]) -> None:
    bad = [f"{m} imports {d}" for m, deps in graph.items() for d in deps if _layer(d) == "cli" and _layer(m) != "cli"]
    assert not bad, bad


def test_folders_hold_at_most_twelve_public_modules() -> None:
    folders = [SRC, *(p for p in SRC.rglob("*") if p.is_dir() and "__pycache__" not in p.parts)]
    assert any(f.parent != SRC for f in folders if f != SRC)  # nested packages (estimation/ahrs) are checked too
    for folder in folders:
        public = [p.name for p in folder.glob("*.py") if not p.name.startswith("_")]
        assert len(public) <= MAX_PUBLIC_MODULES, f"{folder.name}: {len(public)} public modules: {sorted(public)}"


def test_the_checker_sees_a_cycle_and_an_upward_import(tmp_path: Path) -> None:
    """The graph builder itself: a planted cycle and an upward import are found (guards against a blind test)."""
    pkg = tmp_path / "dualpose"
    (pkg / "algebra").mkdir(parents=True)
    (pkg / "cli").mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "algebra" / "__init__.py").write_text("")
    (pkg / "algebra" / "a.py").write_text("def f():\n    from dualpose.algebra import b\n")
    (pkg / "algebra" / "b.py").write_text("from dualpose.algebra import a\nimport dualpose.cli.main\n")
    (pkg / "cli" / "__init__.py").write_text("")
    (pkg / "cli" / "main.py").write_text("")
    global SRC
    saved, SRC = SRC, pkg
    try:
        mods = _modules()
        g = {name: _imports(path, mods) for name, path in mods.items()}
    finally:
        SRC = saved
    assert "dualpose.algebra.b" in g["dualpose.algebra.a"]
    assert "dualpose.algebra.a" in g["dualpose.algebra.b"]
    assert "dualpose.cli.main" in g["dualpose.algebra.b"]
