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
`serve(AcmeArm, mw, port=...)` and station files do); both go through `validate_config` (in
`Configurable.__init__`, or `Node.__init__` for nodes), so there is no constructor signature to keep in sync
with the model. A plugin registers a variant of a component
as a spec carrying preset field values (`Spec(..., preset={"model": "so101"})`), not as a subclass.

A model sets other defaults for fields it inherits in `defaults` (a vendor's rate over its kind's, a bus's
baud rate): each field keeps its type, constraints and description, so nothing is declared twice. A field
(or a value) renamed in a release keeps its old name working for one more release: the model lists it in
`renamed` / `renamed_values`, and a station file or a script using the old name is validated as if it had
used the new one, with one line in the log saying so.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator
from pydantic.fields import FieldInfo

from rio.suggest import closest

log = logging.getLogger("rio.config")


class Config(BaseModel):
    """Base of every component's config model: unknown fields are errors (a typo in a station file must
    not be silently ignored), and every number is finite: `inf` or `nan` in a station file (TOML has both)
    would pass any `gt=`/`le=` bound one way or another (nan compares false to everything) and quietly
    switch off what the number limits (`max_step_rad = inf`, `joint_limits = [[nan, 1]]`,
    `call_timeout = inf`); refused, naming the field."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    #: {field: default} for inherited fields, or {field: Field(default, <more constraints>)}: the field keeps
    #: its type, constraints and description (`class Config(ArmNode.Config): defaults = {"rate_hz": 250.0}`).
    defaults: ClassVar[Mapping[str, Any]] = {}
    #: {old field name: new field name}: renamed fields still accepted for one release (a class's entries
    #: add to its bases').
    renamed: ClassVar[Mapping[str, str]] = {}
    #: {field: {old value: new value}}: renamed values of a field, still accepted for one release.
    renamed_values: ClassVar[Mapping[str, Mapping[Any, Any]]] = {}

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        own = cls.__dict__.get("defaults")
        if own:
            for name, value in own.items():
                cls.__pydantic_fields__[name] = with_default(cls, name, value)
            cls.model_rebuild(force=True)

    @model_validator(mode="before")
    @classmethod
    def _accept_old_names(cls, data: Any) -> Any:
        return accept_renamed(cls, data)


def with_default(model: type[BaseModel], name: str, value: Any) -> FieldInfo:
    """Field `name` of `model` with the default `value` (or merged with `value`, a `Field(...)`)."""
    base = model.model_fields.get(name)
    if base is None:
        raise KeyError(f"{model.__qualname__}.defaults: it has no field '{name}' (fields: "
                       f"{', '.join(model.model_fields)})")
    if isinstance(value, FieldInfo):
        return FieldInfo.merge_field_infos(base, value)
    return FieldInfo.merge_field_infos(base, default=value)


_noticed: set[tuple[str, str]] = set()


def _notice(model: type, old: str, new: str) -> None:
    notice_renamed(model.__qualname__, old, new)


def notice_renamed(owner: str, old: str, new: str) -> None:
    """One line per process and rename: a station validated by a server, its client and a tool says it once.
    Also for old names outside a config model (a gripper request's key, an observation field a script reads)."""
    key = (owner, old)
    if key not in _noticed:
        _noticed.add(key)
        log.warning("%s: %s is now %s (the old name is accepted until the next release)", owner, old, new)


def accept_renamed(model: type, data: Any) -> Any:
    """`data` (a mapping of fields) with the old names and values `model` declares renamed (`Config.renamed`,
    `Config.renamed_values`, from every class of its MRO) turned into the new ones. Both names at once is an
    error naming both."""
    if not isinstance(data, Mapping):
        return data
    names: dict[str, str] = {}
    values: dict[str, Mapping[Any, Any]] = {}
    for klass in reversed(model.__mro__):
        names.update(klass.__dict__.get("renamed", {}))
        for field, table in klass.__dict__.get("renamed_values", {}).items():
            values[field] = {**values.get(field, {}), **table}
    if not names and not values:
        return data
    out = dict(data)
    for old, new in names.items():
        if old in out:
            if new in out:
                raise ValueError(f"{old} and {new} are one field ({old} is its old name): set {new} only")
            _notice(model, f"'{old}'", f"'{new}'")
            out[new] = out.pop(old)
    for field, table in values.items():
        value = out.get(field)
        if isinstance(value, (str, bool)) and value in table:  # (a flag that became a choice: True/False)
            _notice(model, f"{field} = {value!r}", repr(table[value]))
            out[field] = table[value]
    return out


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
