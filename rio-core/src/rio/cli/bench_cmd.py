"""`rio bench ...`: thin front doors to the benchmark modules in `rio.benchmarks`, which parse their
own arguments (everything after the subcommand is passed through untouched)."""

from __future__ import annotations

import typer

app = typer.Typer(help="Benchmarks that print figures.", no_args_is_help=True)

_PASS_THROUGH = {"allow_extra_args": True, "ignore_unknown_options": True, "help_option_names": []}


@app.command("middleware", context_settings=_PASS_THROUGH, add_help_option=False)
def middleware(ctx: typer.Context) -> None:
    """Middleware latency (the paper's method); `rio bench middleware --help` lists its options."""
    from rio.benchmarks.middleware_latency import main as bench_main

    raise typer.Exit(bench_main(list(ctx.args)) or 0)
