"""One config convention for every component: drivers, policies, middlewares, embodiments, dataset formats.

A component class declares its pydantic `Config` once, as a nested class (or a class attribute). Its
defaults, descriptions and constraints live only there: the station file's table is validated by it,
`rio drivers show` documents it, and the component receives the validated object as `self.config`.

    class AcmeArm(ArmNode):
        class Config(ArmNode.Config):
            port: str = Field(description="serial port")

        def setup(self):            # runs once, where the component runs
            self.port = self.config.port

A component is built from a config object or from fields (`AcmeArm(port="/dev/ttyUSB0")`, what
`serve(AcmeArm, mw, port=...)` and station files do); both go through `Configurable.__init__`, so there is
no constructor signature to keep in sync with the model. A plugin registers a variant of a component
as a spec carrying preset field values (`Spec(..., preset={"model": "so101"})`), not as a subclass.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError

from rio.suggest import closest


class Config(BaseModel):
    """Base of every component's config model: unknown fields are errors (a typo in a station file must
    not be silently ignored), and every number is finite: `inf` or `nan` in a station file (TOML has both)
    would pass any `gt=`/`le=` bound one way or another (nan compares false to everything) and quietly
    switch off what the number limits (`max_step_rad = inf`, `joint_limits = [[nan, 1]]`,
    `call_timeout = inf`); refused, naming the field."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


def validate_config(model: type[BaseModel], config: Any = None, fields: Mapping[str, Any] | None = None) -> Any:
    """`config` (an instance of `model`, of a parent model, or a dict) with `fields` applied on top,
    validated by `model`. Raises pydantic's ValidationError naming each bad field."""
    if isinstance(config, model) and not fields:
        return config
    base = config.model_dump() if isinstance(config, BaseModel) else dict(config or {})
    return model.model_validate({**base, **(fields or {})})


class Configurable:
    """Mixin: `Cls(config=None, /, **fields)` validates into `self.config` (an instance of `Cls.Config`),
    then calls `setup()`, where a component derives what it needs from its config (cheaply: tools such as
    `rio drivers show` build components too). Components override `setup()`, never `__init__`."""

    Config = Config
    config: Any

    def __init__(self, config: Any = None, /, **fields: Any):
        self.config = validate_config(type(self).Config, config, fields)
        self.setup()

    def setup(self) -> None:
        """Derive state from `self.config`. No hardware, no heavy imports, no network."""


def apply_preset(preset: Mapping[str, Any], fields: Mapping[str, Any], owner: str) -> dict[str, Any]:
    """Station fields over a spec's preset values. A preset is what makes the variant (SO-101 is the SO-100
    driver with `model = "so101"`), so a field that contradicts it is an error rather than a silent override."""
    for key, value in fields.items():
        if key in preset and preset[key] != value:
            raise ValueError(f"{key}: '{owner}' fixes it to {preset[key]!r} (got {value!r}); "
                             "use the driver registered for that variant instead")
    return {**preset, **fields}


def error_lines(exc: ValidationError, prefix: str, model: type[BaseModel] | None = None) -> list[str]:
    """One line per problem, each starting with the field's full path (`components.arm.port: ...`)."""
    allowed = sorted(model.model_fields) if model is not None else []
    lines = []
    for err in exc.errors():
        loc = ".".join(str(p) for p in err["loc"])
        path = f"{prefix}.{loc}" if prefix and loc else (prefix or loc)
        if err["type"] == "extra_forbidden":
            field = str(err["loc"][-1])
            best = closest(field, allowed) if len(err["loc"]) == 1 else None
            hint = f"; did you mean '{best}'?" if best else ""
            known = f" (allowed: {', '.join(allowed)})" if allowed and len(err["loc"]) == 1 else ""
            lines.append(f"{path}: unknown field{hint}{known}")
        elif err["type"] == "missing":
            lines.append(f"{path}: required field missing")
        else:
            lines.append(f"{path}: {err['msg']} (got {err.get('input')!r:.80})")
    return lines
