"""Assembles the root typer app: built-in command groups, then whatever plugins add."""

from __future__ import annotations

from typing import Annotated

import typer


def _version(value: bool) -> None:
    if value:
        from .. import __version__

        typer.echo(f"rio {__version__}")
        raise typer.Exit()


def build_app(load_plugins: bool = True) -> typer.Typer:
    from ..teleop import command as teleop_cmd
    from . import (
        bench_cmd,
        cameras_cmd,
        datasets_cmd,
        deploy_cmd,
        doctor_cmd,
        drivers_cmd,
        export_cmd,
        new_cmd,
        plugins_cmd,
        replay_cmd,
        run_cmd,
        stations_cmd,
        top_cmd,
    )

    app = typer.Typer(name="rio", help="RIO: real-time robot I/O for robot learning.",
                      no_args_is_help=True, add_completion=False, rich_markup_mode="rich",
                      pretty_exceptions_enable=False)

    @app.callback()
    def root(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                                   help="Print the version and exit.")] = False) -> None:
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
    app.command("replay")(replay_cmd.replay)
    app.command("teleop")(teleop_cmd.teleop)
    app.command("deploy")(deploy_cmd.deploy)
    app.command("run")(run_cmd.run)
    app.command("top")(top_cmd.top)
    if load_plugins:
        from ..plugins import get_registry

        get_registry().extend_cli(app)
    return app
