"""Every registered driver reads like its hardware: its class is its kind plus its own code, and the
settings every network device or serial bus has come from the one core model of each.

A driver class is at most 6 classes deep (`object` included): the driver, its kind's chain (`ArmNode`,
`JointNode`, `CommandedNode`, `Node`) and `object`, or one shared vendor class in place of a shorter kind's
link. Faults, dropped links, damping, model tables and grab threads are parts a node holds, not classes to
inherit (docs/drivers.md). Drivers whose module imports a vendor SDK that is not installed are skipped,
named."""

from __future__ import annotations

import pytest

from rio.interfaces import NetworkDevice, ServoBus
from rio.plugins import get_registry

#: The most classes a driver's method resolution order may have, `object` included.
MAX_MRO = 6
DEVICE_KINDS = ("arm", "gripper", "hand", "humanoid", "teleop")


def _drivers() -> tuple[list[tuple[str, str, type]], list[str]]:
    """(name, kind, class) of every registered driver that imports, and why the others do not."""
    loaded, skipped = [], []
    for spec in get_registry().specs("rio_drivers"):
        try:
            loaded.append((spec.name, spec.kind, spec.load()))
        except ImportError as e:  # an optional vendor SDK imported at the top of the driver's module
            skipped.append(f"{spec.name}: {type(e).__name__}: {e}")
    return loaded, skipped


def test_no_driver_class_is_more_than_six_classes_deep():
    loaded, skipped = _drivers()
    if skipped:
        print("skipped (their SDK is not installed):\n  " + "\n  ".join(skipped))
    assert len(loaded) > 20, f"only {len(loaded)} drivers could be loaded: {skipped}"
    offenders = [f"{name} ({cls.__module__}.{cls.__qualname__}): {len(cls.__mro__)} classes: "
                 + " > ".join(k.__name__ for k in cls.__mro__)
                 for name, _, cls in loaded if len(cls.__mro__) > MAX_MRO]
    print(f"{len(loaded)} drivers, deepest {max(len(cls.__mro__) for _, _, cls in loaded)} classes")
    if offenders:
        print("more than", MAX_MRO, "classes:\n  " + "\n  ".join(offenders))
    assert not offenders, "drivers more than 6 classes deep:\n" + "\n".join(offenders)


@pytest.mark.parametrize(("field", "model"), [("ip", NetworkDevice), ("connect_timeout_s", NetworkDevice),
                                              ("baudrate", ServoBus)])
def test_device_settings_come_from_the_core_models(field, model):
    """A device driver with an `ip`, a `connect_timeout_s` or a `baudrate` has it from `NetworkDevice` or
    `ServoBus` (a driver may widen a field's type, as the URCap's host names, but not redeclare the model)."""
    loaded, _ = _drivers()
    config_models = {name: cls.Config for name, kind, cls in loaded if kind in DEVICE_KINDS}
    have = {name: c for name, c in config_models.items() if field in c.model_fields}
    assert have, f"no device driver has a '{field}' field"
    # devices on DDS topics wait for their first state instead of connecting: theirs is the damping config's
    dds = {name for name, c in have.items() if field == "connect_timeout_s" and "domain_id" in c.model_fields}
    strays = sorted(name for name, c in have.items() if not issubclass(c, model) and name not in dds)
    assert not strays, f"'{field}' declared outside {model.__name__} by: {', '.join(strays)}"
