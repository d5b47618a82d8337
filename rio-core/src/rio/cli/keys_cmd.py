"""`rio keys generate|add|show`: the keys of a station whose nodes run on several machines (`rio.machine.keys`).

`generate DIR --name robot --name workstation` makes a station CA and one directory per machine;
copy `DIR/<machine>` to that machine (same path on each, e.g. `~/.config/rio/keys/lab`) and name it in
the station file: `[middleware] keys = "~/.config/rio/keys/lab"`."""

from __future__ import annotations

from typing import Annotated

import typer

from rio.cli.args import not_empty, output_dir

app = typer.Typer(help="Keys that authenticate and encrypt a station's links between machines.",
                  no_args_is_help=True)

_NAMES = typer.Option("--name", "-n", help="A machine of the station (repeat: --name robot --name workstation).")
_ADDRESSES = typer.Option("--address", "-a", help="NAME=HOST: an address the machine is reached at, written into its "
                                                  "certificate (repeat; optional: machines are authenticated by "
                                                  "the station CA, not by address).")


def _addresses(items: list[str] | None, names: list[str]) -> dict[str, list[str]]:
    """`--address NAME=HOST` values, each checked (a machine named, an IP address or host name) before
    anything is written."""
    from rio.machine.keys import address_problem

    out: dict[str, list[str]] = {}
    for item in items or []:
        name, sep, host = item.partition("=")
        if not sep or not host or name not in names:
            raise typer.BadParameter(f"'{item}': expected NAME=HOST with NAME one of {', '.join(names)}",
                                     param_hint="--address")
        if (why := address_problem(host)) is not None:
            raise typer.BadParameter(f"'{item}': {why}", param_hint="--address")
        out.setdefault(name, []).append(host)
    return out


def _days(value: int) -> int:
    """A certificate's validity: 1 to `rio.machine.keys.MAX_DAYS` days."""
    from rio.machine.keys import MAX_DAYS

    if not 1 <= value <= MAX_DAYS:
        raise typer.BadParameter(f"must be a number of days from 1 to {MAX_DAYS}, not {value}")
    return value


def _cryptography() -> None:
    try:
        import cryptography  # noqa: F401
    except ImportError:
        from rio.errors import ConfigError

        raise ConfigError("making keys needs the cryptography package: pip install 'rio-core[keys]'") from None


@app.command("generate")
def generate(
    out: Annotated[str, typer.Argument(callback=output_dir, help="Directory to create (holds the CA and one "
                                                                 "directory per machine).")],
    names: Annotated[list[str], _NAMES],
    addresses: Annotated[list[str] | None, _ADDRESSES] = None,
    days: Annotated[int, typer.Option(callback=_days, help="Validity of the certificates in days (up to 36500).")]
    = 3650,
) -> None:
    """A new station CA and keys for each named machine."""
    from rio.machine import keys

    _cryptography()
    made = keys.generate(out, names, _addresses(addresses, names), days)
    _report(out, made)


@app.command("add")
def add(
    out: Annotated[str, typer.Argument(callback=not_empty, help="A directory made by `rio keys generate`.")],
    names: Annotated[list[str], _NAMES],
    addresses: Annotated[list[str] | None, _ADDRESSES] = None,
    days: Annotated[int, typer.Option(callback=_days, help="Validity of the certificates in days (up to 36500).")]
    = 3650,
) -> None:
    """Keys for more machines, signed by the same CA; every machine's peers/ learns them."""
    from rio.machine import keys

    _cryptography()
    made = keys.add(out, names, _addresses(addresses, names), days)
    _report(out, made)
    typer.echo("copy every machine's directory out again: their peers/ now trust the new machines")


@app.command("show")
def show(path: Annotated[str, typer.Argument(callback=not_empty, help="One machine's keys directory.")],
         as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """Whose keys these are, which machines they trust, and when the certificate expires."""
    from rio.machine import keys

    k = keys.load(path)
    expires = None
    try:
        from cryptography import x509

        expires = f"{x509.load_pem_x509_certificate(k.tls_cert.read_bytes()).not_valid_after_utc:%Y-%m-%d}"
    except ImportError:
        pass
    if as_json:
        from rio.cli.output import print_json

        print_json({"machine": k.identity, "trusts": sorted(k.peers), "expires": expires})
        return
    typer.echo(f"machine:  {k.identity}")
    typer.echo(f"trusts:   {', '.join(sorted(k.peers))}")
    if expires is not None:
        typer.echo(f"expires:  {expires}")


def _report(out: str, made: list) -> None:
    for d in made:
        typer.echo(f"{d}  ->  copy to machine '{d.name}'")
    typer.echo(f"the CA's private key stays in {out}/ca (needed only to add machines); in the station file:\n"
               f'  [middleware]\n  keys = "<where each machine keeps its directory>"')
