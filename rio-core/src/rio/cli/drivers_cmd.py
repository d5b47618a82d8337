"""`rio drivers list [--kind arm]`: registered drivers and policies, without importing any of them."""

from __future__ import annotations

from typing import Annotated

import typer

from rio.cli.args import not_empty

app = typer.Typer(help="Registered device drivers and policies.", no_args_is_help=True)


@app.command("list")
def list_drivers(
    kind: Annotated[str | None, typer.Option("--kind", "-k", callback=not_empty,
                                             help="Only this kind (arm, camera, ...).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """List drivers (and policies) by name, kind and plugin."""
    from rio.cli.output import print_json, table, warn_problems
    from rio.errors import ConfigError
    from rio.plugins import get_registry
    from rio.plugins.specs import DRIVER_KINDS
    from rio.suggest import unknown

    kinds = (*DRIVER_KINDS, "policy")
    if kind is not None and kind not in kinds:
        raise ConfigError(unknown("kind", kind, kinds))
    reg = get_registry()
    specs = [s for s in reg.specs("rio_drivers") + reg.specs("rio_policies") if kind in (None, s.kind)]
    if as_json:
        print_json([{"name": s.name, "kind": s.kind, "plugin": s.plugin, "target": s.target,
                     "description": s.description} for s in specs])
        return
    rows = [(s.name, s.kind, s.plugin, s.description) for s in sorted(specs, key=lambda s: (s.kind, s.name))]
    title = "RIO policies" if kind == "policy" else f"RIO {kind or 'driver'}s"
    table(title, ("name", "kind", "plugin", "description"), rows)
    warn_problems(reg)


@app.command("show")
def show(name: Annotated[str, typer.Argument(callback=not_empty,
                                             help="Registered driver or policy name, e.g. rio.fake_arm.")],
         as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """The station-file fields a driver accepts (its class's `Config`): name, type, default, description.
    Imports the driver's module (not its SDK: drivers import that in `open()`)."""
    from pydantic_core import PydanticUndefined

    from rio.cli.output import console, print_json, table
    from rio.errors import ConfigError
    from rio.plugins import get_registry
    from rio.suggest import unknown

    reg = get_registry()
    specs = {s.name: s for s in reg.specs("rio_drivers") + reg.specs("rio_policies")}
    if name not in specs:
        raise ConfigError(unknown("driver", name, specs))
    spec = specs[name]
    model = spec.config_model()
    rows = []
    for field, info in model.model_fields.items():
        if field in spec.preset:
            default = f"{spec.preset[field]!r} (fixed by {spec.name})"
        elif info.default_factory is not None:
            default = repr(info.default_factory())
        else:
            default = "(required)" if info.default is PydanticUndefined else repr(info.default)
        ann = info.annotation
        type_name = ann.__name__ if isinstance(ann, type) else str(ann).replace("typing.", "")
        rows.append((field, type_name, default, info.description or ""))
    if as_json:
        print_json({"name": spec.name, "kind": spec.kind, "plugin": spec.plugin, "description": spec.description,
                    "target": spec.target, "fields": [dict(zip(("field", "type", "default", "description"), r,
                                                               strict=True)) for r in rows]})
        return
    console().print(f"{spec.name} ({spec.kind}, plugin {spec.plugin}): {spec.description}\n"
                    f"node: {spec.target}", markup=False)
    table(f"[components.<role>] fields (driver = \"{spec.name}\")", ("field", "type", "default", "description"), rows)
