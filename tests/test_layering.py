"""Package layering (STYLE.md): no import cycle among modules, no module imports a higher layer.

Every module under src/ibvs_youla is parsed with ``ast``; every ``import`` counts, including the
lazy ones inside functions and those under ``if TYPE_CHECKING:``. An import of a higher layer is
allowed only under ``if TYPE_CHECKING:`` (annotations), and even then it must not close a cycle.
The package ``__init__.py`` (lazy re-exports of the public API) is exempt; a name imported
through it (``from ibvs_youla import Arm``) counts as an import of the module that defines it.
"""

from __future__ import annotations

import ast
from collections import deque
from dataclasses import dataclass
from pathlib import Path

ROOT = "ibvs_youla"
SRC = Path(__file__).resolve().parents[1] / "src" / ROOT

# Low -> high. A module may import its own layer and the layers before it.
LAYERS: tuple[tuple[str, ...], ...] = (
    (
        "_validation",
        "_memory",
        "_jit",
        "_linalg",
        "_geometry",
        "_reproducible",
        "exceptions",
        "files",
        "catalog",
    ),
    ("model",),
    ("estimation",),
    ("control",),
    ("controllers",),  # controller roles of the servo loop: use control/estimation/model, used by simulation
    ("scenarios",),
    ("simulation",),
    ("analysis",),
    ("campaign",),  # campaigns: cases, specs, runs and their rows (use simulation and analysis)
    ("viz", "config", "cli"),
)


@dataclass(frozen=True)
class Import:
    importer: str
    imported: str
    line: int
    type_checking: bool  # under ``if TYPE_CHECKING:``

    def __str__(self) -> str:
        where = " (TYPE_CHECKING)" if self.type_checking else ""
        return f"{self.importer} -> {self.imported} (line {self.line}){where}"


def _module_name(path: Path) -> str:
    parts = [ROOT, *path.relative_to(SRC).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES: dict[str, Path] = {_module_name(p): p for p in sorted(SRC.rglob("*.py"))}


def _root_lazy_names() -> dict[str, str]:
    """The root package's ``_LAZY`` map (public name -> defining module), read from its source."""
    tree = ast.parse(MODULES[ROOT].read_text(encoding="utf-8"))
    for node in tree.body:
        targets = [node.target] if isinstance(node, ast.AnnAssign) else getattr(node, "targets", [])
        if any(isinstance(t, ast.Name) and t.id == "_LAZY" for t in targets):
            return {name: ROOT + relative for name, relative in ast.literal_eval(node.value).items()}
    raise AssertionError("ibvs_youla/__init__.py has no _LAZY map")


LAZY = _root_lazy_names()


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _known(name: str) -> str:
    """The longest prefix of a dotted name that is a module of the package (the root if none)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or ROOT


class _Collector(ast.NodeVisitor):
    def __init__(self, module: str) -> None:
        self.module = module
        self.package = module if MODULES[module].name == "__init__.py" else module.rpartition(".")[0]
        self.type_checking = False
        self.found: list[Import] = []

    def _add(self, target: str, node: ast.stmt) -> None:
        if target != ROOT and target != self.module:
            self.found.append(Import(self.module, target, node.lineno, self.type_checking))

    def visit_If(self, node: ast.If) -> None:
        if _is_type_checking(node.test):
            outer, self.type_checking = self.type_checking, True
            for child in node.body:
                self.visit(child)
            self.type_checking = outer
            for child in node.orelse:
                self.visit(child)
        else:
            self.generic_visit(node)

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            if alias.name == ROOT or alias.name.startswith(ROOT + "."):
                self._add(_known(alias.name), node)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        if node.level:
            base_parts = self.package.split(".")
            base = ".".join(base_parts[: len(base_parts) - node.level + 1])
            base = f"{base}.{node.module}" if node.module else base
        else:
            base = node.module or ""
        if base != ROOT and not base.startswith(ROOT + "."):
            return
        for alias in node.names:
            submodule = f"{base}.{alias.name}"
            if submodule in MODULES:
                self._add(submodule, node)
            elif base == ROOT:
                self._add(LAZY.get(alias.name, ROOT), node)
            else:
                self._add(_known(base), node)


def _collect() -> list[Import]:
    imports = []
    for module, path in MODULES.items():
        if module == ROOT:
            continue  # the lazy re-exports of the public API
        collector = _Collector(module)
        collector.visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)))
        imports += collector.found
    return imports


IMPORTS = _collect()


def layer_of(module: str) -> int:
    top = module.split(".")[1]
    for index, names in enumerate(LAYERS):
        if top in names:
            return index
    raise AssertionError(f"{module}: {top!r} is in no layer of LAYERS; add it where it belongs")


def _upward(imp: Import) -> bool:
    return not imp.type_checking and layer_of(imp.imported) > layer_of(imp.importer)


def _graph(imports: list[Import]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for imp in imports:
        graph[imp.importer].add(imp.imported)
    return graph


def _components(graph: dict[str, set[str]]) -> list[set[str]]:
    """Strongly connected components with more than one module (Tarjan): the import cycles."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    components: list[set[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = {stack.pop()}
            while v not in component:
                component.add(stack.pop())
            if len(component) > 1:
                components.append(component)

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return components


def _shortest_cycle(graph: dict[str, set[str]], component: set[str]) -> list[str]:
    """The shortest closed path from the component's first module back to it (breadth first)."""
    start = min(component)
    parent: dict[str, str] = {}
    queue = deque([start])
    while queue:
        v = queue.popleft()
        for w in sorted(graph[v] & component):
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(parent[path[-1]])
                return [*reversed(path), start]
            if w not in parent:
                parent[w] = v
                queue.append(w)
    raise AssertionError(f"{sorted(component)} is not strongly connected")


def test_the_parser_sees_lazy_and_type_checking_imports():
    """Guards the collector itself: known imports of each kind are found."""
    edges = {(i.importer, i.imported, i.type_checking) for i in IMPORTS}
    assert ("ibvs_youla.model.arm", "ibvs_youla.model.ik", False) in edges  # module level
    assert ("ibvs_youla.analysis.convergence", "ibvs_youla.simulation.results", True) in edges
    assert ("ibvs_youla.analysis.design_report", "ibvs_youla.model.arm", False) in edges  # in a function
    assert ("ibvs_youla.analysis.design_report", "ibvs_youla.scenarios", False) in edges  # from .. import x
    assert len(MODULES) > 40


def test_every_module_has_a_layer():
    layered = {name for names in LAYERS for name in names}
    assert sorted({m.split(".")[1] for m in MODULES if m != ROOT} - layered) == []


def test_no_import_cycle():
    graph = _graph(IMPORTS)
    cycles = [" -> ".join(_shortest_cycle(graph, c)) for c in _components(graph)]
    assert cycles == [], "import cycles:\n" + "\n".join(cycles)


def test_no_module_imports_a_higher_layer():
    upward = [str(i) for i in IMPORTS if _upward(i)]
    assert upward == [], "imports of a higher layer:\n" + "\n".join(upward)
