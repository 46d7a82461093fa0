"""The add-on's layout: no import cycle between its modules, and a solver folder that shows
the pipeline (a few modules at the top, one sub-package per stage, each saying what it does
and listing its modules)."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "isoparam_addon"
SOLVER = PACKAGE / "solver"
MAX_TOP_LEVEL = 12  # solver/*.py, __init__.py included
MIN_STAGES = 3


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def module_level_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """The imports a module runs when it is imported: at its top level, or in a top-level
    ``if`` / ``try`` (never an ``if TYPE_CHECKING:`` block, nor inside a function or class)."""
    found: list[ast.Import | ast.ImportFrom] = []

    def walk(body):
        for node in body:
            if isinstance(node, ast.Import | ast.ImportFrom):
                found.append(node)
            elif isinstance(node, ast.If):
                if "TYPE_CHECKING" not in ast.unparse(node.test):
                    walk(node.body)
                    walk(node.orelse)
            elif isinstance(node, ast.Try):
                for block in (node.body, node.orelse, node.finalbody, *(h.body for h in node.handlers)):
                    walk(block)

    walk(tree.body)
    return found


def import_graph() -> dict[str, set[str]]:
    """Module -> the add-on's modules importing it runs (the packages on the way included:
    importing ``a.b.c`` runs ``a/b/__init__.py``), module-level imports only."""
    paths = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in paths}
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in module_level_imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                base = node.module or ""
                if node.level:
                    parts = package.split(".")
                    base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in paths else base for alias in node.names]
            for target in targets:
                while target and target not in paths:  # a name inside a module: the module
                    target = target.rpartition(".")[0]
                while target:
                    if target in paths and target != name and not name.startswith(target + "."):
                        graph[name].add(target)
                    target = target.rpartition(".")[0]
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), and modules
    that import themselves."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph[v]:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_cycle_finder_finds_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"e"}}
    assert sorted(cycles(graph)) == [["a", "b", "c"], ["e"]]


def test_the_import_graph_sees_relative_imports_and_the_packages_they_run():
    graph = import_graph()
    assert "isoparam_addon.solver.steps.embed" in graph["isoparam_addon.solver.pipeline"]
    assert "isoparam_addon.solver.steps" in graph["isoparam_addon.solver.pipeline"]
    assert "isoparam_addon.solver.mesh.halfedges" in graph["isoparam_addon.solver.steps.local"]
    assert "isoparam_addon.solver.pipeline" in graph["isoparam_addon.solver.charting.charts"]
    assert "isoparam_addon.solver" in graph["isoparam_addon.blender.unwrap"]


def test_no_import_cycle_between_the_addons_modules():
    assert cycles(import_graph()) == []


def test_the_solver_shows_its_stages():
    top = sorted(p.name for p in SOLVER.glob("*.py"))
    assert len(top) <= MAX_TOP_LEVEL, top
    stages = sorted(p.parent for p in SOLVER.glob("*/__init__.py"))
    assert len(stages) >= MIN_STAGES, stages
    assert not [p for p in SOLVER.iterdir() if p.is_dir() and p.name != "__pycache__" and p not in stages]
    for stage in stages:
        doc = ast.get_docstring(ast.parse((stage / "__init__.py").read_text()))
        assert doc, f"{stage.name}/__init__.py says nothing about its stage"
        modules = sorted(p.name for p in stage.glob("*.py") if p.name != "__init__.py")
        assert modules, stage
        assert [m for m in modules if f"``{m}``" not in doc] == [], f"{stage.name}/__init__.py lists every module"


MAX_FUNCTION = 80  # lines, def to last line
MAX_CLASS = 150


def test_functions_and_classes_stay_short():
    """Every function of the add-on and its scripts fits on a screen or two, every class
    holds one concept."""
    long = []
    for path in sorted([*PACKAGE.rglob("*.py"), *(ROOT / "scripts").rglob("*.py")]):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                limit = MAX_CLASS if isinstance(node, ast.ClassDef) else MAX_FUNCTION
                lines = node.end_lineno - node.lineno + 1
                if lines > limit:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    assert long == []
