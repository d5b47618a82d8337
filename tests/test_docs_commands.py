"""Every `rio ...` command the README, the plugin READMEs and the docs quote in a code block is one a user
can type: it parses against the command line as installed here (the command exists, its options and
arguments are accepted, a packaged station it names exists), and the read-only ones among them run and
succeed. A command a page quotes that does not exist (`rio stations show` once did not) fails here, naming
the page and line.

Commands that drive a station, record or export are parsed, not run: they need hardware, minutes of run
time, or a dataset the page's reader made first; the workflows themselves are tested elsewhere."""

from __future__ import annotations

import functools
import re
import shlex
from pathlib import Path
from typing import Any

import pytest

from rio.testing import run_rio

ROOT = Path(__file__).resolve().parent.parent
SHELL_FENCES = {"", "bash", "sh", "shell", "console"}
#: commands that read only and finish in a second: run as quoted
RUN_AS_QUOTED = {("stations", "list"), ("stations", "show"), ("plugins", "list"), ("datasets", "formats"),
                 ("drivers", "list"), ("drivers", "show")}
#: what a page may name that does not exist here: the reader's own files and the docs' scaffolded example
#: plugin (rio-acme, made by `rio new plugin acme` a few lines above)
READERS_OWN = re.compile(r"does not exist|station file not found|unknown station 'acme")


def quoted_commands() -> list[tuple[str, str]]:
    """(page:line, command) for every line of a shell code block that runs `rio` (with `$ `, `uv run` and
    line continuations undone; the comment, a pipe or a redirection cut off). A fenced diagram (box-drawing
    characters) is not a shell block."""
    pages = [ROOT / "README.md", *sorted(ROOT.glob("plugins/*/README.md")),
             *sorted(p for p in (ROOT / "docs").rglob("*.md") if p.name != "cli-reference.md")]
    found = []
    for page in pages:
        blocks = re.findall(r"^\s*```(\w*)\n(.*?)^\s*```", page.read_text(encoding="utf-8"), re.M | re.S)
        text = page.read_text(encoding="utf-8")
        for lang, body in blocks:
            if lang not in SHELL_FENCES or re.search("[\u2500-\u257f]", body):
                continue
            start = text[: text.index(body)].count("\n") + 1
            for offset, line in enumerate(body.replace("\\\n", " ").splitlines()):
                line = re.sub(r"^\s*(\$\s+)?(uv run (--no-sync )?)?", "", line)
                if not line.startswith("rio "):
                    continue
                line = re.split(r"\s+#", line)[0]
                line = re.split(r"\s(?:\||>|&&|;)\s", line)[0].strip()
                if " [" in line:  # a synopsis (`rio replay DATASET [--speed S]`), not a command
                    continue
                found.append((f"{page.relative_to(ROOT)}:{start + offset}", line))
    return found


COMMANDS = quoted_commands()


@functools.cache
def _root() -> Any:
    import typer

    from rio.cli.app import build_app

    return typer.main.get_command(build_app())


def parse(args: list[str]) -> Any:
    """Parse `rio ARGS` down to the command it names, as the command line does before running it (types
    converted, callbacks run: a station name is checked), without running it."""
    root = _root()
    ctx = root.make_context("rio", list(args))
    command = root
    while hasattr(command, "resolve_command"):  # a group: find the subcommand in what it left
        name, command, rest = command.resolve_command(ctx, [*ctx._protected_args, *ctx.args])
        ctx = command.make_context(name, rest, parent=ctx)
    return command


def test_the_pages_quote_commands():
    assert len(COMMANDS) > 100, COMMANDS  # the extraction found the pages' commands
    assert any(c == "rio stations show xarm7-robotiq" for _, c in COMMANDS)


@pytest.mark.parametrize("where, command", COMMANDS, ids=[w for w, _ in COMMANDS])
def test_a_quoted_command_parses(where: str, command: str):
    args = shlex.split(re.sub(r"<[^>]+>", "x", command))[1:]
    try:
        parse(args)
    except Exception as e:  # click's usage errors, typer's Exit for --help
        if type(e).__name__ == "Exit" or READERS_OWN.search(str(e)):
            return
        pytest.fail(f"{where}: `{command}` does not parse: {type(e).__name__}: {e}")


RUNNABLE = [(w, c) for w, c in COMMANDS if tuple(c.split()[1:3]) in RUN_AS_QUOTED]


@pytest.mark.parametrize("where, command", RUNNABLE, ids=[w for w, _ in RUNNABLE])
def test_a_quoted_read_only_command_runs(where: str, command: str):
    if "acme" in command:
        pytest.skip("names the docs' example plugin, made by `rio new plugin acme` on the page")
    out = run_rio(*shlex.split(command)[1:], timeout=120)
    assert out.stdout.strip(), f"{where}: `{command}` printed nothing"
    if command.split()[1:3] == ["stations", "show"]:
        import tomllib

        assert tomllib.loads(out.stdout)["name"] == command.split()[3]


def test_a_command_that_does_not_exist_fails_to_parse():
    with pytest.raises(Exception, match="No such command 'shwo'"):
        parse(["stations", "shwo", "sim-so100"])
    with pytest.raises(Exception, match="unknown station 'sim-so1000'"):
        parse(["teleop", "sim-so1000"])
