"""The registry of dataset kinds (:mod:`hertzsweep.core.kinds`) is the one table keyed by
kind: every function it names exists, and no other module-level mapping of the package is
keyed by kind names (read from the source, an ast walk)."""

from __future__ import annotations

import ast
import dataclasses

import pytest

from hertzsweep.core.kinds import KINDS, Ref

from .test_layers import MODULES, parse

REGISTRY = "hertzsweep.core.kinds"
# The scene's TOML tables: its sections [sweep], [branch], [random] share their names with
# kinds but are sections of a scene file (the schema and the config classes), not kinds.
SCENE_TABLES = {"hertzsweep.core.config": ("SCHEMA", "CLASSES")}
KIND_NAMES = set(KINDS)
MIN_KIND_KEYS = 2  # a mapping with two or more kind names as keys is a table of kinds


def refs() -> list[tuple[str, str, Ref]]:
    return [
        (kind.name, field.name, value)
        for kind in KINDS.values()
        for field in dataclasses.fields(kind)
        if isinstance(value := getattr(kind, field.name), Ref)
    ]


@pytest.mark.parametrize(("kind", "field", "ref"), refs(), ids=lambda v: str(v))
def test_every_function_the_registry_names_exists(kind, field, ref):
    assert callable(ref.resolve()), f"{kind}.{field}: {ref.module}:{ref.name}"


def assigned_names(node: ast.stmt) -> set[str]:
    targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
    return {t.id for t in targets if isinstance(t, ast.Name)}


def kind_keyed_mappings(
    tree: ast.Module, allowed: tuple[str, ...] = ()
) -> list[tuple[int, list[str]]]:
    """``(line, kind names)`` of each module-level dict literal (or ``dict(...)`` call)
    whose keys hold at least :data:`MIN_KIND_KEYS` kind names, but those assigned to
    ``allowed`` names."""
    found = []
    for node in tree.body:
        value = node.value if isinstance(node, ast.Assign | ast.AnnAssign) else None
        if value is not None and assigned_names(node) & set(allowed):
            continue
        if isinstance(value, ast.Dict):
            keys = [k.value for k in value.keys if isinstance(k, ast.Constant)]
        elif isinstance(value, ast.Call) and getattr(value.func, "id", None) == "dict":
            keys = [k.arg for k in value.keywords]
        else:
            continue
        named = sorted(KIND_NAMES.intersection(k for k in keys if isinstance(k, str)))
        if len(named) >= MIN_KIND_KEYS:
            found.append((node.lineno, named))
    return found


def test_the_check_sees_a_table_of_kinds():
    tree = ast.parse('RUNNERS = {"sweep": 1, "trace": 2}\nOTHER = {"rig": 1, "sweep": 2}\n')
    assert kind_keyed_mappings(tree) == [(1, ["sweep", "trace"])]
    assert kind_keyed_mappings(ast.parse("T = dict(random=1, branch=2)\n")) == [
        (1, ["branch", "random"])
    ]
    assert kind_keyed_mappings(ast.parse("T = dict(random=1, branch=2)\n"), ("T",)) == []


def test_no_other_mapping_is_keyed_by_kind_names():
    wrong = [
        f"{path.name}:{line}: {name} keys a mapping by {', '.join(named)}"
        for name, path in MODULES.items()
        if name != REGISTRY
        for line, named in kind_keyed_mappings(parse(path), SCENE_TABLES.get(name, ()))
    ]
    assert not wrong, "a table of kinds outside the registry:\n" + "\n".join(wrong)


def test_a_ref_passes_its_keywords():
    ref = Ref("builtins", "sorted", (("reverse", True),))
    assert ref([1, 3, 2]) == [3, 2, 1]
