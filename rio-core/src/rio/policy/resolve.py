"""Which policy to deploy: `--policy SPEC`, or the station's own `[components.policy]`.

SPEC is one of
- a registered policy name plus comma-separated fields: `openpi.remote,host=gpu1,port=8000`
  (values are read as JSON when they parse: numbers, booleans, lists; otherwise as text);
- an import path of a `PolicyNode` subclass, with the same fields: `rio.policy.testing:SleepPolicyNode,forward_s=0.086`;
- a .toml file with a `[policy]` table written like a station's policy component (`driver = ...`).

Fields are validated by the policy's config model, with the same error lines as a station file.
"""

from __future__ import annotations

import json
import os
from typing import Any

from pydantic import ValidationError

from rio.config import apply_preset, error_lines
from rio.errors import ConfigError
from rio.plugins.specs import import_path
from rio.policy.node import PolicyNode


def _top_level_commas(text: str) -> list[str]:
    """`text` split at the commas outside brackets and quotes, so a value may be a JSON list or object
    (`command=[0.3,0,0]`)."""
    parts, depth, quote, start = [], 0, "", 0
    for i, ch in enumerate(text):
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth = max(depth - 1, 0)
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def parse_policy_arg(text: str) -> tuple[str, dict[str, Any]]:
    """'name,k=v,...' -> (name, {k: v}); a .toml path -> its [policy] table's driver and fields."""
    if text.endswith(".toml") and os.path.isfile(text):
        from rio.toml import read_toml

        table = dict(read_toml(text).get("policy") or {})
        if "driver" not in table:
            raise ConfigError(f"{text}: needs a [policy] table with a driver = \"...\" line")
        return str(table.pop("driver")), table
    name, *pairs = [p.strip() for p in _top_level_commas(text)]
    fields: dict[str, Any] = {}
    for pair in pairs:
        key, sep, raw = pair.partition("=")
        if not sep or not key:
            raise ConfigError(f"--policy {text!r}: '{pair}' is not key=value")
        try:
            fields[key.strip()] = json.loads(raw)
        except json.JSONDecodeError:
            fields[key.strip()] = raw
    return name, fields


def policy_node_class(name: str, registry: Any = None) -> tuple[type[PolicyNode], dict[str, Any]]:
    """(PolicyNode subclass, the preset values its registered name fixes) for a registered name or a
    'module:Class' path (no preset)."""
    preset: dict[str, Any] = {}
    if ":" in name:
        try:
            cls = import_path(name)
        except (ImportError, AttributeError) as e:
            raise ConfigError(f"policy '{name}' cannot be imported: {e}") from None
    else:
        from rio.plugins import get_registry

        spec = (registry or get_registry()).find("rio_policies", name, "policy")
        preset = spec.preset
        try:
            cls = spec.load()
        except ImportError as e:
            raise ConfigError(f"policy '{name}' (plugin {spec.plugin}) cannot be imported: {e}. "
                              "Is its optional dependency installed? (`rio doctor`)") from None
    if not (isinstance(cls, type) and issubclass(cls, PolicyNode)):
        raise ConfigError(f"policy '{name}' is {cls!r}, not a rio.policy.PolicyNode subclass")
    return cls, preset


def resolve_policy(ref: str | None, station: Any, registry: Any = None) -> tuple[str, type[PolicyNode], dict[str, Any]]:
    """(name, node class, validated constructor kwargs) of the policy to deploy on `station`."""
    if ref is None:
        comp = station.components.get("policy")
        if comp is None:
            raise ConfigError(f"station '{station.name}' has no [components.policy]; pass --policy SPEC")
        name, fields, where = comp.driver, comp.kwargs(), "components.policy"
    else:
        (name, fields), where = parse_policy_arg(ref), "--policy"
    cls, preset = policy_node_class(name, registry)
    model = cls.Config
    try:
        config = model.model_validate(apply_preset(preset, fields, name))
    except ValidationError as e:
        raise ConfigError(f"invalid policy '{name}':\n  " + "\n  ".join(error_lines(e, where, model))) from None
    except ValueError as e:  # a field contradicting the preset
        raise ConfigError(f"invalid policy '{name}':\n  {where}.{e}") from None
    return name, cls, config.model_dump()
