"""Plugin loading: the core's built-in plugin plus every distribution in the `rio` entry-point group.

A plugin is never allowed to crash `rio`: an entry point that fails to import, a hook that raises,
a malformed spec or a name already taken is recorded as a `Problem` naming the plugin, and skipped.
`rio plugins list` and `rio doctor` show those problems; everything else keeps working.

`RIO_LOAD_PLUGINS=a,b` loads only those plugins (entry-point or distribution names; an empty value
loads none but the core's), like datasette's DATASETTE_LOAD_PLUGINS: useful to bisect a bad plugin.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import pluggy

from rio.errors import ConfigError
from rio.plugins import builtin as builtin_plugin
from rio.plugins import hookspecs
from rio.plugins.known import missing_plugin_hint, normalize
from rio.plugins.requirements import Requirement, check_requirement
from rio.plugins.specs import HOOK_KINDS, Spec, check_spec
from rio.suggest import closest, unknown

if TYPE_CHECKING:
    from rio.runtime.transport import Middleware

GROUP = "rio"
CORE = "rio-core"
ENV_ONLY = "RIO_LOAD_PLUGINS"
#: Hooks that return something other than specs (so `specs()` does not handle them).
OTHER_HOOKS = frozenset({"rio_cli", "rio_requirements", "rio_camera_listers"})


@dataclass
class PluginInfo:
    """One loaded plugin: its name (the entry point's), distribution, version and what it provides."""

    name: str
    dist: str
    version: str
    module: str
    provides: dict[str, list[str]] = field(default_factory=dict)


@dataclass(frozen=True)
class Problem:
    """Why (part of) a plugin was skipped."""

    plugin: str
    message: str

    def __str__(self) -> str:
        return f"plugin '{self.plugin}': {self.message}"


def _core_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(CORE)
    except PackageNotFoundError:
        return "0.0.0+unknown"


class Registry:
    """The plugin manager plus validated, de-duplicated specs per hook (computed once, on demand)."""

    def __init__(self, *, load_entry_points: bool = True, only: str | None = None):
        self.pm = pluggy.PluginManager(GROUP)
        self.pm.add_hookspecs(hookspecs)
        self.plugins: dict[str, PluginInfo] = {}
        self.problems: list[Problem] = []
        self._specs: dict[str, list[Spec]] = {}
        self.register(builtin_plugin, name=CORE, dist=CORE, version=_core_version())
        if load_entry_points:
            self._load_entry_points(only)

    def report(self, problem: Problem) -> None:
        if problem not in self.problems:  # specs are recomputed after a late register(); report once
            self.problems.append(problem)

    # -- loading ------------------------------------------------------------------------------------
    def _load_entry_points(self, only: str | None) -> None:
        from importlib.metadata import entry_points

        wanted = None if only is None else {normalize(n.strip()) for n in only.split(",") if n.strip()}
        seen: set[str] = set()
        for ep in sorted(entry_points(group=GROUP), key=lambda e: e.name):
            dist = getattr(ep, "dist", None)
            dist_name = dist.name if dist is not None else ep.name
            if wanted is not None and not ({normalize(ep.name), normalize(dist_name)} & wanted):
                continue
            seen |= {normalize(ep.name), normalize(dist_name)}
            if ep.name in self.plugins:
                self.report(Problem(ep.name, f"entry point name already used by "
                                             f"'{self.plugins[ep.name].dist}'; skipped"))
                continue
            try:
                obj = ep.load()
            except (Exception, SystemExit) as e:  # anything a plugin's import raises, but Ctrl+C
                self.report(Problem(ep.name, f"cannot import {ep.value}: {type(e).__name__}: {e}"))
                continue
            self.register(obj, name=ep.name, dist=dist_name, version=dist.version if dist else "?")
        for name in sorted((wanted or set()) - seen):
            self.report(Problem(name, f"named in {ENV_ONLY} but no installed plugin has that name"))

    def register(self, obj: Any, *, name: str, dist: str | None = None, version: str = "?") -> bool:
        """Add a plugin object (module or instance with hookimpls). Returns False if it was skipped."""
        try:
            self.pm.register(obj, name=name)
        except Exception as e:  # pluggy.PluginValidationError, ValueError (already registered)
            self.report(Problem(name, f"invalid plugin: {e}"))
            return False
        known = set(HOOK_KINDS) | OTHER_HOOKS
        for caller in self.pm.get_hookcallers(obj) or []:
            if caller.name not in known:
                hint = closest(caller.name, known)
                self.report(Problem(name, f"implements unknown hook '{caller.name}'"
                                          + (f" (did you mean '{hint}'?)" if hint else "")))
        module = getattr(obj, "__name__", type(obj).__module__)
        self.plugins[name] = PluginInfo(name, dist or name, version, module)
        self._specs.clear()
        return True

    # -- calling hooks, one plugin at a time --------------------------------------------------------
    def _impls(self, hook: str) -> list[Any]:
        caller = getattr(self.pm.hook, hook, None)
        return list(caller.get_hookimpls()) if caller is not None else []

    def _each_list(self, hook: str, item: str) -> Iterator[tuple[str, list | tuple]]:
        """(plugin name, the list its `hook` returned), one plugin at a time: a hook that raises or
        returns something other than a list of `item` is reported as a Problem and skipped."""
        for impl in self._impls(hook):
            plugin = impl.plugin_name
            try:
                result = impl.function()
            except Exception as e:
                self.report(Problem(plugin, f"hook {hook} raised {type(e).__name__}: {e}"))
                continue
            if result is None:
                continue
            if not isinstance(result, (list, tuple)):
                self.report(Problem(plugin, f"hook {hook} returned {type(result).__name__}, not a list of {item}"))
                continue
            yield plugin, result

    def specs(self, hook: str) -> list[Spec]:
        """Every valid spec from `hook`, each tagged with its plugin; first registration of a name wins."""
        if hook not in HOOK_KINDS:
            raise ValueError(f"'{hook}' is not a spec hook; spec hooks: {sorted(HOOK_KINDS)}")
        if hook in self._specs:
            return self._specs[hook]
        out: dict[str, Spec] = {}
        for plugin, result in self._each_list(hook, "Spec"):
            for spec in result:
                why = check_spec(spec, HOOK_KINDS[hook])
                if why is not None:
                    self.report(Problem(plugin, f"{hook}: {why}; skipped"))
                    continue
                if spec.name in out:
                    self.report(Problem(plugin, f"{spec.kind} '{spec.name}' is already provided by "
                                                f"'{out[spec.name].plugin}'; skipped"))
                    continue
                out[spec.name] = replace(spec, plugin=self.plugins[plugin].dist if plugin in self.plugins else plugin)
                info = self.plugins.get(plugin)
                if info is not None and spec.name not in info.provides.setdefault(spec.kind, []):
                    info.provides[spec.kind].append(spec.name)
        self._specs[hook] = list(out.values())
        return self._specs[hook]

    def all_specs(self) -> list[Spec]:
        return [s for hook in HOOK_KINDS for s in self.specs(hook)]

    def find(self, hook: str, name: str, what: str | None = None) -> Spec:
        """The spec called `name`, or a ConfigError with the closest registered name."""
        by_name = {s.name: s for s in self.specs(hook)}
        if name not in by_name:
            raise ConfigError(unknown(what or HOOK_KINDS[hook][0], name, by_name)
                              + self.plugin_hint(HOOK_KINDS[hook][0], name))
        return by_name[name]

    def plugin_hint(self, kind: str, name: str) -> str:
        """" (provided by rio-sim, which is not installed: pip install rio-sim)" when one of RIO's own
        plugins, not loaded here, provides `name` of `kind`; "" otherwise. Append it to an unknown-name error."""
        return missing_plugin_hint(kind, name, {p.dist for p in self.plugins.values()}) or ""

    def requirements(self) -> dict[str, list[Requirement]]:
        """{plugin distribution: its valid requirements}, from each plugin's `rio_requirements` hook in
        turn; a hook that raises or returns something malformed is reported as a Problem and skipped."""
        out: dict[str, list[Requirement]] = {}
        for plugin, result in self._each_list("rio_requirements", "Requirement"):
            dist = self.plugins[plugin].dist if plugin in self.plugins else plugin
            for req in result:
                why = check_requirement(req)
                if why is not None:
                    self.report(Problem(plugin, f"rio_requirements: {why}; skipped"))
                    continue
                out.setdefault(dist, []).append(req)
        return out

    def camera_listers(self) -> list[tuple[str, str]]:
        """(plugin distribution, 'module:function') for every camera lister the plugins declare."""
        out = []
        for plugin, result in self._each_list("rio_camera_listers", "import path"):
            dist = self.plugins[plugin].dist if plugin in self.plugins else plugin
            for path in result:
                if not isinstance(path, str) or ":" not in path:
                    self.report(Problem(plugin, f"rio_camera_listers: {path!r} is not 'module:function'; skipped"))
                    continue
                out.append((dist, path))
        return out

    def add_workflows(self, app: Any) -> None:
        """Mount every workflow (`rio_workflows`) as a command of the `rio` typer app; one whose command
        cannot be imported, or whose name a command already has, is reported and skipped."""
        taken = {c.name for c in app.registered_commands} | {g.name for g in app.registered_groups}
        for spec in self.specs("rio_workflows"):
            if spec.name in taken:
                self.report(Problem(spec.plugin, f"workflow '{spec.name}': `rio {spec.name}` is a command already; "
                                                 "skipped"))
                continue
            try:
                command = spec.load()
            except Exception as e:
                self.report(Problem(spec.plugin, f"workflow '{spec.name}': cannot import {spec.target}: "
                                                 f"{type(e).__name__}: {e}"))
                continue
            app.command(spec.name)(command)
            taken.add(spec.name)

    def extend_cli(self, app: Any) -> None:
        """Let each plugin add subcommands; a plugin whose hook fails is reported and skipped."""
        for impl in self._impls("rio_cli"):
            try:
                result = impl.function(app=app) if "app" in impl.argnames else impl.function()
                for sub_name, sub in (result or {}).items():
                    app.add_typer(sub, name=sub_name)
            except Exception as e:
                self.report(Problem(impl.plugin_name, f"hook rio_cli raised {type(e).__name__}: {e}"))


_REGISTRY: Registry | None = None


def get_registry() -> Registry:
    """The process-wide registry, loaded on first use (honours RIO_LOAD_PLUGINS at that moment)."""
    global _REGISTRY
    if _REGISTRY is None:
        _REGISTRY = Registry(only=os.environ.get(ENV_ONLY))
    return _REGISTRY


def reset() -> None:
    """Forget the loaded plugins (tests; after installing a plugin in a running process)."""
    global _REGISTRY
    _REGISTRY = None


def get_plugin_manager() -> pluggy.PluginManager:
    return get_registry().pm


def specs(hook: str) -> list[Spec]:
    return get_registry().specs(hook)


def get_middleware(name: str) -> type[Middleware]:
    return get_registry().find("rio_middlewares", name, "middleware").load()
