"""Assembles the root typer app: built-in command groups, then whatever plugins add; and how every
command ends (`RioGroup.main`)."""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from typing import Annotated, Any

import typer
from typer.core import TyperGroup

#: Exit status of a command ended by Ctrl-C (128 + SIGINT), like a shell's.
EXIT_INTERRUPTED = 130


class Interrupted(Exception):
    """Ctrl-C inside a command, carried past typer (which would end it silently) to `_exit_status`."""


class RioGroup(TyperGroup):
    """The root command. Every way a command can fail ends here, once, as one line on stderr and an
    exit status, never a traceback: a bad argument or usage (2, the line names the option), a
    RioError (1), Ctrl-C at any moment, start-up included ("interrupted", 130). `rio --debug` (or
    RIO_DEBUG=1) prints a RioError's traceback above its line; an exception that is not a RioError is a
    bug and keeps its traceback."""

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True, windows_expand_args: bool = True,
             **extra: Any) -> Any:
        _tidy_help(self)
        code = _exit_status(lambda: super(RioGroup, self).main(args, prog_name, complete_var, standalone_mode=False,
                                                               windows_expand_args=windows_expand_args, **extra))
        if standalone_mode:
            sys.exit(code)
        return code

    def invoke(self, ctx: Any) -> Any:
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            raise Interrupted() from None


def _tidy_help(command: Any) -> None:
    """What `--help` shows, for every command a plugin or the core adds: a flag shows no `<bool>` type (it
    takes no value), and a command's line in its group's list is its first paragraph on one line (typer
    kept the docstring's line breaks there, cutting sentences)."""
    for param in getattr(command, "params", ()):
        if getattr(param, "is_flag", False) and param.metavar is None:
            param.metavar = ""
    if "get_help_option" in dir(command) and "get_help_option" not in vars(command):  # --help: made on demand
        made = command.get_help_option

        def help_option(ctx: Any) -> Any:
            option = made(ctx)
            if option is not None:
                option.metavar = ""
            return option

        command.get_help_option = help_option
    for sub in getattr(command, "commands", {}).values():
        if sub.short_help is None and sub.help:
            sub.short_help = " ".join(sub.help.split("\n\n")[0].split())
        _tidy_help(sub)


def run(argv: Sequence[str]) -> int:
    """The `rio` command line: build the app (plugins add their commands), run it, return its exit
    status. Ctrl-C while plugins load is an interruption like any other."""
    try:
        app = build_app()
        app(args=list(argv), prog_name="rio", standalone_mode=True)
    except KeyboardInterrupt:
        return _interrupted()
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    return 0


def _exit_status(invoke: Any) -> int:
    """Run `invoke` (the command line, not in standalone mode) and turn how it ended into a status."""
    from typer._click.exceptions import ClickException, NoArgsIsHelpError

    from rio.cli.output import error
    from rio.errors import RioError

    try:
        result = invoke()
    except NoArgsIsHelpError as e:  # the help is printed already
        return e.exit_code
    except ClickException as e:
        error(" ".join(e.format_message().splitlines()) + _help_hint(e))
        return e.exit_code
    except RioError as e:
        _traceback_if_debug()
        error(str(e))
        return 1
    except (KeyboardInterrupt, Interrupted):
        return _interrupted()
    except typer.Abort:  # a confirmation answered no, or stdin closed at a prompt
        error("aborted")
        return 1
    return result if isinstance(result, int) else 0


def _traceback_if_debug() -> None:
    """Under `rio --debug`: the traceback of the exception being handled, on stderr."""
    from rio.errors import debug

    if debug():
        import traceback

        traceback.print_exc()


def _interrupted() -> int:
    from rio.cli.output import error

    error("interrupted")
    return EXIT_INTERRUPTED


def _help_hint(e: Any) -> str:
    """Where a usage error can be read about: ` (see 'rio teleop --help')`."""
    ctx = getattr(e, "ctx", None)
    return f" (see '{ctx.command_path} --help')" if ctx is not None else ""


def _version(value: bool) -> None:
    if value:
        from rio import __version__

        typer.echo(f"rio {__version__}")
        raise typer.Exit()


def _debug(value: bool) -> None:
    # in the environment, so that what the command starts (node processes) shows tracebacks as well
    if value:
        os.environ["RIO_DEBUG"] = "1"


def build_app(load_plugins: bool = True) -> typer.Typer:
    from rio.cli import (
        bench_cmd,
        cameras_cmd,
        datasets_cmd,
        doctor_cmd,
        drivers_cmd,
        export_cmd,
        keys_cmd,
        new_cmd,
        plugins_cmd,
        ports_cmd,
        serve_cmd,
        stations_cmd,
        top_cmd,
    )
    from rio.plugins.registry import Registry, get_registry

    app = typer.Typer(name="rio", help="RIO: real-time robot I/O for robot learning.", cls=RioGroup,
                      no_args_is_help=True, add_completion=True, rich_markup_mode="rich",
                      pretty_exceptions_enable=False)

    @app.callback()
    def root(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                                   help="Print the version and exit.")] = False,
             debug: Annotated[bool, typer.Option("--debug", callback=_debug, is_eager=True,
                                                 help="Show full tracebacks (also: RIO_DEBUG=1).")] = False) -> None:
        """RIO: real-time robot I/O for robot learning."""

    app.add_typer(plugins_cmd.app, name="plugins")
    app.add_typer(drivers_cmd.app, name="drivers")
    app.add_typer(stations_cmd.app, name="stations")
    app.add_typer(cameras_cmd.app, name="cameras")
    app.add_typer(new_cmd.app, name="new")
    app.add_typer(bench_cmd.app, name="bench")
    app.command("doctor")(doctor_cmd.doctor)
    app.add_typer(datasets_cmd.app, name="datasets")
    app.command("export")(export_cmd.export)
    app.command("serve")(serve_cmd.serve)
    app.command("top")(top_cmd.top)
    app.add_typer(keys_cmd.app, name="keys")
    app.command("ports")(ports_cmd.ports)
    app.command("find-port")(ports_cmd.find_port)
    registry = get_registry() if load_plugins else Registry(load_entry_points=False)
    registry.add_workflows(app)  # teleop, deploy, replay, run and those of plugins: the rio_workflows hook
    if load_plugins:
        registry.extend_cli(app)
    return app
