"""Every code block of the manual runs: one test per page of ``docs/**/*.md`` and for
``README.md``, which executes the page's fenced code blocks in order.

Each page runs in a fresh temporary folder holding a copy of the repository's
``configs/`` (symbolic links resolved), with the environment's ``bin`` (the .venv's) first
on ``PATH``, ``MPLBACKEND=Agg`` and ``COLUMNS=80`` (so ``--help`` wraps as shown). By the
block's language:

- ``console``: each line starting with ``$ `` is a shell command (a line ending with ``\\``
  continues on the next), run by ``bash -e -c`` in the page's folder, each in its own
  shell (``cd`` and variables do not carry over), with a timeout of 300 s. The lines after
  a command up to the next ``$ `` line are its expected standard output; a command shown
  with none may print anything. The exit status must be 0, unless the last expected line
  is ``[exit N]``: then it must be N, and the lines above ``[exit N]`` are compared with
  the standard output followed by the last line of standard error (the error message),
  e.g. ``hertzsweep: error: ...`` then ``[exit 2]``. Text before the first ``$ `` line is
  an error.
- ``$ make TARGET...`` is not run (it would install or recurse): the targets must exist in
  the repository's Makefile (``make -n -C REPOSITORY TARGET...`` succeeds); its shown
  output is not compared. Such a command stands alone (no ``;``, ``&&``, pipes).
- ``python``: executed with ``exec`` in one namespace per page, block after block, with
  the page's folder as the working directory. When the next fenced block, with only blank
  lines between, is a ``text`` block, that block is the expected standard output of the
  python block; otherwise what it prints is not checked. An exception fails the page.
- ``toml`` with a title (```` ```toml title="scene.toml" ````): written to that file
  (relative to the page's folder) before the blocks after it run. Without a title: it must
  be valid TOML (``tomllib``); nothing is written.
- ``csv`` with a title: written to that file, as a titled ``toml`` block; a ``csv`` block
  needs a title.
- ``text`` not right after a python block: an illustration (a table copied from a run, a
  sketch); it is not run.
- Any other language, or a block with no language, fails the page:
  ``docs/x.md:LINE: code block of language 'x' has no runner``.

Expected and actual output are compared line by line after trailing whitespace is
stripped and trailing blank lines are dropped. A line that is only ``...`` matches any
number of lines (none included). Within a line, a number is compared with the digits
shown: ``|actual - shown| <= 0.5 * 10**-d`` with d the decimals shown (``1.23`` matches
1.2345 but not 1.2351; ``1.2e-05`` has d = 6, a tolerance of 5e-7), integers exactly;
other text must match exactly, whitespace runs counted as one space and whitespace next
to a number or at either end of a line ignored (so columns may shift). A failure names
the page and the line of the block and shows the expected and the actual output.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
import traceback
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").glob("**/*.md")) + [ROOT / "README.md"]
BIN = Path(sys.executable).parent  # the environment's bin: hertzsweep, mkdocs, ...
COMMAND_SECONDS = 300  # the longest a console command may run
WRITTEN = ("toml", "csv")  # languages of blocks that a title writes to a file
RUNNERS = ("console", "python", "text", *WRITTEN)
EXIT = re.compile(r"^\[exit (\d+)\]$")
FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})(?P<info>.*)$")
NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
SHELL_OPERATORS = re.compile(r"[;&|<>`]|\$\(")


class DocsFailure(AssertionError):
    """A code block of a page did not run as the page shows."""


@dataclass(frozen=True)
class Block:
    """A fenced code block: its language, title, first line (of the fence) and text."""

    language: str
    title: str | None
    line: int
    text: str
    end: int  # the line of the closing fence


# --------------------------------------------------------------------------- parsing
def parse_blocks(markdown: str) -> list[Block]:
    """The fenced code blocks of a page, in order (indented fences, as in an admonition
    or a list, included; their indentation removed)."""
    lines = markdown.splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        match = FENCE.match(lines[i])
        if match is None or match["fence"][0] in match["info"]:
            i += 1
            continue
        indent, fence = match["indent"], match["fence"]
        closing = re.compile(rf"^[ \t]*{re.escape(fence[0])}{{{len(fence)},}}[ \t]*$")
        end = i + 1
        while end < len(lines) and not closing.match(lines[end]):
            end += 1
        body = [_dedent(line, indent) for line in lines[i + 1 : end]]
        language, title = _info(match["info"])
        blocks.append(Block(language, title, i + 1, "\n".join(body), end + 1))
        i = end + 1
    return blocks


def _dedent(line: str, indent: str) -> str:
    return line[len(indent) :] if line.startswith(indent) else line.lstrip()


def _info(info: str) -> tuple[str, str | None]:
    """The language and the title of a fence's info string (``toml title="a.toml"`` or
    ``{ .toml title="a.toml" }``)."""
    info = info.strip()
    if info.startswith("{") and info.endswith("}"):
        info = info[1:-1].strip()
    title = re.search(r'title="([^"]*)"', info)
    words = info.split()
    language = words[0].lstrip(".") if words and "=" not in words[0] else ""
    return language, title.group(1) if title else None


# --------------------------------------------------------------------------- comparing
def _decimals(token: str) -> int | None:
    """The decimal place of a number's last digit (1.23: 2; 1.2e-05: 6; 1e3: -3), None
    for an integer (compared exactly)."""
    mantissa, _, exponent = token.lower().partition("e")
    if "." not in mantissa and not exponent:
        return None
    decimals = len(mantissa.partition(".")[2])
    return decimals - int(exponent or 0)


def _split(line: str) -> tuple[list[str], list[str]]:
    """A line's text between numbers (normalised) and its numbers."""
    texts, numbers, last = [], [], 0
    for match in NUMBER.finditer(line):
        texts.append(" ".join(line[last : match.start()].split()))
        numbers.append(match.group())
        last = match.end()
    texts.append(" ".join(line[last:].split()))
    return texts, numbers


def numbers_match(shown: str, actual: str) -> bool:
    """Whether ``actual`` rounds to the digits of ``shown`` (integers: equal)."""
    decimals = _decimals(shown)
    difference = abs(float(actual) - float(shown))
    if decimals is None:
        return difference == 0
    return difference <= 0.5 * 10.0**-decimals * (1 + 1e-9)  # 1e-9: the binary rounding


def line_matches(shown: str, actual: str) -> bool:
    """One line against another by the rule of the module docstring."""
    shown_texts, shown_numbers = _split(shown)
    actual_texts, actual_numbers = _split(actual)
    return (
        shown_texts == actual_texts
        and len(shown_numbers) == len(actual_numbers)
        and all(map(numbers_match, shown_numbers, actual_numbers))
    )


def _lines(text: str | Sequence[str]) -> list[str]:
    lines = [line.rstrip() for line in (text.splitlines() if isinstance(text, str) else text)]
    while lines and not lines[-1]:
        lines.pop()
    return lines


def output_matches(expected: str | Sequence[str], actual: str | Sequence[str]) -> bool:
    """Whether the actual output matches the expected, ``...`` lines matching any run of
    lines."""
    shown, got = _lines(expected), _lines(actual)
    # reachable[j]: shown[:i] can match got[:j]
    reachable = [True] + [False] * len(got)
    for line in shown:
        if line.strip() == "...":
            for j in range(1, len(got) + 1):
                reachable[j] = reachable[j] or reachable[j - 1]
            continue
        reachable = [False] + [reachable[j] and line_matches(line, got[j]) for j in range(len(got))]
    return reachable[-1]


def _show(expected: str | Sequence[str], actual: str | Sequence[str]) -> str:
    return (
        "\n--- expected\n"
        + "\n".join(_lines(expected))
        + "\n--- actual\n"
        + "\n".join(_lines(actual))
    )


# --------------------------------------------------------------------------- running
@dataclass(frozen=True)
class Command:
    """One ``$ `` command of a console block and its expected output."""

    line: int
    text: str
    expected: list[str]


def console_commands(block: Block, label: str) -> list[Command]:
    """The commands of a console block with the lines each is expected to print."""
    commands: list[Command] = []
    lines = block.text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.startswith("$ "):
            if line.strip() and not commands:
                raise DocsFailure(
                    f"{label}:{block.line + 1 + i}: console text before the first '$ ' "
                    f"command: {line!r}"
                )
            if commands:
                commands[-1].expected.append(line)
            i += 1
            continue
        first = i
        text = [line[2:]]
        while text[-1].endswith("\\") and i + 1 < len(lines):
            i += 1
            text.append(lines[i])
        commands.append(Command(block.line + 1 + first, "\n".join(text), []))
        i += 1
    return commands


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    env["COLUMNS"] = "80"
    return env


def run_command(command: Command, folder: Path, label: str, repository: Path) -> None:
    """Run one console command (or check a make command's targets) and compare."""
    where = f"{label}:{command.line}: $ {command.text}"
    words = shlex.split(command.text) if command.text.strip() else []
    if words and words[0] == "make":
        if any(SHELL_OPERATORS.search(word) for word in words):
            raise DocsFailure(f"{where}: a make command stands alone (it is not run)")
        done = subprocess.run(
            ["make", "-n", "-C", str(repository), *words[1:]],
            capture_output=True,
            text=True,
            env=_environment(),
            timeout=COMMAND_SECONDS,
        )
        if done.returncode != 0:
            raise DocsFailure(f"{where}: no such make target here\n{done.stderr.strip()}")
        return
    expected = _lines(command.expected)
    status = 0
    if expected and EXIT.match(expected[-1].strip()):
        status = int(EXIT.match(expected[-1].strip()).group(1))
        expected = expected[:-1]
    try:
        done = subprocess.run(
            ["bash", "-e", "-c", command.text],
            cwd=folder,
            capture_output=True,
            text=True,
            env=_environment(),
            timeout=COMMAND_SECONDS,
        )
    except subprocess.TimeoutExpired:
        raise DocsFailure(f"{where}: still running after {COMMAND_SECONDS} s") from None
    actual = _lines(done.stdout)
    if status:
        actual += _lines(done.stderr)[-1:]
    if done.returncode != status:
        raise DocsFailure(
            f"{where}: exit status {done.returncode}, expected {status}"
            + _show(command.expected, actual)
            + "\n--- stderr\n"
            + done.stderr.rstrip()
        )
    if expected and not output_matches(expected, actual):
        raise DocsFailure(f"{where}: output differs" + _show(expected, actual))


@contextlib.contextmanager
def _page_folder(folder: Path) -> Iterator[None]:
    """The page's folder as working directory and its environment, for python blocks."""
    saved = {name: os.environ.get(name) for name in ("PATH", "MPLBACKEND", "COLUMNS")}
    cwd = os.getcwd()
    os.environ.update({name: _environment()[name] for name in saved})
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(cwd)
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
        if "matplotlib.pyplot" in sys.modules:
            sys.modules["matplotlib.pyplot"].close("all")


def run_python(block: Block, namespace: dict, label: str, expected: Block | None) -> None:
    """Execute a python block in the page's namespace; compare what it prints with the
    text block after it, if any."""
    code = compile("\n" * block.line + block.text, label, "exec")  # tracebacks: page lines
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            exec(code, namespace)
    except BaseException as exc:  # SystemExit too: the page failed
        if isinstance(exc, KeyboardInterrupt):
            raise
        frames = exc.__traceback__.tb_next if exc.__traceback__ else None  # from the page on
        trace = "".join(traceback.format_exception(type(exc), exc, frames))
        raise DocsFailure(f"{label}:{block.line}: python block raised\n{trace}") from None
    if expected is not None and not output_matches(expected.text, out.getvalue()):
        raise DocsFailure(
            f"{label}:{block.line}: printed output differs from the text block at line "
            f"{expected.line}" + _show(expected.text, out.getvalue())
        )


def write_file(block: Block, folder: Path, label: str) -> None:
    """A titled toml or csv block: its text, written to its file in the page's folder."""
    title = Path(block.title or "")
    if title.is_absolute() or ".." in title.parts or not title.name:
        raise DocsFailure(f"{label}:{block.line}: title {block.title!r} is not a file here")
    target = folder / title
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(block.text + "\n", encoding="utf-8")


def run_page(markdown: str, folder: Path, label: str, repository: Path = ROOT) -> None:
    """Run every code block of a page in ``folder`` by the rules of the module docstring.

    Raises
    ------
    DocsFailure
        Naming ``label:LINE`` of the first block that does not run as the page shows.
    """
    blocks = parse_blocks(markdown)
    lines = markdown.splitlines()
    for block in blocks:  # nothing runs when a block has no runner
        if block.language not in RUNNERS:
            raise DocsFailure(
                f"{label}:{block.line}: code block of language {block.language!r} has no runner"
            )
        if block.language == "csv" and not block.title:
            raise DocsFailure(f"{label}:{block.line}: a csv block needs a title (its file)")
    namespace: dict = {"__name__": "__main__"}
    for index, block in enumerate(blocks):
        if block.language == "text":
            continue
        if block.language == "console":
            for command in console_commands(block, label):
                run_command(command, folder, label, repository)
        elif block.language == "python":
            after = blocks[index + 1] if index + 1 < len(blocks) else None
            between = lines[block.end : after.line - 1] if after else []
            shown = after is not None and after.language == "text"
            shown = shown and not any(line.strip() for line in between)
            with _page_folder(folder):
                run_python(block, namespace, label, after if shown else None)
        elif block.title:
            write_file(block, folder, label)
        else:
            try:
                tomllib.loads(block.text)
            except tomllib.TOMLDecodeError as exc:
                raise DocsFailure(f"{label}:{block.line}: not valid TOML: {exc}") from None


def page_folder(tmp_path: Path, repository: Path = ROOT) -> Path:
    """A fresh folder holding a copy of the repository's configs/ (links resolved)."""
    shutil.copytree(repository / "configs", tmp_path / "configs", symlinks=False)
    return tmp_path


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_page(page: Path, tmp_path: Path) -> None:
    if not page.exists():
        pytest.fail(f"{page.relative_to(ROOT)}: no such page")
    label = str(page.relative_to(ROOT))
    try:
        run_page(page.read_text(encoding="utf-8"), page_folder(tmp_path), label)
    except DocsFailure as failure:
        message = str(failure)
    else:
        return
    pytest.fail(message, pytrace=False)  # the page, the line and the outputs say it all
