"""The shape of the package, read from its source (an ast walk, nothing imported).

- Layers: core -> kernels -> drivers -> output -> io -> jobs -> api -> cli; a module
  imports only from its own layer or those before it (``hertzsweep.errors`` and the
  package root, which holds the version, from anywhere). Imports inside functions count,
  except the package root's: its module-level ``__getattr__`` hands out the public names
  of ``hertzsweep.api`` and ``hertzsweep.errors`` on first use (PEP 562), which is no
  dependency of the layers.
- The command line reaches the engine only through the API: a ``cli`` module imports
  ``hertzsweep.api`` (and its modules), ``hertzsweep.errors``, the package root and
  ``cli`` modules, nothing else of the package.
- No import cycles between modules.
- At most :data:`MAX_FMT_SKIP` ``# fmt: skip`` markers.
- At most :data:`MAX_LONG_FUNCTIONS` functions longer than :data:`LONG_FUNCTION` code lines.
- No numba-compiled function takes more than :data:`MAX_KERNEL_PARAMETERS` parameters.
"""

from __future__ import annotations

import ast
import tokenize
from collections.abc import Iterator
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "hertzsweep"
LAYERS = (
    "core",
    "kernels",
    "drivers",
    "output",
    "io",
    "jobs",
    "api",
    "cli",
)  # each uses those before
CLI_MAY_IMPORT = ("api", "cli")  # the layers a cli module may import (besides ANYWHERE)
ANYWHERE = {PACKAGE, f"{PACKAGE}.errors"}  # the package root (version) and the exceptions
ENTRY = f"{PACKAGE}.__main__"  # ``python -m hertzsweep``: above every layer
MAX_FMT_SKIP = 5  # hand-formatted lines: a long call wants keywords or a bundle instead
LONG_FUNCTION = 80  # [code lines] non-blank, non-comment, docstring excluded
MAX_LONG_FUNCTIONS = 0  # functions allowed beyond LONG_FUNCTION
MAX_KERNEL_PARAMETERS = 8  # beyond this a compiled function should take a parameter bundle
JIT_DECORATORS = {"njit", "jit"}  # numba.njit, numba.jit, and the names imported bare


# --------------------------------------------------------------------------- reading
def module_name(path: Path) -> str:
    """``src/hertzsweep/drivers/sweep.py`` -> ``hertzsweep.drivers.sweep``."""
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def source_files() -> dict[str, Path]:
    """Every module of the package by dotted name."""
    return {module_name(p): p for p in sorted((SRC / PACKAGE).rglob("*.py"))}


MODULES = source_files()


def parse(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def is_package(name: str) -> bool:
    return MODULES[name].name == "__init__.py"


def imported_modules(name: str, tree: ast.Module) -> Iterator[tuple[str, int]]:
    """``(module, line)`` for every import of a package module anywhere in the tree
    (module level or inside functions); ``from X import y`` names ``X.y`` when that is a
    module of the package, else ``X``."""
    package = name if is_package(name) else name.rpartition(".")[0]
    nodes = tree.body if name == PACKAGE else ast.walk(tree)  # the root: module level only
    for node in nodes:
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == PACKAGE:
                    yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != PACKAGE:
                continue
            for alias in node.names:
                child = f"{target}.{alias.name}"
                yield (child if child in MODULES else target), node.lineno


def layer(name: str) -> int | None:
    """Index of a module's layer in :data:`LAYERS`; None for the modules allowed
    everywhere; ``len(LAYERS)`` for the entry point."""
    if name in ANYWHERE:
        return None
    if name == ENTRY:
        return len(LAYERS)
    parts = name.split(".")
    assert len(parts) > 1 and parts[1] in LAYERS, f"{name} belongs to no layer"
    return LAYERS.index(parts[1])


IMPORTS = {name: sorted(set(imported_modules(name, parse(path)))) for name, path in MODULES.items()}


# --------------------------------------------------------------------------- layers
def test_every_module_has_a_layer():
    for name in MODULES:
        layer(name)  # asserts


def test_layers_import_only_downwards():
    wrong = []
    for name, imports in IMPORTS.items():
        own = layer(name)
        for target, line in imports:
            other = layer(target)
            if other is None:
                continue
            if own is None or other > own:
                wrong.append(f"{MODULES[name].relative_to(SRC)}:{line}: {name} imports {target}")
    assert not wrong, "layer rule broken:\n" + "\n".join(wrong)


def test_the_command_line_reaches_the_engine_only_through_the_api():
    wrong = []
    for name, imports in IMPORTS.items():
        if layer(name) != LAYERS.index("cli"):
            continue
        for target, line in imports:
            other = layer(target)
            if other is not None and LAYERS[other] not in CLI_MAY_IMPORT:
                wrong.append(f"{MODULES[name].relative_to(SRC)}:{line}: {name} imports {target}")
    assert not wrong, "the command line bypasses the API:\n" + "\n".join(wrong)


def test_the_api_check_sees_a_bypass():
    tree = ast.parse("def f():\n    from ..drivers.sweep import run_sweep\n")
    found = list(imported_modules(f"{PACKAGE}.cli.sweep", tree))
    assert found == [(f"{PACKAGE}.drivers.sweep", 2)]
    assert LAYERS[layer(found[0][0])] not in CLI_MAY_IMPORT


def test_the_layer_check_sees_lazy_imports():
    tree = ast.parse("def f():\n    from ..output.dataset import write_atomic\n")
    found = list(imported_modules(f"{PACKAGE}.drivers.study", tree))
    assert found == [(f"{PACKAGE}.output.dataset", 2)]
    assert layer(f"{PACKAGE}.output.dataset") > layer(f"{PACKAGE}.drivers.study")


# --------------------------------------------------------------------------- cycles
def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), and the
    modules that import themselves."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in sorted(graph.get(node, ())):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1 or node in graph.get(node, ()):
                cycles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return cycles


def test_find_cycles_finds_one():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert find_cycles(graph) == [["a", "b", "c"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    graph = {name: {t for t, _ in imports if t != name} for name, imports in IMPORTS.items()}
    cycles = find_cycles(graph)
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


# --------------------------------------------------------------------------- formatting
def comment_tokens(path: Path) -> Iterator[tokenize.TokenInfo]:
    with open(path, encoding="utf-8") as handle:
        for token in tokenize.generate_tokens(handle.readline):
            if token.type == tokenize.COMMENT:
                yield token


def test_few_fmt_skip_markers():
    found = [
        f"{path.relative_to(SRC)}:{token.start[0]}"
        for path in MODULES.values()
        for token in comment_tokens(path)
        if token.string.lstrip("#").strip().startswith("fmt: skip")
    ]
    assert len(found) <= MAX_FMT_SKIP, f"{len(found)} '# fmt: skip' markers: {', '.join(found)}"


# --------------------------------------------------------------------------- function size
def docstring_lines(node: ast.AST) -> set[int]:
    body = getattr(node, "body", [])
    first = body[0] if body else None
    if (
        isinstance(first, ast.Expr)
        and isinstance(first.value, ast.Constant)
        and isinstance(first.value.value, str)
    ):
        return set(range(first.lineno, first.end_lineno + 1))
    return set()


def code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef, lines: list[str]) -> int:
    """Non-blank, non-comment lines from ``def`` to the end, the docstrings of the
    function and of the functions and classes inside it left out."""
    skipped: set[int] = set()
    for inner in ast.walk(node):
        if isinstance(inner, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            skipped |= docstring_lines(inner)
    count = 0
    for number in range(node.lineno, node.end_lineno + 1):
        text = lines[number - 1].strip()
        if text and not text.startswith("#") and number not in skipped:
            count += 1
    return count


def functions(tree: ast.Module) -> Iterator[ast.FunctionDef | ast.AsyncFunctionDef]:
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield node


def test_code_lines_leave_out_docstrings_comments_and_blanks():
    text = 'def f(x):\n    """Doc.\n\n    More.\n    """\n    # note\n\n    return x\n'
    node = next(functions(ast.parse(text)))
    assert code_lines(node, text.splitlines()) == 2


def test_few_long_functions():
    long = []
    for path in MODULES.values():
        lines = path.read_text().splitlines()
        for node in functions(parse(path)):
            count = code_lines(node, lines)
            if count > LONG_FUNCTION:
                long.append(f"{path.relative_to(SRC)}:{node.lineno} {node.name} ({count} lines)")
    assert len(long) <= MAX_LONG_FUNCTIONS, (
        f"{len(long)} functions over {LONG_FUNCTION} code lines: " + ", ".join(long)
    )


# --------------------------------------------------------------------------- kernels
def decorator_name(node: ast.expr) -> str:
    """``njit`` for ``@njit``, ``@njit(cache=True)``, ``@numba.njit(...)``, ``@nb.jit``."""
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Name):
        return node.id
    return ""


def parameter_count(node: ast.FunctionDef) -> int:
    arguments = node.args
    count = len(arguments.posonlyargs) + len(arguments.args) + len(arguments.kwonlyargs)
    return count + (arguments.vararg is not None) + (arguments.kwarg is not None)


def compiled_functions(tree: ast.Module) -> Iterator[ast.FunctionDef]:
    for node in functions(tree):
        if any(decorator_name(d) in JIT_DECORATORS for d in node.decorator_list):
            yield node


def test_compiled_functions_found():
    text = "import numba\n@numba.njit(cache=True)\ndef f(a, b, *c, d=1):\n    return a\n"
    (node,) = compiled_functions(ast.parse(text))
    assert parameter_count(node) == 4


@pytest.mark.parametrize("name", sorted(MODULES))
def test_compiled_functions_take_few_parameters(name):
    wide = [
        f"{node.name} ({parameter_count(node)} parameters)"
        for node in compiled_functions(parse(MODULES[name]))
        if parameter_count(node) > MAX_KERNEL_PARAMETERS
    ]
    assert not wide, f"{MODULES[name].relative_to(SRC)}: " + ", ".join(wide)
