"""The package's structure, read from the source with ``ast``: layers that only point down,
no import cycle, no private name crossing a module, no sibling import hidden in a function,
modules and functions a reader can hold at once.

Layers, lowest first (a module may import its own layer and the layers below)::

    core    exceptions, mujoco_warnings, spatial, frames, inputs, callbacks, progress, tasks/, qp/,
            cascade, solve/, balance/, dynamics
    robot   robot/    (model loading, limbs, keyframes, ground and soles, descriptions,
                       sensors, cameras, couplings, MJCF world building)
    ik      ik/       (irteus entry points; a robot assembled with the IK)
    sim     sim/      (scene, static check, hold, motion playback)
    top     walking/ < record/ < scenario/ < sweep/ < scenarios < cli

Inside ``top`` the order is a chain too: walking reports through callbacks and knows no
recorder; the recorder logs what walking, the simulation and the solve produce.
``pik_mj/__init__.py`` (the facade) may import anything; nothing inside the package imports
the facade except the scenario scripts, which are written as a user writes.
"""

from __future__ import annotations

import ast
import textwrap
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "core",
        (
            "exceptions",
            "mujoco_warnings",
            "spatial",
            "frames",
            "inputs",
            "outputs",
            "checks",
            "callbacks",
            "progress",
            "tasks",
            "qp",
            "cascade",
            "solve",
            "balance",
            "dynamics",
        ),
    ),
    ("robot", ("robot",)),
    ("ik", ("ik",)),
    ("sim", ("sim",)),
    ("walking", ("walking",)),
    ("record", ("record",)),
    ("scenario", ("scenario",)),
    ("sweep", ("sweep",)),
    ("scenarios", ("scenarios",)),
    ("cli", ("cli",)),
)
"""Layer of each first-level name under ``pik_mj``, lowest first."""

FACADE = "pik_mj"
DATA_PACKAGES = ("pik_mj.mjcf",)
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 100
PUBLIC_UNDERSCORE = frozenset({"_replace", "_asdict", "_fields", "_make", "_field_defaults"})
"""Underscore names that are public API by convention (``collections.namedtuple``)."""


@dataclass
class Module:
    name: str
    path: Path
    tree: ast.Module
    lines: int
    is_package: bool


@dataclass
class Import:
    importer: str
    target: str
    line: int
    in_function: bool


@dataclass
class Findings:
    cycles: list[list[str]] = field(default_factory=list)
    upward: list[str] = field(default_factory=list)
    facade: list[str] = field(default_factory=list)
    private: list[str] = field(default_factory=list)
    function_imports: list[str] = field(default_factory=list)
    long_modules: list[str] = field(default_factory=list)
    long_functions: list[str] = field(default_factory=list)


def read_package(package_dir: Path, extra: dict[str, Path] | None = None) -> dict[str, Module]:
    """Every module under ``package_dir`` (a package named after the folder), by dotted
    name, plus ``extra`` folders installed as subpackages (``scenarios/`` as
    ``pik_mj.scenarios``)."""
    roots = {package_dir.name: package_dir, **(extra or {})}
    modules = {}
    for prefix, folder in roots.items():
        for path in sorted(folder.rglob("*.py")):
            parts = [*prefix.split("."), *path.relative_to(folder).with_suffix("").parts]
            is_package = parts[-1] == "__init__"
            if is_package:
                parts = parts[:-1]
            source = path.read_text(encoding="utf-8")
            name = ".".join(parts)
            modules[name] = Module(
                name, path, ast.parse(source), len(source.splitlines()), is_package
            )
    return modules


def _absolute(module: Module, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = module.name.split(".")
    if not module.is_package:
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, *([node.module] if node.module else [])])


def _functions_enclosing(tree: ast.AST) -> dict[ast.AST, bool]:
    """For every node: whether it sits inside a function body."""
    inside: dict[ast.AST, bool] = {}

    def visit(node: ast.AST, in_function: bool) -> None:
        inside[node] = in_function
        nested = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        for child in ast.iter_child_nodes(node):
            visit(child, nested)

    visit(tree, False)
    return inside


def imports_of(module: Module, modules: dict[str, Module], root: str) -> list[Import]:
    """The package modules ``module`` imports (a ``from P import name`` of a submodule
    ``P.name`` counts as that submodule)."""
    inside = _functions_enclosing(module.tree)
    found = []
    for node in ast.walk(module.tree):
        targets: list[str] = []
        if isinstance(node, ast.ImportFrom):
            base = _absolute(module, node)
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                targets.append(sub if sub in modules else base)
        elif isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        for target in targets:
            if target == root or target.startswith(root + "."):
                while target not in modules and "." in target:
                    target = target.rsplit(".", 1)[0]
                found.append(Import(module.name, target, node.lineno, inside[node]))
    return list({(i.target, i.line): i for i in found}.values())


def layer_of(name: str, root: str) -> int | None:
    """Index in :data:`LAYERS` of a module, None for the facade and data packages."""
    if name == root or name in DATA_PACKAGES:
        return None
    first = name.split(".")[1]
    for i, (_, members) in enumerate(LAYERS):
        if first in members:
            return i
    raise AssertionError(f"module {name} is in no layer: add it to LAYERS")


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                connect(w)
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
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            connect(v)
    return components


def _defined_privates(tree: ast.Module) -> set[str]:
    """Underscore names a module defines: functions, classes, attributes it assigns
    (``self._x = ...``, class-level ``_x = ...``, dataclass fields) and names it binds."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
    return {n for n in names if n.startswith("_") and not n.startswith("__")}


def private_crossings(module: Module) -> list[str]:
    """Underscore names that ``module`` takes from elsewhere: imported by name, or read
    as an attribute of an object other than ``self``/``cls`` when the module does not
    define that name itself."""
    own = _defined_privates(module.tree)
    found = []
    for node in ast.walk(module.tree):
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    found.append(f"{module.name}:{node.lineno} imports {alias.name}")
        elif isinstance(node, ast.Attribute):
            name = node.attr
            if not name.startswith("_") or name.startswith("__") or name in PUBLIC_UNDERSCORE:
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue
            if name in own:
                continue
            found.append(f"{module.name}:{node.lineno} reads {ast.unparse(node)}")
    return found


def _body_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines of a function from its ``def`` to its end, its docstring not counted."""
    lines = node.end_lineno - node.lineno + 1
    first = node.body[0]
    if (
        isinstance(first, ast.Expr)
        and isinstance(first.value, ast.Constant)
        and isinstance(first.value.value, str)
    ):
        lines -= first.end_lineno - first.lineno + 1
    return lines


def survey(modules: dict[str, Module], root: str) -> Findings:
    """Everything this test forbids, found in ``modules`` (a package named ``root``)."""
    out = Findings()
    edges: dict[str, set[str]] = {name: set() for name in modules}
    for module in modules.values():
        mine = layer_of(module.name, root)
        for imp in imports_of(module, modules, root):
            if imp.target == module.name:
                continue
            where = f"{imp.importer}:{imp.line} imports {imp.target}"
            theirs = layer_of(imp.target, root)
            if imp.target == root:
                if mine is not None and LAYERS[mine][0] != "scenarios":
                    out.facade.append(where)
                continue
            edges[module.name].add(imp.target)
            if mine is not None and theirs is not None and theirs > mine:
                out.upward.append(f"{where} ({LAYERS[mine][0]} -> {LAYERS[theirs][0]})")
            if imp.in_function:
                out.function_imports.append(where)
        out.private.extend(private_crossings(module))
        if module.lines > MAX_MODULE_LINES:
            out.long_modules.append(f"{module.name}: {module.lines} lines")
        for node in ast.walk(module.tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = _body_lines(node)
                if n > MAX_FUNCTION_LINES:
                    out.long_functions.append(f"{module.name}.{node.name}: {n} lines")
    out.cycles = _cycles(edges)
    return out


@pytest.fixture(scope="module")
def findings() -> Findings:
    modules = read_package(
        ROOT / "pik_mj", {"pik_mj.scenarios": ROOT / "scenarios", "pik_mj.mjcf": ROOT / "models"}
    )
    return survey(modules, "pik_mj")


def _none(what: str, items: Iterable[object]) -> None:
    """Fail, listing ``items``, unless there are none."""
    items = list(items)
    if items:
        pytest.fail(f"{len(items)} {what}:\n  " + "\n  ".join(str(x) for x in items), False)


def test_no_import_cycle(findings: Findings) -> None:
    _none("import cycles", findings.cycles)


def test_layers_only_point_down(findings: Findings) -> None:
    _none("upward imports", findings.upward)


def test_nothing_inside_imports_the_facade(findings: Findings) -> None:
    _none("imports of the pik_mj facade", findings.facade)


def test_no_private_name_crosses_a_module(findings: Findings) -> None:
    _none("private names used outside their module", findings.private)


def test_no_sibling_import_inside_a_function(findings: Findings) -> None:
    _none("package imports inside functions", findings.function_imports)


def test_modules_fit_on_a_few_screens(findings: Findings) -> None:
    _none(f"modules over {MAX_MODULE_LINES} lines", findings.long_modules)


def test_functions_fit_on_a_screen(findings: Findings) -> None:
    _none(f"functions over {MAX_FUNCTION_LINES} lines", findings.long_functions)


# The checker itself, on a small package written here: it must see what it forbids.


def _write(root: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))


CLEAN = {
    "pik_mj/__init__.py": "from pik_mj.sim.scene import Scene\n",
    "pik_mj/exceptions.py": "class PikError(Exception): ...\n",
    "pik_mj/robot/__init__.py": "",
    "pik_mj/robot/robot.py": "from pik_mj.exceptions import PikError\n",
    "pik_mj/sim/__init__.py": "",
    "pik_mj/sim/scene.py": """
        from pik_mj.robot.robot import PikError

        class Scene:
            def __init__(self):
                self._contacts = []

            def contacts(self):
                return list(self._contacts)
        """,
    "pik_mj/sim/hold.py": """
        from pik_mj.sim.scene import Scene

        def hold(scene: Scene):
            return scene.contacts()
        """,
}


def _survey(tmp_path: Path, changes: dict[str, str]) -> Findings:
    _write(tmp_path, {**CLEAN, **changes})
    return survey(read_package(tmp_path / "pik_mj"), "pik_mj")


def test_the_checker_passes_a_clean_package(tmp_path: Path) -> None:
    found = _survey(tmp_path, {})
    assert found == Findings()


def test_the_checker_sees_an_upward_import_and_its_cycle(tmp_path: Path) -> None:
    found = _survey(tmp_path, {"pik_mj/robot/robot.py": "from pik_mj.sim.scene import Scene\n"})
    assert found.upward == ["pik_mj.robot.robot:1 imports pik_mj.sim.scene (robot -> sim)"]
    assert found.cycles == [["pik_mj.robot.robot", "pik_mj.sim.scene"]]


def test_the_checker_sees_a_reach_in(tmp_path: Path) -> None:
    hold = """
        from pik_mj.sim.scene import Scene

        def hold(scene: Scene):
            return scene._contacts
        """
    found = _survey(tmp_path, {"pik_mj/sim/hold.py": hold})
    assert found.private == ["pik_mj.sim.hold:5 reads scene._contacts"]


def test_the_checker_sees_a_hidden_import_and_a_long_function(tmp_path: Path) -> None:
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    hold = f'''
def hold(scene):
    """Docstring lines are not counted."""
    from pik_mj.sim.scene import Scene
{body}
    return Scene
'''
    found = _survey(tmp_path, {"pik_mj/sim/hold.py": hold})
    assert found.function_imports == ["pik_mj.sim.hold:4 imports pik_mj.sim.scene"]
    assert found.long_functions == [f"pik_mj.sim.hold.hold: {MAX_FUNCTION_LINES + 3} lines"]


def test_the_checker_sees_the_facade_imported_from_inside(tmp_path: Path) -> None:
    found = _survey(tmp_path, {"pik_mj/sim/hold.py": "from pik_mj import Scene\n"})
    assert found.facade == ["pik_mj.sim.hold:1 imports pik_mj"]
