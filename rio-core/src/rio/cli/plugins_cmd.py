"""`rio plugins list|install|uninstall`: each plugin, its version and what it provides, plus any plugin
problems; installing and removing plugins in the environment `rio` itself runs in (like `llm install`)."""

from __future__ import annotations

from typing import Annotated

import typer

app = typer.Typer(help="Installed RIO plugins.", no_args_is_help=True)


def _show_plugins(as_json: bool = False) -> None:
    from rio.cli.output import print_json, table, warn_problems
    from rio.plugins import get_registry

    reg = get_registry()
    reg.all_specs()  # fills each plugin's `provides` and collects problems
    plugins = list(reg.plugins.values())
    if as_json:
        print_json({
            "plugins": [{"name": p.name, "distribution": p.dist, "version": p.version, "module": p.module,
                         "provides": p.provides} for p in plugins],
            "problems": [{"plugin": x.plugin, "message": x.message} for x in reg.problems],
        })
        return
    rows = []
    for p in plugins:
        provides = "; ".join(f"{kind}: {', '.join(names)}" for kind, names in sorted(p.provides.items())) or "-"
        rows.append((p.dist, p.version, provides))
    table("RIO plugins", ("plugin", "version", "provides"), rows)
    warn_problems(reg)


@app.command("list")
def list_plugins(as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """List plugins (the `rio` entry-point group; RIO_LOAD_PLUGINS=a,b loads only those)."""
    _show_plugins(as_json)


def _run_installer(cmd: list[str]) -> None:
    """Run `cmd`, its output going straight to the terminal; its failure is this command's failure."""
    import shlex
    import subprocess

    from rich.markup import escape

    from rio.cli.output import console, error

    console(stderr=True).print(f"[dim]$ {escape(shlex.join(cmd))}[/]", soft_wrap=True)
    try:
        rc = subprocess.call(cmd)
    except OSError as e:
        error(f"cannot run {cmd[0]}: {e}")
        raise typer.Exit(1) from None
    if rc != 0:
        head = next((cmd[:i + 1] for i, a in enumerate(cmd) if a in ("install", "uninstall")), cmd[:1])
        error(f"{shlex.join(head)} failed with exit status {rc} (its message is above)")
        raise typer.Exit(rc)


def _installer() -> tuple[str, str | None]:
    """This environment's python and uv (None: use pip); a clear error if there is neither."""
    import importlib.util
    import shutil
    import sys

    from rio.errors import RioError

    uv = shutil.which("uv")
    if uv is None and importlib.util.find_spec("pip") is None:
        raise RioError(f"neither uv (on PATH) nor pip (in {sys.prefix}) is available to install with: "
                       f"install uv (https://docs.astral.sh/uv/) or run '{sys.executable} -m ensurepip'")
    return sys.executable, uv


def _after_change(before: set[str]) -> None:
    from rio.plugins import registry as plugins
    from rio.plugins.install import activate_new_paths

    activate_new_paths(before)
    plugins.reset()
    _show_plugins()


@app.command("install")
def install(
    specs: Annotated[list[str], typer.Argument(help="Requirements, paths or URLs, as pip takes them.",
                                               metavar="SPEC", show_default=False)],
    editable: Annotated[bool, typer.Option("-e", "--editable",
                                           help="Install the given local project folders in editable mode.")] = False,
    upgrade: Annotated[bool, typer.Option("-U", "--upgrade", help="Upgrade the given packages.")] = False,
) -> None:
    """Install plugins into the environment rio runs in (with uv if on PATH, else pip).

    Examples: rio plugins install rio-acme; rio plugins install -e ./rio-acme
    """
    import sys

    from rio.cli.output import warn
    from rio.plugins.install import install_command, pth_files, uv_project_of

    python, uv = _installer()
    before = pth_files()
    _run_installer(install_command(specs, editable, upgrade, python=python, uv_path=uv))
    _after_change(before)
    project = uv_project_of(sys.prefix)
    if project is not None:
        warn(f"this environment belongs to the uv project {project}: a plain 'uv sync' there removes what "
             "was installed here; use 'uv sync --inexact' (uv run keeps it) or run this command again")


@app.command("uninstall")
def uninstall(
    names: Annotated[list[str], typer.Argument(help="Distribution names, as `rio plugins list` shows them.",
                                               metavar="NAME", show_default=False)],
    yes: Annotated[bool, typer.Option("-y", "--yes", help="Do not ask for confirmation.")] = False,
) -> None:
    """Uninstall plugins from the environment rio runs in (rio-core itself is refused)."""
    import sys

    from rio.errors import RioError
    from rio.plugins.install import protected, pth_files, uninstall_command

    refused = protected(names)
    if refused:
        raise RioError(f"refusing to uninstall {', '.join(refused)}: it is RIO itself (the `rio` command); "
                       f"remove it with your installer if you mean it ('{sys.executable} -m pip uninstall rio-core' "
                       "or 'uv pip uninstall rio-core')")
    python, uv = _installer()
    if not yes:
        typer.confirm(f"Uninstall {', '.join(names)} from {sys.prefix}?", abort=True)
    before = pth_files()
    _run_installer(uninstall_command(names, python=python, uv_path=uv))
    _after_change(before)
