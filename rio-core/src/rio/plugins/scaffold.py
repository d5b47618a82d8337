"""`rio new plugin` and `rio new driver`: render the copier templates shipped in `rio/templates`.

Two templates, package data of rio-core, so what a generated plugin contains is readable and testable
as files rather than assembled from strings:

- `templates/plugin`: the distribution around the drivers: pyproject.toml with the `rio` entry point,
  the plugin module registering specs, the README;
- `templates/driver/<kind>`: one driver of that kind: its module, an emulator, a demo station and a
  test (an arm adds its robot model, as package data).

`new_plugin` renders both into `rio-NAME/`; `new_driver` renders a driver into an existing plugin and
adds its specs to the plugin module (or says which lines to add when it cannot edit it safely), so
one plugin can hold drivers of several kinds. copier is an optional dependency:
`pip install 'rio-core[new]'` (included in `rio-core[all]`).
"""

from __future__ import annotations

import keyword
import re
from dataclasses import dataclass
from pathlib import Path

from rio.errors import ConfigError, RioError
from rio.plugins.source import CannotEdit, add_spec, indent

PLUGIN_KINDS = ("arm", "gripper", "camera", "teleop", "policy", "sensor")
_NAME = re.compile(r"^[a-z][a-z0-9_-]*[a-z0-9]$")
_MODEL = re.compile(r"^[a-z][a-z0-9_]*$")
#: Module names of a generated plugin that a new driver may not take.
_RESERVED_MODULES = frozenset({"plugin", "driver", "emulator", "models", "stations", "cli", "tests"})
_DESCRIPTION = {
    "arm": "6-joint arm",
    "gripper": "parallel gripper",
    "camera": "RGB(-D) camera",
    "teleop": "teleop device (twist, gripper, buttons)",
    "policy": "policy (action chunks from proprio and cameras)",
    "sensor": "force/torque sensor (wrench)",
}
#: What each kind's demo station pairs the driver with.
_STATION_WITH = {
    "arm": "a fake camera and scripted teleop",
    "gripper": "a fake arm and scripted teleop",
    "camera": "a fake arm and scripted teleop",
    "teleop": "a fake arm and gripper",
    "policy": "a fake arm and camera",
    "sensor": "a fake arm and scripted teleop",
}


def template_dir(which: str = "plugin") -> Path:
    """`templates/plugin` (the distribution) or `templates/driver` (one driver, a folder per kind)."""
    return Path(__file__).parent / "templates" / which


def _copier():
    try:
        import copier
    except ImportError:
        raise RioError("`rio new` needs copier, which is not installed: pip install 'rio-core[new]'") from None
    return copier


def _check_kind(kind: str) -> None:
    from rio.suggest import unknown

    if kind not in PLUGIN_KINDS:
        raise ConfigError(unknown("plugin kind", kind, PLUGIN_KINDS))


# -- names ----------------------------------------------------------------------------------------------


def check_name(name: str) -> str:
    if not _NAME.match(name):
        raise ConfigError(f"plugin name '{name}' must be lowercase letters, digits, '-' or '_', "
                          "start with a letter and be at least 2 characters (e.g. 'acme')")
    if name in {"core", "rio"}:
        raise ConfigError(f"plugin name '{name}' is reserved")
    return name


def check_unclaimed(name: str) -> None:
    """Refuse a name whose distribution `rio-NAME` (or import package `rio_NAME`) is taken: one of this
    repository's plugins, shipped or planned (`rio.plugins.known`), or anything installed here."""
    import importlib
    import importlib.util
    from importlib.metadata import PackageNotFoundError, distribution

    from rio.plugins.known import repository_plugin

    dist, package = f"rio-{name}", package_of(name)
    ours = repository_plugin(dist)
    if ours is not None:
        raise ConfigError(f"plugin name '{name}' is taken: {ours} is a plugin of the RIO repository "
                          "(shipped or planned); choose another name, e.g. your company's or the product's")
    importlib.invalidate_caches()
    try:
        found = distribution(dist)
    except PackageNotFoundError:
        found = None
    if found is not None:
        raise ConfigError(f"plugin name '{name}' is taken: {found.metadata['Name']} {found.version} is already "
                          f"installed in this environment; choose another name, or uninstall it first "
                          f"(rio plugins uninstall {found.metadata['Name']})")
    spec = importlib.util.find_spec(package)
    if spec is not None:
        where = spec.origin or ", ".join(spec.submodule_search_locations or [])
        raise ConfigError(f"plugin name '{name}' is taken: a module '{package}' is already importable ({where}); "
                          "choose another name")


def package_of(name: str) -> str:
    return f"rio_{name.replace('-', '_')}"


def _camel(*words: str) -> str:
    return "".join(w.capitalize() for part in words for w in re.split(r"[-_]", part) if w)


def rio_core_bounds() -> str:
    """The rio-core versions a new plugin accepts: the installed one's minor series (the version policy:
    plugins and rio-core move by minor together), e.g. ">=0.1,<0.2"."""
    from rio import __version__

    major, minor = (int(x) for x in __version__.split(".")[:2])
    return f">={major}.{minor},<{major}.{minor + 1}"


def driver_values(name: str, package: str, dist: str, kind: str, model: str, *, first: bool) -> dict[str, str]:
    """Everything the driver template is rendered with. `first`: the plugin's first driver (files
    driver.py / emulator.py / tests/test_<package>.py, station <name>-demo), else named after `model`."""
    if kind == "camera":
        role = "front_camera" if model == kind else model if model.endswith("_camera") else f"{model}_camera"
    elif kind == "sensor":
        role = "wrist_sensor" if model == kind else model if model.endswith("_sensor") else f"{model}_sensor"
    else:
        role = kind
    return {
        "kind": kind, "name": name, "dist": dist, "package": package, "model": model,
        "driver": f"{name}.{model}",
        "module": "driver" if first else model,
        "emulator_module": "emulator" if first else f"{model}_emulator",
        "test_module": f"test_{package}" if first else f"test_{package}_{model}",
        "class_name": _camel(name, model) + ("" if model == kind or model.endswith(f"_{kind}") else _camel(kind)),
        "station": f"{name}-demo" if first else f"{name}-{model.replace('_', '-')}-demo",
        "role": role,
        "model_file": f"{model}.xml",
        "port_env": re.sub(r"[^A-Z0-9]+", "_", f"{name}_{model}".upper())
        + ("_CHECKPOINT" if kind == "policy" else "_PORT"),
    }


def hook_of(kind: str) -> str:
    return "rio_policies" if kind == "policy" else "rio_drivers"


def spec_entries(values: dict[str, str]) -> dict[str, str]:
    """hook -> the `Spec(...)` expression registering the driver (or policy) and its station."""
    v = values
    kind = v["kind"]
    target = f"{v['package']}.{v['module']}:{v['class_name']}" + ("Node" if kind == "policy" else "")
    stand_in = ("checkpoint = 'emulator': a stand-in model" if kind == "policy"
                else "port = 'emulator': an in-process stand-in")
    return {
        hook_of(kind): _spec(v["driver"], kind, target, f"{_DESCRIPTION[kind]}; {stand_in}"),
        "rio_stations": _spec(v["station"], "station", f"{v['package']}:stations/{v['station']}.toml",
                              f"{v['driver']} (emulated) with {_STATION_WITH[kind]}"),
    }


def _spec(*args: str, width: int = 112) -> str:
    """`Spec("a", "b", ...)`, its arguments wrapped under the first one to fit `width` (the list's
    8-space indent taken off 120 columns)."""
    lines, line = [], "Spec("
    for i, arg in enumerate(args):
        item = f'"{arg}"' + (", " if i < len(args) - 1 else ")")
        if line.strip() not in ("Spec(", "") and len(line) + len(item.rstrip()) > width:
            lines.append(line.rstrip())
            line = " " * 5
        line += item
    return "\n".join([*lines, line])


# -- rio new plugin -------------------------------------------------------------------------------------


def new_plugin(name: str, kind: str = "arm", output: str | Path = ".", *, force: bool = False) -> Path:
    """Generate `<output>/rio-<name>/` with one driver of `kind`; returns its path."""
    check_name(name)
    _check_kind(kind)
    check_unclaimed(name)
    copier = _copier()
    dst = Path(output) / f"rio-{name}"
    if dst.exists() and any(dst.iterdir()) and not force:
        raise RioError(f"{dst} already exists and is not empty (use --force to render into it)")
    values = driver_values(name, package_of(name), f"rio-{name}", kind, kind, first=True)
    specs = spec_entries(values)
    hook = hook_of(kind)
    plugin = {**values, "hook": hook, "driver_spec": indent(specs[hook], 8).lstrip(),
              "station_spec": indent(specs["rio_stations"], 8).lstrip(), "rio_core_bounds": rio_core_bounds()}
    copier.run_copy(str(template_dir("plugin")), str(dst), data=plugin, defaults=True, overwrite=force,
                    quiet=True, unsafe=False)
    copier.run_copy(str(template_dir("driver")), str(dst), data=values, defaults=True, overwrite=force,
                    quiet=True, unsafe=False)
    return dst


# -- rio new driver -------------------------------------------------------------------------------------


@dataclass
class PluginDir:
    """A plugin's folder: a pyproject.toml whose `[project.entry-points.rio]` names `<package>.plugin`,
    with `src/<package>/plugin.py`."""

    root: Path
    name: str  # the entry point's name: the vendor part of its driver names
    dist: str
    package: str

    @property
    def plugin_py(self) -> Path:
        return self.root / "src" / self.package / "plugin.py"


def find_plugin(path: str | Path = ".") -> PluginDir:
    """The plugin whose folder is `path` or contains it."""
    from rio.toml import read_toml

    start = Path(path).resolve()
    root = next((d for d in (start, *start.parents) if (d / "pyproject.toml").is_file()), None)
    if root is None:
        raise RioError(f"{start} is not inside a plugin folder (no pyproject.toml here or above); run "
                       "`rio new driver` in the folder `rio new plugin` made, or pass --plugin DIR")
    pyproject = root / "pyproject.toml"
    data = read_toml(pyproject)
    project = data.get("project") or {}
    eps = (project.get("entry-points") or {}).get("rio") or {}
    if not eps:
        raise RioError(f"{pyproject} has no [project.entry-points.rio] table: not a RIO plugin")
    for ep_name, target in eps.items():
        package, _, last = str(target).partition(":")[0].rpartition(".")
        if last == "plugin" and package and "." not in package and (root / "src" / package / "plugin.py").is_file():
            return PluginDir(root, ep_name, str(project.get("name") or root.name), package)
    raise RioError(f"{pyproject}: no entry point of [project.entry-points.rio] names '<package>.plugin' with "
                   f"src/<package>/plugin.py (found {dict(eps)}); add the driver by hand (see docs/plugins.md)")


@dataclass
class NewDriver:
    plugin: PluginDir
    values: dict[str, str]
    files: list[Path]
    #: hook -> the Spec(...) expression to register
    specs: dict[str, str]
    #: True: plugin.py was edited; False: `note` says why not, and the specs are to be added by hand
    registered: bool
    note: str = ""

    def instructions(self) -> str:
        rel = self.plugin.plugin_py.relative_to(self.plugin.root)
        if self.registered:
            head = f"registered in {rel}:"
        else:
            head = f"not registered: {self.note}\nadd these entries to the lists returned by the hooks of {rel}:"
        lines = [head]
        for hook, entry in self.specs.items():
            lines.append(f"  in {hook}():")
            lines.append(indent(entry, 8) + ",")
        return "\n".join(lines)


def new_driver(model: str, kind: str, plugin: str | Path = ".", *, register: bool = True) -> NewDriver:
    """Add a driver of `kind` named `<plugin name>.<model>` to the plugin at (or above) `plugin`:
    `src/<package>/<model>.py`, its emulator, a demo station and a test; then register its specs in
    plugin.py (unless `register` is False or the file is not in a shape it can edit safely)."""
    _check_kind(kind)
    if not _MODEL.match(model) or keyword.iskeyword(model) or model in _RESERVED_MODULES:
        raise ConfigError(f"driver name '{model}' must be a lowercase Python module name (letters, digits, '_', "
                          f"starting with a letter; not {', '.join(sorted(_RESERVED_MODULES))}), e.g. 'wrist_camera'")
    p = find_plugin(plugin)
    values = driver_values(p.name, p.package, p.dist, kind, model, first=False)
    text = p.plugin_py.read_text(encoding="utf-8")
    for what in ("driver", "station"):
        if f'"{values[what]}"' in text:
            raise ConfigError(f"{p.plugin_py} already registers {what} '{values[what]}'; choose another driver name")
    copier = _copier()
    before = {q for q in p.root.rglob("*") if q.is_file()}
    expected = [p.root / "src" / p.package / f"{values[m]}.py" for m in ("module", "emulator_module")]
    expected += [p.root / "src" / p.package / "stations" / f"{values['station']}.toml",
                 p.root / "tests" / f"{values['test_module']}.py"]
    if kind == "arm":
        expected.append(p.root / "src" / p.package / "models" / values["model_file"])
    clash = [str(q.relative_to(p.root)) for q in expected if q.exists()]
    if clash:
        raise RioError(f"not overwriting {', '.join(clash)}: choose another driver name")
    copier.run_copy(str(template_dir("driver")), str(p.root), data=values, defaults=True, overwrite=False,
                    quiet=True, unsafe=False)
    files = sorted(q for q in p.root.rglob("*") if q.is_file() and q not in before)
    specs = spec_entries(values)
    out = NewDriver(p, values, files, specs, registered=False)
    if not register:
        out.note = "--no-register"
        return out
    try:
        edited = text
        for hook, entry in specs.items():
            edited = add_spec(edited, hook, entry)
    except CannotEdit as e:
        out.note = str(e)
        return out
    p.plugin_py.write_text(edited, encoding="utf-8")
    out.registered = True
    return out
