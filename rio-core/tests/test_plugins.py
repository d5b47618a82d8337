"""Plugin loading: specs from hooks, entry points, broken plugins skipped and named, RIO_LOAD_PLUGINS."""

from __future__ import annotations

import sys
import types

import pytest

from rio.errors import ConfigError
from rio.plugins import Registry
from rio.plugins import registry as plugins
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec
from rio.testing import write_plugin_dist

GOOD = '''
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec

@hookimpl
def rio_drivers():
    return [Spec("acme.arm", "arm", "tp_good_driver:AcmeArm", "an arm")]

@hookimpl
def rio_stations():
    return [Spec("acme-station", "station", "/nonexistent/acme.toml", "a station")]
'''
BROKEN_IMPORT = "import tp_vendor_sdk_that_is_not_installed\n"
BAD_SPECS = '''
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec

@hookimpl
def rio_drivers():
    return [
        Spec("ok.gripper", "gripper", "x.y:Z"),
        Spec("rio.fake_arm", "arm", "tp_bad:Hijack"),       # name taken by rio-core
        Spec("wrong.kind", "policy", "x.y:Z"),               # a policy returned from rio_drivers
        Spec("bad.target", "arm", "not an import path"),
        "not a spec",
    ]

@hookimpl
def rio_policies():
    raise RuntimeError("policy registry exploded")

@hookimpl
def rio_driver():  # typo of a hook name
    return []
'''


@pytest.fixture(scope="module")
def dists(tmp_path_factory):
    root = tmp_path_factory.mktemp("dists")
    write_plugin_dist(root, "tp-good", "1.2.3", {"tp_good": GOOD}, {"tp-good": "tp_good"})
    write_plugin_dist(root, "tp-broken", "0.1", {"tp_broken": BROKEN_IMPORT}, {"tp-broken": "tp_broken"})
    write_plugin_dist(root, "tp-bad", "0.2", {"tp_bad": BAD_SPECS}, {"tp-bad": "tp_bad"})
    sys.path.insert(0, str(root))
    yield root
    sys.path.remove(str(root))
    for m in ("tp_good", "tp_broken", "tp_bad"):
        sys.modules.pop(m, None)


def names(reg: Registry, hook: str) -> set[str]:
    return {s.name for s in reg.specs(hook)}


def problems_of(reg: Registry, plugin: str) -> list[str]:
    return [p.message for p in reg.problems if p.plugin == plugin]


def test_core_registers_middlewares_embodiments_and_fakes():
    reg = Registry(load_entry_points=False)
    assert {"thread", "shm", "zmq", "zenoh", "portal"} <= names(reg, "rio_middlewares")
    assert names(reg, "rio_embodiments") == {"single_arm", "bimanual", "humanoid", "mobile_manipulator"}
    assert {"rio.fake_arm", "rio.fake_gripper", "rio.fake_camera", "rio.fake_base"} <= names(reg, "rio_drivers")
    assert all(s.plugin == "rio-core" for s in reg.all_specs())
    assert reg.problems == []


def test_entry_points_load_and_broken_plugins_are_skipped_by_name(dists):
    reg = Registry(only=None)
    assert {"rio-core", "tp-good", "tp-bad"} <= set(reg.plugins)
    assert reg.plugins["tp-good"].version == "1.2.3"
    assert "tp-broken" not in reg.plugins
    (imp,) = problems_of(reg, "tp-broken")
    assert "cannot import tp_broken" in imp and "ModuleNotFoundError" in imp

    drivers = {s.name: s for s in reg.specs("rio_drivers")}
    assert drivers["acme.arm"].plugin == "tp-good"
    assert drivers["ok.gripper"].plugin == "tp-bad"  # the valid spec of a partly bad plugin is kept
    assert drivers["rio.fake_arm"].plugin == "rio-core"  # a duplicate never replaces the first
    assert "wrong.kind" not in drivers and "bad.target" not in drivers
    assert [s for s in reg.specs("rio_policies") if s.plugin == "tp-bad"] == []

    bad = " | ".join(problems_of(reg, "tp-bad"))
    assert "arm 'rio.fake_arm' is already provided by 'rio-core'" in bad
    assert "'policy' spec 'wrong.kind' is not allowed here" in bad
    assert "'not an import path' is not an import path" in bad
    assert "returned str" in bad
    assert "hook rio_policies raised RuntimeError: policy registry exploded" in bad
    assert "unknown hook 'rio_driver' (did you mean 'rio_drivers'?)" in bad
    reg.all_specs()  # `provides` is filled as hooks are called
    assert reg.plugins["tp-good"].provides == {"arm": ["acme.arm"], "station": ["acme-station"]}


def test_rio_load_plugins_selects_by_entry_point_or_dist_name(dists, monkeypatch):
    monkeypatch.setenv("RIO_LOAD_PLUGINS", "tp_good, nosuch")
    plugins.reset()
    try:
        reg = plugins.get_registry()
        assert set(reg.plugins) == {"rio-core", "tp-good"}
        assert [p.plugin for p in reg.problems] == ["nosuch"]  # tp-broken was never imported
        assert "acme.arm" in names(reg, "rio_drivers")
    finally:
        plugins.reset()


def test_rio_load_plugins_empty_loads_only_core(dists, monkeypatch):
    monkeypatch.setenv("RIO_LOAD_PLUGINS", "")
    plugins.reset()
    try:
        assert set(plugins.get_registry().plugins) == {"rio-core"}
    finally:
        plugins.reset()


def test_register_module_directly_and_invalid_plugin():
    reg = Registry(load_entry_points=False)
    mod = types.ModuleType("inline_plugin")

    @hookimpl
    def rio_embodiments():
        return [Spec("acme_mobile", "embodiment", "somewhere:Mobile")]

    mod.rio_embodiments = rio_embodiments
    assert reg.register(mod, name="inline", dist="rio-inline", version="9")
    assert "acme_mobile" in names(reg, "rio_embodiments")

    bad = types.ModuleType("bad_plugin")

    @hookimpl
    def rio_drivers(unexpected_argument):
        return []

    bad.rio_drivers = rio_drivers
    assert not reg.register(bad, name="bad")
    assert "invalid plugin" in problems_of(reg, "bad")[0]


def test_find_unknown_middleware_suggests_closest():
    reg = Registry(load_entry_points=False)
    with pytest.raises(ConfigError, match=r"unknown middleware 'thred'; did you mean 'thread'\? registered: "):
        reg.find("rio_middlewares", "thred", "middleware")
    assert reg.find("rio_middlewares", "thread").target == "rio.middleware.thread:ThreadMiddleware"
