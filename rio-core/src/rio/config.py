"""Driver config models and readable validation errors.

A driver's config model is a pydantic model whose fields are its node's constructor keyword
arguments: the station file's `[components.<role>]` table (less `driver`) is validated by it, and the
validated values are what `serve(NodeCls, mw, **values)` receives. Subclass `DriverConfig` so
unknown keys are errors (a typo in a station file must not be silently ignored).
"""

from __future__ import annotations

import inspect
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError, create_model

from .suggest import closest


class DriverConfig(BaseModel):
    """Base class of driver (and policy) config models: unknown fields are rejected."""

    model_config = ConfigDict(extra="forbid")


def model_from_signature(cls: type) -> type[BaseModel]:
    """A config model derived from `cls.__init__`'s keyword arguments, for drivers registered
    without one (their annotations and defaults become the fields)."""
    fields: dict[str, Any] = {}
    for p in list(inspect.signature(cls.__init__).parameters.values())[1:]:
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        ann = Any if p.annotation is inspect.Parameter.empty or isinstance(p.annotation, str) else p.annotation
        fields[p.name] = (ann, ... if p.default is inspect.Parameter.empty else p.default)
    return create_model(f"{cls.__name__}Config", __base__=DriverConfig, **fields)


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
