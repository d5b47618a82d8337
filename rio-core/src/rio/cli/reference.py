"""The command-line reference as Markdown, made from the `rio` command itself (every command, its usage,
arguments and options with their help and defaults), so the docs page can never describe a command that
changed: the docs build writes it (docs/_hooks.py), and `python -m rio.cli.reference` prints it."""

from __future__ import annotations

from typing import Any


def _params(command: Any, ctx: Any) -> list[str]:
    rows = []
    for p in command.get_params(ctx):
        if getattr(p, "hidden", False) or p.name == "help":
            continue
        if p.param_type_name == "argument":
            name = f"`{(p.metavar or p.name).upper()}`"
        else:
            name = ", ".join(f"`{o}`" for o in [*p.opts, *p.secondary_opts])
            if not p.is_flag:
                shown = p.metavar or (p.display_type_rich(ctx) if hasattr(p, "display_type_rich") else None) or "VALUE"
                name += f" `{shown.strip('<>').upper()}`"
        help_text = " ".join((getattr(p, "help", None) or "").split()).replace("|", "\\|")
        default = p.default if p.param_type_name == "option" else None
        if default not in (None, False, (), []) and not callable(default) and p.show_default is not False:
            help_text += f" (default: `{default}`)"
        if p.required:
            help_text += " (required)"
        rows.append(f"| {name} | {help_text} |")
    return rows


def _command(command: Any, path: list[str], parent: Any, out: list[str]) -> None:
    ctx = command.context_class(command, info_name=path[-1], parent=parent)  # typer's own click, not click's
    if hasattr(command, "list_commands"):
        for name in command.list_commands(ctx):
            sub = command.get_command(ctx, name)
            if sub is not None and not sub.hidden:
                _command(sub, [*path, name], ctx, out)
        return
    out += [f"## `{' '.join(path)}`", ""]
    for paragraph in (command.help or "").split("\n\n")[:3]:
        if paragraph.strip():
            out += [" ".join(paragraph.split()), ""]
    pieces = command.collect_usage_pieces(ctx)
    out += ["```", f"{' '.join(path)} {' '.join(pieces)}".rstrip(), "```", ""]
    rows = _params(command, ctx)
    if rows:
        out += ["| argument or option | what it does |", "|---|---|", *rows, ""]


def reference() -> str:
    """The reference page (the commands of the core and of the plugins installed here)."""
    import typer

    from rio.cli.app import _tidy_help, build_app

    root = typer.main.get_command(build_app())
    _tidy_help(root)
    out = ["# Command reference", "",
           "Every `rio` command with its arguments and options, generated from the command itself (the plugins "
           "installed where the docs were built add theirs). `rio COMMAND --help` prints the same in a terminal; "
           "the conventions all commands share are on [The rio command line](cli.md).", ""]
    _command(root, ["rio"], None, out)
    return "\n".join(out).rstrip() + "\n"


if __name__ == "__main__":  # pragma: no cover
    print(reference(), end="")
