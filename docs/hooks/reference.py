"""The generated parts of the reference pages (an mkdocs hook: ``hooks:`` in mkdocs.yml).

A line ``<!-- generated: NAME -->`` alone in a page is replaced, when the page is built,
by the Markdown that ``GENERATORS[NAME]()`` builds from the code itself, so the reference
cannot drift from it:

- ``cli``: every command of :data:`hertzsweep.cli.group.COMMANDS` from click's own
  objects: usage, help text, arguments and options (names, value, default, help);
- ``config``: every table and key of :data:`hertzsweep.core.config.SCHEMA` with what it
  accepts (its validator), its default (the dataclasses' fields) and its meaning
  (:data:`hertzsweep.core.config.DESCRIPTIONS`);
- ``datasets``: every variable and coordinate of ``hertzsweep/output/attributes.toml``,
  grouped as the file's comments group them, and the global attributes of every dataset;
- ``errors``: the exceptions of :mod:`hertzsweep.errors` with the exit status the command
  line gives each (read from :func:`hertzsweep.cli._run`), and the exit statuses;
- ``api``: a mkdocstrings entry (``::: path``) for every name of ``hertzsweep.__all__``,
  pointing at the module that defines it.

An unknown marker fails the build. The generators are plain functions of no argument
(``tests/test_docs_reference.py`` checks them without running mkdocs).
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import json
import re
import signal
import textwrap
import tomllib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]  # the repository
DEFAULT_SCENE = ROOT / "configs" / "default.toml"  # the scene the global attributes come from
MARKER = re.compile(r"^<!-- generated: ([a-z][a-z-]*) -->[ \t]*$", re.MULTILINE)
NONE = "—"  # an empty cell


# --------------------------------------------------------------------------- the hook
def on_page_markdown(markdown: str, *, page: Any, config: Any, files: Any, **_: Any) -> str:
    """Replace every marker line of a page by its generated Markdown."""
    from mkdocs.exceptions import PluginError

    def generated(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in GENERATORS:
            known = ", ".join(GENERATORS)
            raise PluginError(
                f"{page.file.src_uri}: unknown marker 'generated: {name}' (known: {known})"
            )
        return GENERATORS[name]()

    return MARKER.sub(generated, markdown)


def on_page_content(html: str, **_: Any) -> str:
    """Docstrings rendered by mkdocstrings: a Sphinx role before a code span
    (``:func:`~hertzsweep.api.sweep```) becomes the code span alone (``sweep``, its last
    part after ``~``), as Sphinx shows it."""
    return RENDERED_ROLE.sub(lambda m: f"<code>{_role_target(m)}</code>", html)


# --------------------------------------------------------------------------- Markdown
RENDERED_ROLE = re.compile(
    r":(?:py:)?(?:func|class|mod|data|meth|attr|exc|obj|const):<code>(~?)([^<]*)</code>"
)
ROLE = re.compile(r":(?:py:)?(?:func|class|mod|data|meth|attr|exc|obj|const):`(~?)([^`]+)`")
CODE = re.compile(r"``(.+?)``|`([^`]+)`")
ESCAPES = str.maketrans({"<": "&lt;", ">": "&gt;", "*": r"\*", "_": r"\_", "[": r"\[", "]": r"\]"})


def code(text: Any) -> str:
    """``text`` as a Markdown code span (a table cell does not split at a ``|`` inside)."""
    text = str(text)
    fence = "``" if "`" in text else "`"
    pad = " " if fence == "``" else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def prose(text: str) -> str:
    """A docstring's or a help text's words as Markdown: reST literals (````x````) and
    roles (``:func:`x```) become code spans; the rest is escaped, so that it reads as
    written (``<``, ``*``, ``_``, brackets, and ``|`` in a table cell)."""
    text = ROLE.sub(lambda m: f"``{_role_target(m)}``", " ".join(text.split()))
    out, last = [], 0
    for match in CODE.finditer(text):
        out.append(_escape(text[last : match.start()]))
        out.append(code(match.group(1) or match.group(2)))
        last = match.end()
    out.append(_escape(text[last:]))
    return "".join(out)


def _role_target(match: re.Match[str]) -> str:
    """A role's target as Sphinx shows it: whole, or its last part after ``~``."""
    return match.group(2).rsplit(".", 1)[-1] if match.group(1) else match.group(2)


def _escape(text: str) -> str:
    return text.translate(ESCAPES).replace("|", r"\|")


def table(header: Iterable[str], rows: Iterable[Iterable[str]]) -> str:
    """A Markdown table; an empty cell shows :data:`NONE`."""
    header = list(header)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        lines.append("| " + " | ".join(str(cell) or NONE for cell in row) + " |")
    return "\n".join(lines)


def summary(doc: str | None) -> str:
    """The first paragraph of a docstring, on one line."""
    return " ".join(inspect.cleandoc(doc or "").split("\n\n")[0].split())


def paragraphs(doc: str | None) -> str:
    """A docstring or a help text as Markdown paragraphs (click's ``\\b`` paragraphs kept
    line by line, everything after ``\\f`` left out, as ``--help`` does)."""
    text = inspect.cleandoc((doc or "").split("\f")[0])
    out = []
    for block in re.split(r"\n\s*\n", text):
        if block.startswith("\b"):
            out.append("```text\n" + block[1:].strip("\n") + "\n```")
        elif block.strip():
            out.append(prose(block))
    return "\n\n".join(out)


# --------------------------------------------------------------------------- cli
def cli_reference() -> str:
    """Every command: its usage, help, arguments and options, from click's objects."""
    import click

    from hertzsweep.cli.group import COMMANDS, cli

    root = click.Context(cli, info_name="hertzsweep", **cli.context_settings)
    names = list(COMMANDS)
    commands = {}
    for name in names:
        command = cli.get_command(root, name)  # imports the module that registers it
        if command is None:
            raise LookupError(f"hertzsweep {name}: listed in COMMANDS but not registered")
        commands[name] = command
    names += sorted(set(cli.commands) - set(names))  # registered without a COMMANDS line
    commands.update({name: cli.commands[name] for name in names if name not in commands})

    listing = table(
        ["command", "does"],
        [
            [f"[`hertzsweep {name}`](#{name})", prose(COMMANDS.get(name, ("", ""))[1])]
            for name in names
        ],
    )
    sections = [_command_section(cli, root, "hertzsweep", "hertzsweep", listing)]
    for name in names:
        ctx = click.Context(
            commands[name], info_name=name, parent=root, **commands[name].context_settings
        )
        sections.append(_command_section(commands[name], ctx, f"hertzsweep {name}", name))
    return "\n\n".join(sections) + "\n"


def _command_section(
    command: Any, ctx: Any, title: str, anchor: str, listing: str | None = None
) -> str:
    import click

    usage = " ".join([ctx.command_path, *command.collect_usage_pieces(ctx)])
    parts = [f"## `{title}` {{ #{anchor} }}", paragraphs(command.help)]
    parts.append(f"```text\nUsage: {usage}\n```")
    if listing is not None:
        parts.append(listing)
    params = [p for p in command.get_params(ctx) if not getattr(p, "hidden", False)]
    arguments = [p for p in params if isinstance(p, click.Argument)]
    options = [p for p in params if isinstance(p, click.Option)]
    if arguments:
        rows = [
            [code(_metavar(p, ctx)), _type_text(p), "yes" if p.required else "no"]
            for p in arguments
        ]
        parts.append("**Arguments**\n\n" + table(["argument", "type", "required"], rows))
    if options:
        rows = [
            [
                ", ".join(code(name) for name in [*p.opts, *p.secondary_opts]),
                _option_value(p, ctx),
                _option_default(p),
                prose(p.help or "") + (f" Environment: {code(p.envvar)}." if p.envvar else ""),
            ]
            for p in options
        ]
        parts.append("**Options**\n\n" + table(["option", "value", "default", "description"], rows))
    return "\n\n".join(part for part in parts if part)


def _metavar(param: Any, ctx: Any) -> str:
    try:
        return param.make_metavar(ctx)  # click >= 8.2
    except TypeError:
        return param.make_metavar()


def _type_text(param: Any) -> str:
    """What a parameter accepts: a choice's values, a range's bounds, else the type."""
    info = param.type.to_info_dict()
    if "choices" in info:
        return "one of " + ", ".join(code(choice) for choice in info["choices"])
    bounds = []
    for end, sign, strict in (("min", ">", "min_open"), ("max", "<", "max_open")):
        if info.get(end) is not None:
            bounds.append(f"x {sign}{'' if info.get(strict) else '='} {info[end]:g}")
    kind = info.get("name", "text").replace(" range", "")
    return f"{kind}, " + " and ".join(bounds) if bounds else kind


def _option_value(param: Any, ctx: Any) -> str:
    if param.is_flag and not param.secondary_opts:
        return "flag"
    text = f"{code(param.metavar)} ({_type_text(param)})" if param.metavar else _type_text(param)
    if param.multiple:
        text += ", repeatable"
    if param.nargs > 1:
        text += f", {param.nargs} values"
    return text


def _option_default(param: Any) -> str:
    if param.required:
        return "required"
    if not param.expose_value:  # --help, --version: act at once
        return NONE
    if isinstance(param.show_default, str):
        return prose(param.show_default)
    default = param.to_info_dict().get("default")
    if param.is_flag and not param.secondary_opts:
        return "on" if default else "off"
    if default is None or default == () or callable(default):
        return NONE
    return code(default)


# --------------------------------------------------------------------------- config
CHECKS = {  # a validator of hertzsweep.core.config -> what it accepts
    "_band": "two numbers `[w_low, w_high]`, 0 < w_low < w_high",
    "_non_negative_int": "a whole number >= 0",
    "_bin_count": "a whole number >= 2",
    "_seed": "a whole number, 0 to 2**63 - 1",
    "_number": "a number",
    "_integer": "a whole number",
    "_positive": "a number > 0",
    "_non_negative": "a number >= 0",
    "_positive_int": "a whole number >= 1",
    "_poisson": "a number in (-1, 0.5)",
    "_fraction": "a number in (0, 1)",
    "_sigma_list": "a number > 0, or a list of distinct ones",
    "_directions": '`"up"`, `"down"`, or a list of one or both',
    "_settle": 'a whole number >= 0, or `"auto"`',
    "_harmonics": "an order > 0, whole or a multiple of 1/2, 1/3, 1/4 (within 1e-9), or a "
    "list of distinct ones",
    "_period_multiple": "a whole number, 1 to 8",
    "_boolean": "`true` or `false`",
    "_initial_state": "two finite numbers `[q, dq]`",
}


def config_reference() -> str:
    """Every table and key of the schema: accepted values, default, meaning."""
    from hertzsweep.core import config

    missing = [
        f"{t}.{k}"
        for t, keys in config.SCHEMA.items()
        for k in keys
        if f"{t}.{k}" not in config.DESCRIPTIONS
    ]
    if missing:
        raise LookupError(f"no line in hertzsweep.core.config.DESCRIPTIONS for {missing}")
    tables = [code(f"[{name}]") for name in config.SCHEMA]
    parts = [
        "A scene file holds the tables " + ", ".join(tables) + "; `rig` is an inline `[rig]` "
        'table or the name of a rig file (`rig = "rig.toml"`, relative to the scene), which '
        "holds only `[rig]`. Every key but the rig's "
        + ", ".join(code(key) for key in config.REQUIRED_RIG_KEYS)
        + " has a default. Unknown tables and keys are errors. `--set TABLE.KEY=VALUE` "
        "(TOML value syntax) overrides any key on the command line."
    ]
    for name, checks in config.SCHEMA.items():
        cls = config.CLASSES[name]
        fields = {field.name: field for field in dataclasses.fields(cls)}
        rows = []
        for key, check in checks.items():
            if key not in fields:
                raise LookupError(f"{name}.{key}: in SCHEMA but not a field of {cls.__name__}")
            rows.append(
                [
                    code(key),
                    _accepts(check, config),
                    _default(fields[key], key in config.REQUIRED_RIG_KEYS and name == "rig"),
                    prose(config.DESCRIPTIONS[f"{name}.{key}"]),
                ]
            )
        parts.append(f"## `[{name}]` {{ #{name} }}")
        parts.append(prose(summary(cls.__doc__)))
        parts.append(table(["key", "accepts", "default", "meaning"], rows))
    return "\n\n".join(parts) + "\n"


def _accepts(check: Callable[..., Any], module: Any) -> str:
    """What a validator accepts: :data:`CHECKS` by its name; a lambda that calls
    ``_string`` with a tuple of the module (``GEOMETRIES``, ...): one of its values."""
    name = getattr(check, "__name__", "")
    if name in CHECKS:
        return CHECKS[name]
    if name == "<lambda>":
        code_names = check.__code__.co_names
        choices = [
            getattr(module, n) for n in code_names if isinstance(getattr(module, n, None), tuple)
        ]
        if "_string" in code_names and len(choices) == 1:
            return "one of " + ", ".join(code(json.dumps(value)) for value in choices[0])
    raise LookupError(
        f"validator {name or check!r} of hertzsweep.core.config: say what it accepts in "
        "CHECKS of docs/hooks/reference.py"
    )


def _default(field: dataclasses.Field[Any], required: bool) -> str:
    if required:
        return "required"
    if field.default is not dataclasses.MISSING:
        value = field.default
    elif field.default_factory is not dataclasses.MISSING:
        value = field.default_factory()
    else:
        return "required"
    return "unset" if value is None else code(toml_value(value))


def toml_value(value: Any) -> str:
    """A default as it would be written in a scene file."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return repr(value)


# --------------------------------------------------------------------------- datasets
def datasets_reference() -> str:
    """The dataset kinds, every variable and coordinate, and the global attributes."""
    from hertzsweep.core import kinds
    from hertzsweep.output import dataset

    text = dataset.ATTRIBUTES_FILE.read_text(encoding="utf-8")
    attributes = tomllib.loads(text)
    parts = [
        "Every dataset names its kind in the global attribute `hertzsweep_kind`: "
        + ", ".join(code(name) for name in kinds.KINDS)
        + ". A variable or coordinate means the same in every kind that has it; units "
        '`1` mark a dimensionless value (forces in units of the static load F_s), "—" a '
        "label (CF labels carry no units)."
    ]
    for title, names in attribute_groups(text, attributes):
        rows = []
        for name in names:
            attrs = dict(attributes[name])
            long_name = attrs.pop("long_name", "")
            units = attrs.pop("units", "")
            others = "; ".join(f"{code(k)}: {prose(str(v))}" for k, v in attrs.items())
            rows.append([code(name), prose(long_name), code(units) if units else "", others])
        parts.append(f"## {title[:1].upper() + title[1:]}")
        parts.append(table(["name", "long_name", "units", "other attributes"], rows))
    parts.append("## Global attributes { #global-attributes }")
    parts.append(prose(summary(dataset.global_attributes.__doc__)))
    parts.append(table(["attribute", "what", "units"], global_attribute_rows()))
    return "\n\n".join(parts) + "\n"


def attribute_groups(text: str, attributes: Mapping[str, Any]) -> list[tuple[str, list[str]]]:
    """The names of the attributes file grouped by the comment line right above each
    group (a comment followed by a blank line, as the file's preamble, names none);
    names the comments miss go last, under "other"."""
    groups: list[tuple[str, list[str]]] = []
    comment: list[str] = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#"):
            comment.append(stripped.lstrip("#").strip())
            continue
        if not stripped:
            comment = []
            continue
        match = re.match(r'^(?:"([^"]+)"|([\w-]+))\s*=', stripped)
        if match is None:
            continue
        if comment or not groups:
            groups.append((" ".join(comment) or "variables", []))
            comment = []
        groups[-1][1].append(match.group(1) or match.group(2))
    seen = {name for _, names in groups for name in names}
    rest = [name for name in attributes if name not in seen]
    if rest:
        groups.append(("other", rest))
    return groups


RECORD = {  # global attributes that record how a dataset was made -> what each holds
    "title": "what the dataset is, in a line",
    "summary": "what a dataset of its kind holds, in a sentence (ACDD)",
    "Conventions": "the CF version the attributes follow",
    "source": "the program and its version",
    "history": "when, with which version and by which command line (absolute paths, the "
    "working folder) the dataset was made",
    "references": "the paper whose rig, model and figures hertzsweep reproduces",
    "hertzsweep_kind": "the kind of dataset (see above)",
    "hertzsweep_version": "the version of the code",
    "git_commit": "the commit of the checkout the code ran from (only from a git checkout)",
    "git_modified": "1 when the package's files differ from that commit (with git_commit)",
    "python_version": "the version of Python",
    "numpy_version": "the version of numpy",
    "numba_version": "the version of numba",
    "config_json": "the whole resolved configuration, a scene file's tables as JSON (rig "
    "inline): `hertzsweep rerun` runs it again",
    "command_json": "the command and the arguments it ran with, as JSON",
    "scene_file": "the scene file, as an absolute path",
}


def global_attribute_rows() -> list[list[str]]:
    """One row per global attribute of every dataset, in the order a dataset holds them:
    the names :func:`hertzsweep.output.dataset.global_attributes` gives the default scene.

    The rig's derived constants are described by
    :class:`hertzsweep.core.rig.RigConstants`, the configuration values by
    :data:`hertzsweep.core.config.DESCRIPTIONS`, the others by :data:`RECORD`; a name
    none of them describes gets an empty description (tests/test_docs_reference.py)."""
    from hertzsweep.core import config
    from hertzsweep.core.rig import UNITS, RigConstants, derive
    from hertzsweep.output import dataset

    scene = config.load_scene(DEFAULT_SCENE)
    names = list(dataset.global_attributes(scene, "title", "sweep", history="history"))
    constants = derive(scene.rig).as_dict()
    constant_text = numpydoc_attributes(RigConstants.__doc__)
    settings = _setting_keys(scene, config)
    rows = []
    for name in names:
        units = ""
        if name in RECORD:
            what = prose(RECORD[name])
        elif name in constants:
            what = "the rig's " + prose(constant_text.get(name, ""))
            units = UNITS.get(name, "")
        elif name in settings:
            dotted = settings[name]
            what = f"the resolved {code(dotted)}: " + prose(config.DESCRIPTIONS[dotted])
        else:
            what = ""
        rows.append([code(name), what, code(units) if units else ""])
    return rows


def _setting_keys(scene: Any, config: Any) -> dict[str, str]:
    """Flat attribute name (``damping_ratio``) -> dotted config key (``damping.ratio``)."""
    names = set(scene.attributes())
    out = {}
    for dotted in config.DESCRIPTIONS:
        table_name, key = dotted.split(".")
        for candidate in (f"{table_name}_{key}", key):
            if candidate in names and candidate not in out:
                out[candidate] = dotted
                break
    return out


def numpydoc_attributes(doc: str | None) -> dict[str, str]:
    """``name : text`` entries of a docstring's Attributes section, on one line each."""
    out: dict[str, str] = {}
    lines = inspect.cleandoc(doc or "").splitlines()
    inside, current = False, None
    for i, line in enumerate(lines):
        if (
            line.strip() == "Attributes"
            and i + 1 < len(lines)
            and set(lines[i + 1].strip()) == {"-"}
        ):
            inside = True
            continue
        if not inside or set(line.strip()) == {"-"}:
            continue
        match = re.match(r"^(\w+) : (.*)$", line)
        if match:
            current = match.group(1)
            out[current] = match.group(2).strip()
        elif line.startswith(" ") and current:
            out[current] += " " + line.strip()
        elif line.strip():
            break
    return out


# --------------------------------------------------------------------------- errors
def errors_reference() -> str:
    """The exception classes with their exit statuses, and the exit statuses."""
    import hertzsweep.cli as cli
    from hertzsweep import errors

    classes = exception_classes(errors)
    handlers = exit_handlers(cli)
    rows = []
    for cls in classes:
        base = cls.__bases__[0]
        base_name = base.__name__ if base.__module__ == errors.__name__ else base.__qualname__
        status = next((text for types, text in handlers if issubclass(cls, types)), NONE)
        rows.append([code(cls.__name__), code(base_name), status, prose(summary(cls.__doc__))])
    parts = [
        table(["exception", "base", "exit status", "meaning"], rows),
        "## Exit statuses { #exit-statuses }",
        table(["status", "name", "meaning"], exit_status_rows(cli)),
    ]
    return "\n\n".join(parts) + "\n"


def exception_classes(module: Any) -> list[type]:
    """The exception classes a module defines, in the order it defines them."""
    return [
        value
        for value in vars(module).values()
        if isinstance(value, type)
        and issubclass(value, BaseException)
        and value.__module__ == module.__name__
    ]


def exit_handlers(cli: Any) -> list[tuple[tuple[type, ...], str]]:
    """The ``except`` clauses of :func:`hertzsweep.cli._run`, in order: the exception
    types each catches and the exit status it ends with, as Markdown."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cli._run)))
    default = inspect.signature(cli.fail).parameters["status"].default
    out = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Try):
            continue
        for handler in node.handlers:
            if handler.type is None:
                continue
            types = eval(  # an except clause of our own code, in its module
                compile(ast.Expression(handler.type), "<except>", "eval"), vars(cli)
            )
            types = types if isinstance(types, tuple) else (types,)
            out.append((types, _status_text(handler.body, cli, default)))
    return out


def _status_text(body: list[ast.stmt], cli: Any, default: int) -> str:
    """The exit status a handler's ``fail(message, status)`` or ``sys.exit(status)`` gives."""
    for node in (n for stmt in body for n in ast.walk(stmt)):
        if not isinstance(node, ast.Call):
            continue
        callee = ast.unparse(node.func)
        if callee == "fail":
            status = node.args[1] if len(node.args) > 1 else None
        elif callee == "sys.exit":
            status = node.args[0] if node.args else None
        else:
            continue
        if status is None:
            return str(default)
        if isinstance(status, ast.Name) and isinstance(getattr(cli, status.id, None), int):
            return str(getattr(cli, status.id))
        if isinstance(status, ast.Call) and isinstance(status.func, ast.Name):
            helper = getattr(cli, status.func.id, None)
            if helper is not None and helper.__doc__:
                return prose(summary(helper.__doc__))
        return code(ast.unparse(status))
    return NONE


def exit_status_rows(cli: Any) -> list[list[str]]:
    """The ``EXIT_*`` constants of the command line with their comments, and the statuses
    of a run stopped by a signal."""
    from hertzsweep.cli import signals

    rows = [["0", NONE, "the command finished"]]
    source = inspect.getsource(cli)
    for match in re.finditer(r"^(EXIT_[A-Z_]+)\s*=\s*[^#\n]+#\s*(.*)$", source, re.MULTILINE):
        name, comment = match.groups()
        rows.append([str(getattr(cli, name)), code(name), prose(comment)])
    for number in signals.STOP_SIGNALS:
        status = 128 + int(number)
        if not any(row[0] == str(status) for row in rows):
            rows.append([str(status), NONE, f"stopped by {signal.Signals(number).name}"])
    rows.sort(key=lambda row: int(row[0]))
    return rows


# --------------------------------------------------------------------------- api
def api_reference() -> str:
    """A mkdocstrings entry for every public name (``hertzsweep.__all__``), pointing at
    the module that defines it (names the package exports lazily are found there)."""
    hertzsweep = importlib.import_module("hertzsweep")
    entries = ["::: hertzsweep\n    options:\n      show_root_heading: false\n      members: false"]
    for name in api_names(hertzsweep):
        entries.append(f"::: {api_path(hertzsweep, name)}")
    return "\n\n".join(entries) + "\n"


def api_names(package: Any) -> list[str]:
    """``__all__`` of the package, else its public names."""
    names = getattr(package, "__all__", None)
    if names is None:
        names = [n for n, v in vars(package).items() if not n.startswith("_") and callable(v)]
    return list(names)


def api_path(package: Any, name: str) -> str:
    """The dotted path mkdocstrings finds ``package.name`` under: the defining module's."""
    obj = getattr(package, name)
    if inspect.ismodule(obj):
        return obj.__name__
    module = getattr(obj, "__module__", None)
    qualname = getattr(obj, "__qualname__", None)
    if isinstance(module, str) and isinstance(qualname, str) and "<" not in qualname:
        return f"{module}.{qualname}"
    return f"{package.__name__}.{name}"


GENERATORS: dict[str, Callable[[], str]] = {
    "cli": cli_reference,
    "config": config_reference,
    "datasets": datasets_reference,
    "errors": errors_reference,
    "api": api_reference,
}
