"""The runner of the manual's code blocks (tests/test_docs.py) fails where it should: on
small pages held in memory, each rule of its module docstring, passing and failing."""

from __future__ import annotations

import shutil
import textwrap

import pytest

from .test_docs import (
    DocsFailure,
    line_matches,
    numbers_match,
    output_matches,
    parse_blocks,
    run_page,
)

FENCE = "```"


def page(text: str) -> str:
    """A page written with ''' for the fences (so this file's strings stay readable)."""
    return textwrap.dedent(text).replace("'''", FENCE)


def fails(text: str, tmp_path, *messages: str) -> str:
    """Run a page that must fail; check the failure names the page and says each message."""
    with pytest.raises(DocsFailure) as caught:
        run_page(page(text), tmp_path, "mem.md")
    message = str(caught.value)
    assert message.startswith("mem.md:"), message
    for expected in messages:
        assert expected in message, message
    return message


# --------------------------------------------------------------------------- numbers
@pytest.mark.parametrize(
    "shown, actual, matches",
    [
        ("1.23", "1.2345", True),  # rounds to the digits shown
        ("1.24", "1.2345", False),
        ("1.23", "1.2351", False),
        ("1.2e-05", "1.24e-05", True),  # the mantissa's decimals scaled: within 5e-7
        ("1.2e-05", "1.26e-05", False),
        ("6.09027e+09", "6090274164.95", True),
        ("17", "17", True),  # integers exactly
        ("17", "18", False),
        ("17", "17.4", False),
        ("0.00", "-0.004", True),
    ],
)
def test_numbers_match_the_digits_shown(shown, actual, matches):
    assert numbers_match(shown, actual) is matches


def test_lines_compare_numbers_by_digits_and_text_exactly():
    assert line_matches("up  0.006   0.6396", "up    0.006  0.63961")  # columns may shift
    assert not line_matches("up  0.006   0.6396", "down  0.006  0.6396")
    assert not line_matches("wrote a.nc", "wrote b.nc")
    assert not line_matches("f0 230.8 Hz", "f0 230.8 Hz 1")  # a number more
    assert line_matches("CF-1.11", "CF-1.11")


def test_an_ellipsis_line_matches_any_run_of_lines():
    assert output_matches(["a", "...", "z"], ["a", "b", "c", "z"])
    assert output_matches(["a", "...", "z"], ["a", "z"])  # none at all
    assert not output_matches(["a", "...", "z"], ["a", "b"])
    assert output_matches(["...", "last 1.0"], ["x", "last 1.01"])
    assert not output_matches(["a"], ["a", "b"])  # otherwise every line is compared
    assert output_matches("a\n\n", "a   \n")  # trailing whitespace and blank lines


# --------------------------------------------------------------------------- parsing
def test_blocks_are_found_with_their_line_language_and_title():
    blocks = parse_blocks(
        page(
            """\
            # Title

            '''toml title="scene.toml"
            a = 1
            '''

            !!! note
                '''console
                $ echo hi
                hi
                '''
            """
        )
    )
    assert [(b.language, b.title, b.line) for b in blocks] == [
        ("toml", "scene.toml", 3),
        ("console", None, 8),
    ]
    assert blocks[1].text == "$ echo hi\nhi"  # the admonition's indentation removed


# --------------------------------------------------------------------------- python
def test_python_blocks_share_a_namespace_and_their_output_is_checked(tmp_path):
    run_page(
        page(
            """\
            '''python
            x = 1.2345
            '''

            '''python
            print(x, "units")
            print(17)
            '''

            '''text
            1.23 units
            17
            '''
            """
        ),
        tmp_path,
        "mem.md",
    )


def test_python_output_that_differs_fails_showing_both(tmp_path):
    message = fails(
        """\
        Text.

        '''python
        print(1.2345)
        '''

        '''text
        1.24
        '''
        """,
        tmp_path,
        "mem.md:3:",
        "--- expected\n1.24",
        "--- actual\n1.2345",
    )
    assert "text block at line 7" in message


def test_a_python_block_that_raises_fails_with_the_page_line(tmp_path):
    fails(
        """\
        '''python
        x = 1
        raise ValueError("no such scene")
        '''
        """,
        tmp_path,
        "mem.md:1: python block raised",
        "ValueError: no such scene",
        'File "mem.md", line 3',  # the traceback counts the page's lines
    )


def test_a_text_block_after_prose_is_an_illustration(tmp_path):
    run_page(
        page(
            """\
            '''python
            print("something else")
            '''

            Prose between: the text below is not this block's output.

            '''text
            a table copied from a run: 1 2 3
            '''
            """
        ),
        tmp_path,
        "mem.md",
    )


def test_python_runs_in_the_page_folder(tmp_path):
    run_page(page("'''python\nopen('here.txt', 'w').write('x')\n'''\n"), tmp_path, "mem.md")
    assert (tmp_path / "here.txt").read_text() == "x"


# --------------------------------------------------------------------------- console
def test_console_commands_and_their_output(tmp_path):
    run_page(
        page(
            """\
            '''console
            $ echo 1.2345 \\
                and more
            1.23 and more
            $ echo anything
            $ printf 'a\\nb\\nc\\n'
            a
            ...
            '''
            """
        ),
        tmp_path,
        "mem.md",
    )


def test_console_output_that_differs_fails(tmp_path):
    fails(
        "'''console\n$ echo 1.2345\n1.24\n'''\n",
        tmp_path,
        "mem.md:2: $ echo 1.2345: output differs",
        "--- expected\n1.24\n--- actual\n1.2345",
    )


def test_a_failing_command_fails_the_page(tmp_path):
    fails("'''console\n$ false\n'''\n", tmp_path, "mem.md:2: $ false: exit status 1, expected 0")


def test_an_expected_exit_status_and_error_line(tmp_path):
    error = "'''console\n$ echo out; echo 'bad: no' >&2; exit 3\nout\nbad: no\n[exit 3]\n'''\n"
    run_page(page(error), tmp_path, "mem.md")
    fails(error.replace("[exit 3]", "[exit 2]"), tmp_path, "exit status 3, expected 2")
    fails(error.replace("bad: no\n[", "bad: yes\n["), tmp_path, "output differs")


def test_commands_run_in_their_own_shell_in_the_page_folder(tmp_path):
    run_page(page("'''console\n$ cd /\n$ ls\n'''\n"), tmp_path, "mem.md")  # cd: its own shell
    (tmp_path / "mark").write_text("")
    run_page(page("'''console\n$ ls mark\nmark\n'''\n"), tmp_path, "mem.md")


def test_console_text_before_a_command_fails(tmp_path):
    fails("'''console\nhertzsweep rig\n'''\n", tmp_path, "console text before the first '$ '")


@pytest.mark.skipif(shutil.which("make") is None, reason="no make")
def test_make_commands_check_their_targets_without_running(tmp_path):
    run_page(page("'''console\n$ make docs lint\nnot compared\n'''\n"), tmp_path, "mem.md")
    fails("'''console\n$ make no-such-target\n'''\n", tmp_path, "no such make target")
    fails("'''console\n$ make docs && echo\n'''\n", tmp_path, "stands alone")


# --------------------------------------------------------------------------- files
def test_a_titled_toml_block_is_written_before_later_blocks(tmp_path):
    run_page(
        page(
            """\
            '''toml title="sub/scene.toml"
            [damping]
            ratio = 0.01
            '''

            '''console
            $ cat sub/scene.toml
            [damping]
            ratio = 0.01
            '''
            """
        ),
        tmp_path,
        "mem.md",
    )


def test_an_untitled_toml_block_must_be_valid(tmp_path):
    run_page(page("'''toml\na = 1\n'''\n"), tmp_path, "mem.md")
    fails("'''toml\na = = 1\n'''\n", tmp_path, "mem.md:1: not valid TOML")
    fails("'''toml title=\"../out.toml\"\na = 1\n'''\n", tmp_path, "is not a file here")


# --------------------------------------------------------------------------- languages
@pytest.mark.parametrize("language", ["bash", "makefile", "json", ""])
def test_a_block_without_a_runner_fails_before_anything_runs(language, tmp_path):
    text = f"'''console\n$ touch ran\n'''\n\n'''{language}\nx\n'''\n"
    fails(text, tmp_path, f"mem.md:5: code block of language {language!r} has no runner")
    assert not (tmp_path / "ran").exists()


def test_a_csv_block_needs_a_title(tmp_path):
    fails("'''csv\na,b\n'''\n", tmp_path, "needs a title")
    run_page(page("'''csv title=\"m.csv\"\na,b\n'''\n"), tmp_path, "mem.md")
    assert (tmp_path / "m.csv").read_text() == "a,b\n"
