"""Every `rio` command (enumerated from the app, plugins' commands and nested groups included) against a
table of bad arguments: each must end with a non-zero status and one line on stderr starting with
"error:" that names the option or the value, never a traceback, and before anything starts.

Why a table generated from the app rather than hand-written cases: a new command or option is covered
the day it is added (its numbers, paths and station names get the same bad values). What would start
something — nodes of a station, an installer — is replaced by `_Started`, so a bad value that slips
through fails the case instead of starting a station. Plugins' commands that talk to devices or serve
forever (`SUBPROCESS`) run in a subprocess with a deadline instead: their code is not core's to
patch."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from rio.cli.app import EXIT_INTERRUPTED, build_app

#: Where a value stands for a fixture's path (filled in by `_fill`).
STATION, DIR, FILE, MISSING = "{station}", "{dir}", "{file}", "{missing}"

#: A valid value for each required argument / option, by parameter name: how any command (a new one
#: too) gets a command line whose only fault is the bad value under test.
REQUIRED = {
    "station": STATION, "dataset": DIR, "src": DIR, "out": "{tmp}/out", "name": "acme", "specs": "rio-acme",
    "names": "rio-acme", "controller": "rio.teleop.twist:TwistTeleop", "fmt": "zarr", "ip": "192.0.2.1",
    "port": "{missing}", "state": "on", "program": "x.urp", "path": DIR,
    "directory": "{tmp}/out", "layout": "xarm7", "interface": "lo",
}
#: Options a command line also needs (not required by typer, but the command stops without them).
EXTRA = {("teleop",): ["--teleop", "scripted"], ("top",): ["--once"], ("plugins", "uninstall"): ["--yes"]}

#: Bad numbers; an option that accepts one of them says so here (`(command, option): {values}`).
BAD_NUMBERS = ("abc", "nan", "inf", "-5", "0")
#: More bad numbers for options with a range of their own, by option name: a rate outside 1..10000 Hz (`--rate
#: 1e-9` ran past `--duration 1`), a certificate validity past what a date can hold (`--days 99999999` was a
#: traceback).
BAD_NUMBERS_OF = {"--rate": ("1e-9", "100000"), "--days": ("99999999",)}
ACCEPTS = {
    ("deploy", "--threshold"): {"0"}, ("deploy", "--crossfade"): {"0"}, ("replay", "--approach"): {"0"},
    ("eval", "--seed"): {"0"}, ("eval", "--threshold"): {"0"}, ("eval", "--crossfade"): {"0"},
    ("eval", "--hold"): {"0"},
    ("replay", "--episode"): {"0"}, ("ur", "emulator", "--exit-with"): {"0", "-5"},
    ("ros2", "bridge", "--domain"): {"0"},
    ("datasets", "view", "--episode"): {"0"}, ("deploy", "--seed"): {"0"}, ("teleop", "--seed"): {"0"},
    **{("unitree", c, "--domain-id"): {"0"} for c in ("bridge", "check", "damp", "debug-mode", "stand")},
    ("unitree", "stand", "--hold"): {"0"},
}
#: Parameters that are paths of directories to write into / read from, or station names, by name.
STATION_PARAMS = {"station"}
DATASET_PARAMS = {"dataset", "src"}
OUTPUT_DIR_PARAMS = {"record", "profile", "output", "out", "directory"}
#: Where nothing can be created: under a regular file (any system) and under /proc (Linux): `--record
#: /proc/x`, `--profile /proc/x`, `rio export DS /proc/x`, `rio keys generate /proc/x`, `rio ros2 definitions
#: /proc/x` ended in tracebacks once the first file was written.
UNWRITABLE = (FILE + "/sub",) + (("/proc/x",) if Path("/proc/self").is_dir() else ())
EXISTING_DIR_PARAMS = {"plugin_dir"}
#: Strings for which '' is a fair value.
EMPTY_OK = {"instruction", "name"}

#: Commands that serve until stopped when a bad value slips through: a subprocess with a deadline.
SUBPROCESS = {("so100", "emulator"), ("ur", "emulator"), ("ufactory", "emulator"), ("unitree", "bridge")}
SUBPROCESS_DEADLINE_S = 10
class _Started(BaseException):  # noqa: N818 - not an error: the marker that something was started
    """Raised where a station's nodes or an installer would start: a bad value got that far."""


@dataclass(frozen=True)
class Case:
    command: tuple[str, ...]
    param: str
    argv: tuple[str, ...]  # the command line after `rio` (placeholders still in)
    value: str
    subprocess: bool  # run in a subprocess with a deadline (SUBPROCESS), else in-process

    @property
    def id(self) -> str:
        return " ".join(self.argv).replace("{", "").replace("}", "")


def _leaves(group: typer.main.TyperGroup, path: tuple[str, ...] = ()):
    for name, cmd in sorted(group.commands.items()):
        if cmd.hidden:  # an old name kept for one release (rio.cli.renamed): the same function as the new one
            continue
        if hasattr(cmd, "commands"):
            yield from _leaves(cmd, (*path, name))
        else:
            yield (*path, name), cmd


def _annotation(param) -> str:
    ann = param.type_descriptor.annotation
    return ann.__name__ if isinstance(ann, type) else str(ann)


def _base(path: tuple[str, ...], cmd) -> list[str] | None:
    """A command line for `path` that is valid except for what a case changes (None: a parameter
    this table has no valid value for; `test_table_knows_every_required_parameter` names it)."""
    argv = [*path]
    for p in cmd.params:
        if not p.required:
            continue
        if p.name not in REQUIRED:
            return None
        argv += [REQUIRED[p.name]] if p.param_type_name == "argument" else [p.opts[0], REQUIRED[p.name]]
    return [*argv, *EXTRA.get(path, [])]


def _with(base: list[str], param, value: str) -> tuple[str, ...]:
    """`base` with `param` set to `value` (replacing its valid value when it has one)."""
    argv = list(base)
    if param.param_type_name == "argument" and param.required:
        argv[argv.index(REQUIRED[param.name])] = value
        return tuple(argv)
    if param.param_type_name == "argument":  # an optional argument: the only one (`rio top [STATION]`)
        return (*argv, value)
    if param.opts[0] in argv:
        argv[argv.index(param.opts[0]) + 1] = value
        return tuple(argv)
    return (*argv, param.opts[0], value)


def _values(path: tuple[str, ...], param) -> list[str]:
    """The bad values for one parameter, from its type and name."""
    ann, name = _annotation(param), param.name
    opt = param.opts[0] if param.param_type_name == "option" else name
    if ann in ("float", "int"):
        return [v for v in BAD_NUMBERS + BAD_NUMBERS_OF.get(opt, ()) if v not in ACCEPTS.get((*path, opt), set())]
    if ann == "bool" or (path[0] not in CORE_GROUPS and name not in OUTPUT_DIR_PARAMS):
        return []  # plugins' string options: their values mean something only to the device (paths excepted)
    out = [] if name in EMPTY_OK or param.multiple or param.nargs != 1 else [""]
    if name in STATION_PARAMS:
        out += ["no-such-station", DIR, MISSING + ".toml"]
    if name in DATASET_PARAMS:
        out += [MISSING, FILE]
    if name in OUTPUT_DIR_PARAMS:
        out += [FILE, *UNWRITABLE]
    if name in EXISTING_DIR_PARAMS:
        out += [MISSING, FILE]
    return out


APP = build_app()
CORE_GROUPS = {name for name in typer.main.get_command(build_app(load_plugins=False)).commands}


#: Cases a value table cannot make: a good value the rest of the command line makes useless (`--episodes`
#: without `--record` was silently ignored), or a value only the option's meaning makes bad (an address that
#: is no address was written into a certificate). (command, option, what is added to its valid command line).
COMBINATIONS = [
    (("teleop",), "--episodes", ["--episodes", "5"]),
    (("teleop",), "--on-end", ["--on-end", "keep"]),
    (("keys", "generate"), "--address", ["--address", "rio-acme=not an ip"]),
    (("keys", "generate"), "--address", ["--address", "rio-acme=-bad-.lab"]),
    (("keys", "add"), "--address", ["--address", "rio-acme=a..b"]),
]


def _cases() -> list:
    params = []
    commands = dict(_leaves(typer.main.get_command(APP)))
    for path, cmd in commands.items():
        base = _base(path, cmd)
        if base is None or path == ("bench", "middleware"):  # bench parses its own arguments
            continue
        for param in cmd.params:
            opt = param.opts[0] if param.param_type_name == "option" else param.name
            for value in _values(path, param):
                case = Case(path, opt, _with(base, param, value), value, path in SUBPROCESS)
                params.append(pytest.param(case, id=case.id))
    for path, opt, extra in COMBINATIONS:
        base = _base(path, commands[path])
        assert base is not None, path
        case = Case(path, opt, (*base, *extra), extra[-1], path in SUBPROCESS)
        params.append(pytest.param(case, id=case.id))
    return params


@pytest.fixture(scope="module")
def paths(tmp_path_factory) -> dict[str, str]:
    tmp = tmp_path_factory.mktemp("bad_args")
    station = tmp / "station.toml"
    station.write_text('name = "bad-args"\n[middleware]\nname = "thread"\n[components.arm]\ndriver = "rio.fake_arm"\n')
    (tmp / "dir").mkdir()
    (tmp / "file").write_text("not a directory\n")
    return {"{station}": str(station), "{dir}": str(tmp / "dir"), "{file}": str(tmp / "file"),
            "{missing}": str(tmp / "missing"), "{tmp}": str(tmp)}


@pytest.fixture
def nothing_starts(monkeypatch, tmp_path):
    """What a command would start (a station's nodes, an installer) raises `_Started` instead; and a
    command that takes '' for '.' writes into an empty directory, not into the checkout."""
    monkeypatch.chdir(tmp_path)
    from rio.cli import plugins_cmd
    from rio.runtime.manager import ServerManager

    def started(*_a, **_k):
        raise _Started

    monkeypatch.setattr(ServerManager, "__enter__", started)
    monkeypatch.setattr(plugins_cmd, "_run_installer", started)


def _fill(argv: tuple[str, ...], paths: dict[str, str]) -> list[str]:
    out = []
    for a in argv:
        for key, value in paths.items():
            a = a.replace(key, value)
        out.append(a)
    return out


def _run(case: Case, paths: dict[str, str]) -> tuple[int, str, str]:
    argv = _fill(case.argv, paths)
    if not case.subprocess:
        r = CliRunner().invoke(APP, argv, catch_exceptions=True)
        if r.exception is not None and not isinstance(r.exception, SystemExit):
            raise AssertionError(f"rio {' '.join(argv)} raised {r.exception!r}") from r.exception
        return r.exit_code, r.stdout, r.stderr
    try:
        p = subprocess.run([sys.executable, "-m", "rio", *argv], capture_output=True, text=True,
                           timeout=SUBPROCESS_DEADLINE_S, env={**os.environ, "COLUMNS": "200"})
    except subprocess.TimeoutExpired:
        raise AssertionError(f"rio {' '.join(argv)} did not fail fast: still running after "
                             f"{SUBPROCESS_DEADLINE_S} s") from None
    return p.returncode, p.stdout, p.stderr


@pytest.mark.parametrize("case", _cases())
def test_bad_argument_fails_fast_with_one_line(case: Case, paths, nothing_starts):
    code, out, err = _run(case, paths)
    shown = f"rio {' '.join(_fill(case.argv, paths))}\n--- stdout\n{out}--- stderr\n{err}"
    assert "Traceback" not in out + err, shown
    assert code != 0, shown
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), shown
    # the line names the option; a word or path may be named instead (a number: the option, always)
    named = case.value and case.value not in BAD_NUMBERS and _fill((case.value,), paths)[0] in lines[0]
    assert case.param in lines[0] or named, shown


def test_table_knows_every_required_parameter():
    """A command whose required parameter has no valid value in REQUIRED would be left out silently."""
    unknown = [(path, [p.name for p in cmd.params if p.required and p.name not in REQUIRED])
               for path, cmd in _leaves(typer.main.get_command(APP)) if _base(path, cmd) is None]
    assert unknown == []


def test_table_covers_every_command_group():
    covered = {case.values[0].command[0] for case in _cases()}
    only_flags = {"bench", "cameras", "doctor", "plugins", "ports"}  # nothing but --json etc. to get wrong
    assert covered >= CORE_GROUPS - only_flags | {"datasets", "export", "replay"}


# --- Ctrl-C -----------------------------------------------------------------------------------------


def test_ctrl_c_in_a_command_is_one_line_and_130(monkeypatch):
    from rio.plugins import registry as plugins

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(plugins, "get_registry", interrupted)
    r = CliRunner().invoke(APP, ["doctor"])
    assert (r.exit_code, r.stderr.strip(), r.stdout) == (EXIT_INTERRUPTED, "error: interrupted", "")


def test_ctrl_c_during_station_start_up_is_one_line_and_130(monkeypatch, paths):
    from rio.runtime.manager import ServerManager

    def interrupted(*_a):
        raise KeyboardInterrupt

    monkeypatch.setattr(ServerManager, "__enter__", interrupted)
    r = CliRunner().invoke(APP, ["teleop", paths["{station}"], "--teleop", "scripted"])
    assert r.exit_code == EXIT_INTERRUPTED and "Traceback" not in r.output, r.output
    assert r.stderr.strip().splitlines()[-1] == "error: interrupted", r.stderr


def test_ctrl_c_while_plugins_load_is_one_line_and_130(monkeypatch, capsys):
    from rio.cli import app, main

    def interrupted(**_k):
        raise KeyboardInterrupt

    monkeypatch.setattr(app, "build_app", interrupted)
    assert main(["plugins", "list"]) == EXIT_INTERRUPTED
    assert capsys.readouterr().err == "error: interrupted\n"


def test_sigint_during_start_up_of_a_real_station(paths):
    """The real thing, once: SIGINT to the `rio` process group (what Ctrl-C in a terminal sends) while
    the station starts: one line from rio, no traceback from it or from any node process."""
    station = Path(paths["{tmp}"]) / "sigint.toml"  # shm: the nodes are processes, which get the SIGINT too
    station.write_text('name = "sigint"\n[middleware]\nname = "shm"\n[components.arm]\ndriver = "rio.fake_arm"\n'
                       '[embodiment]\naction_space = "eef_pose"\n')
    p = subprocess.Popen([sys.executable, "-m", "rio", "teleop", str(station), "--teleop", "scripted"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 30
    assert p.stderr is not None
    while time.monotonic() < deadline and "starting station" not in (line := p.stderr.readline()):
        assert line, "rio teleop ended before starting its station"
    os.killpg(p.pid, signal.SIGINT)
    out, err = p.communicate(timeout=30)
    assert "Traceback" not in out + err, err
    assert p.returncode == EXIT_INTERRUPTED, (p.returncode, out, err)


def test_ctrl_c_while_the_command_line_is_imported_is_one_line_and_130(monkeypatch, capsys):
    """The first half second of every command is spent importing typer and rich (`rio.cli.app`); Ctrl-C
    there was a KeyboardInterrupt traceback."""
    import builtins

    from rio.cli import main

    real_import = builtins.__import__

    def importing(name, *args, **kwargs):
        if name == "rio.cli.app":
            raise KeyboardInterrupt
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", importing)
    try:
        code = main(["plugins", "list"])
    except KeyboardInterrupt:
        pytest.fail("KeyboardInterrupt escaped rio.cli.main (a traceback for the user)")
    assert code == EXIT_INTERRUPTED and capsys.readouterr().err == "error: interrupted\n"


def test_a_real_sigint_while_typer_is_imported(tmp_path):
    """The real signal, at a moment fixed by an import hook rather than by a timer: the process sends itself
    SIGINT when `typer` is looked for, i.e. while `rio.cli.main` imports the command line."""
    script = textwrap.dedent("""
        import os, signal, sys

        class Interrupt:
            def find_spec(self, name, path=None, target=None):
                if name == "typer":
                    os.kill(os.getpid(), signal.SIGINT)
                return None

        sys.meta_path.insert(0, Interrupt())
        from rio.cli import main
        sys.exit(main(["plugins", "list"]))
    """)
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert "Traceback" not in p.stderr, p.stderr
    assert (p.returncode, p.stderr) == (EXIT_INTERRUPTED, "error: interrupted\n")
