"""The generated reference (docs/hooks/reference.py) has an entry for everything the code
defines: every command and option, every configuration key, every variable and global
attribute, every exception and public name. Checked on the generators' Markdown, without
running mkdocs."""

from __future__ import annotations

import importlib
import importlib.util
import re
from types import SimpleNamespace

import click
import pytest

import hertzsweep
from hertzsweep import errors
from hertzsweep.cli.group import COMMANDS, cli
from hertzsweep.core.config import DESCRIPTIONS, REQUIRED_RIG_KEYS, SCHEMA
from hertzsweep.output.dataset import attributes

from .conftest import ROOT

HOOK = ROOT / "docs" / "hooks" / "reference.py"
PAGES = {  # page -> the marker it holds
    "cli.md": "cli",
    "config.md": "config",
    "datasets.md": "datasets",
    "errors.md": "errors",
    "api.md": "api",
}


@pytest.fixture(scope="module")
def hook():
    spec = importlib.util.spec_from_file_location("docs_reference_hook", HOOK)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def sections(markdown: str) -> dict[str, str]:
    """The ``## heading { #id }`` sections of a generated page, by id."""
    parts = re.split(r"^## .*\{ #([\w-]+) \}$", markdown, flags=re.MULTILINE)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


def rows(markdown: str) -> list[list[str]]:
    """The cells of every table row (header rows included), split at the ``|`` outside
    code spans that no backslash escapes."""
    out = []
    for line in markdown.splitlines():
        if not line.startswith("| "):
            continue
        cells, cell, in_code, previous = [], "", False, ""
        for char in line[1:]:
            if char == "`":
                in_code = not in_code
            if char == "|" and not in_code and previous != "\\":
                cells.append(cell.strip())
                cell = ""
            else:
                cell += char
            previous = char
        out.append(cells)
    return out


def first_cells(markdown: str) -> set[str]:
    return {row[0] for row in rows(markdown)}


# --------------------------------------------------------------------------- markers
def test_each_reference_page_holds_its_marker(hook):
    for name, marker in PAGES.items():
        text = (ROOT / "docs" / "reference" / name).read_text(encoding="utf-8")
        assert hook.MARKER.findall(text) == [marker], name
    assert set(PAGES.values()) == set(hook.GENERATORS)


def test_the_hook_replaces_markers_and_refuses_unknown_ones(hook):
    mkdocs = pytest.importorskip("mkdocs.exceptions")
    page = SimpleNamespace(file=SimpleNamespace(src_uri="reference/x.md"))
    out = hook.on_page_markdown(
        "# Errors\n\n<!-- generated: errors -->\n", page=page, config={}, files=[]
    )
    assert "<!-- generated" not in out and "| `ConfigError` |" in out
    with pytest.raises(mkdocs.PluginError, match="reference/x.md: unknown marker"):
        hook.on_page_markdown("<!-- generated: nothing -->\n", page=page, config={}, files=[])


def test_rendered_sphinx_roles_become_code(hook):
    html = "see :func:`<code>~hertzsweep.api.sweep</code>` and :class:<code>hs.Scene</code>"
    assert hook.on_page_content(html.replace("`", "")) == (
        "see <code>sweep</code> and <code>hs.Scene</code>"
    )


# --------------------------------------------------------------------------- cli
def test_every_command_and_option_has_its_entry(hook):
    by_id = sections(hook.cli_reference())
    root = click.Context(cli, info_name="hertzsweep", **cli.context_settings)
    assert set(by_id) == {"hertzsweep", *COMMANDS}
    for name in COMMANDS:
        command = cli.get_command(root, name)
        ctx = click.Context(command, info_name=name, parent=root)
        section = by_id[name]
        assert f"Usage: hertzsweep {name} [OPTIONS]" in section
        names = first_cells(section)
        for param in command.get_params(ctx):
            if isinstance(param, click.Option):
                cell = ", ".join(f"`{opt}`" for opt in [*param.opts, *param.secondary_opts])
            else:
                cell = f"`{param.make_metavar(ctx)}`"
            assert cell in names, (name, param.name)
    assert all(f"[`hertzsweep {name}`](#{name})" in by_id["hertzsweep"] for name in COMMANDS)


def test_option_defaults_and_values_come_from_click(hook):
    trace = sections(hook.cli_reference())["trace"]
    by_option = {row[0]: row for row in rows(trace)}
    assert by_option["`--periods`"][1:3] == ["integer", "`8`"]
    assert by_option["`--branch`"][1:3] == ["one of `upper`, `lower`", "`upper`"]
    assert by_option["`-o`, `--output`"][2] == "required"
    assert by_option["`-q`, `--quiet`"][1:3] == ["flag", "off"]


# --------------------------------------------------------------------------- config
def test_every_schema_key_has_a_description():
    keys = {f"{table}.{key}" for table, checks in SCHEMA.items() for key in checks}
    assert set(DESCRIPTIONS) == keys
    for key, text in DESCRIPTIONS.items():
        assert text.strip() and "\n" not in text, key


def test_every_schema_key_has_its_row(hook):
    by_id = sections(hook.config_reference())
    assert set(by_id) == set(SCHEMA)
    for table, checks in SCHEMA.items():
        table_rows = {row[0]: row for row in rows(by_id[table])}
        for key in checks:
            row = table_rows[f"`{key}`"]
            assert all(cell != hook.NONE for cell in row), (table, key, row)
            if table == "rig" and key in REQUIRED_RIG_KEYS:
                assert row[2] == "required"
    assert rows(by_id["damping"])[2][1:3] == ['one of `"viscous"`, `"contact"`', '`"viscous"`']
    assert rows(by_id["sweep"])[4][2] == '`["up", "down"]`'


def test_a_validator_without_a_description_fails_the_build(hook):
    from hertzsweep.core import config

    with pytest.raises(LookupError, match="CHECKS"):
        hook._accepts(lambda s, k, v: v, config)


# --------------------------------------------------------------------------- datasets
def test_every_variable_and_coordinate_has_its_row(hook):
    markdown = hook.datasets_reference()
    names = first_cells(markdown)
    for name in attributes():
        assert f"`{name}`" in names, name
    groups = hook.attribute_groups(
        (ROOT / "src/hertzsweep/output/attributes.toml").read_text(encoding="utf-8"),
        attributes(),
    )
    titles = [title for title, _ in groups]
    assert "other" not in titles  # the file's comments group every name
    assert titles[0] == "coordinates"
    assert sorted(n for _, group in groups for n in group) == sorted(attributes())


def test_every_global_attribute_is_described(hook):
    global_rows = hook.global_attribute_rows()
    names = [row[0] for row in global_rows]
    for name in ("`Conventions`", "`config_json`", "`damping_ratio`", "`contact_stiffness`"):
        assert name in names
    for name, what, _ in global_rows:
        assert what, f"global attribute {name}: no description (RECORD in the hook)"


# --------------------------------------------------------------------------- errors
def test_every_exception_has_its_row_and_exit_status(hook):
    table = {row[0]: row for row in rows(hook.errors_reference())}
    classes = hook.exception_classes(errors)
    assert {cls.__name__ for cls in classes} >= {"HertzsweepError", "ConfigError", "Stopped"}
    for cls in classes:
        row = table[f"`{cls.__name__}`"]
        assert row[2] != hook.NONE, cls
    assert table["`ConfigError`"][2] == "2"
    assert table["`Failed`"][2] == "1"
    statuses = {row[0] for row in rows(hook.errors_reference())}
    assert {"0", "1", "2", "130", "143"} <= statuses


# --------------------------------------------------------------------------- api
def test_every_public_name_has_an_entry_that_resolves(hook):
    markdown = hook.api_reference()
    paths = re.findall(r"^::: (\S+)$", markdown, flags=re.MULTILINE)
    assert paths[0] == "hertzsweep"
    names = hook.api_names(hertzsweep)
    assert len(paths) == 1 + len(names)
    for name, path in zip(names, paths[1:], strict=True):
        assert resolve(path) is getattr(hertzsweep, name) or path == f"hertzsweep.{name}"


def resolve(path: str) -> object:
    """The object a dotted path names (its longest importable module, then attributes)."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for part in parts[cut:]:
            obj = getattr(obj, part)
        return obj
    raise ImportError(path)
