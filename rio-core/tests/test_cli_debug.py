"""Failures a user can act on end a command with one line that says what to do, never a traceback first;
`rio --debug` (or RIO_DEBUG=1) shows the tracebacks. And shell completion (typer's) works through
RIO's root command.

The common failures, each as a user meets it: a missing SO-100 calibration and an unplugged serial port
(a node that fails to start, as a thread and as a process), `rio bench middleware` without the portal
package, an unknown station, a malformed station file, an unknown driver. A node that fails after the
station started says so in one line too; an exception that is not a RioError is a bug and keeps its
traceback."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from rio.cli.app import build_app
from rio.errors import RioError

APP = build_app()


@pytest.fixture(autouse=True)
def no_debug(monkeypatch):
    """Each test starts without RIO_DEBUG, and `--debug` (which sets it) does not outlive the test."""
    monkeypatch.setenv("RIO_DEBUG", "0")


def rio(*args: str, env: dict[str, str] | None = None, timeout: float = 90) -> subprocess.CompletedProcess:
    """`python -m rio ARGS` as a user runs it (its node processes print to the same stderr)."""
    return subprocess.run([sys.executable, "-m", "rio", *args], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL, env={**os.environ, "RIO_DEBUG": "0", "COLUMNS": "200",
                                                         **(env or {})})


def error_line(err: str) -> str:
    """The last line on stderr, which must be the command's one error line."""
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines and lines[-1].startswith("error: "), err
    return lines[-1]


# --- a node that cannot start: SO-100 without its calibration, an unplugged port --------------------------

@pytest.fixture
def so100_station(tmp_path):
    """A station file for an SO-100 follower on an emulated Feetech bus (a pseudo-terminal served by the
    test), its leader emulated; `write(middleware, port=..., calibration=...)` writes one."""
    pytest.importorskip("rio_so100")  # the SO-100 cases need the plugin; the rest only rio-core
    from rio_so100.emulator import FeetechBusEmulator

    bus = FeetechBusEmulator()

    def write(middleware: str, port: str | None = None, calibration: str = "default") -> str:
        path = tmp_path / f"so100-{middleware}.toml"
        path.write_text(f'name = "so100-debug"\nrate_hz = 50\n[middleware]\nname = "{middleware}"\n'
                        f'[components.arm]\ndriver = "so100.follower"\nport = "{port or bus.port}"\n'
                        f'calibration = "{calibration}"\n'
                        '[components.teleop]\ndriver = "so100.leader"\nport = "emulator"\n')
        return str(path)

    yield write
    bus.close()


SO100_ENV = {"RIO_LOAD_PLUGINS": "rio-so100"}


@pytest.mark.parametrize("middleware", ["thread", "shm"])
def test_missing_so100_calibration_is_one_line(so100_station, tmp_path, middleware):
    r = rio("teleop", so100_station(middleware), "--duration", "1",
            env={**SO100_ENV, "XDG_CONFIG_HOME": str(tmp_path / "config")})
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    line = error_line(r.stderr)
    assert line.startswith("error: node 'arm' failed to start: CalibrationError: no calibration 'default' for "
                           "the so100 follower") and "run `rio so100 calibrate --port PORT" in line, line
    assert r.stderr.count("no calibration") == 1, r.stderr


@pytest.mark.parametrize("how", [("--debug",), ("RIO_DEBUG=1",)])
def test_debug_shows_the_nodes_traceback(so100_station, tmp_path, how):
    env = {**SO100_ENV, "XDG_CONFIG_HOME": str(tmp_path / "config")}
    args = ["teleop", so100_station("shm"), "--duration", "1"]
    if how == ("--debug",):
        args.insert(0, "--debug")
    else:
        env["RIO_DEBUG"] = "1"
    r = rio(*args, env=env)
    assert r.returncode == 1
    # the node process's traceback (where it was raised), then the command's own, then the one line
    assert "Traceback" in r.stderr and "in load_calibration" in r.stderr and "in _exit_status" in r.stderr
    assert error_line(r.stderr).startswith("error: node 'arm' failed to start: CalibrationError")


def test_unplugged_serial_port_is_one_line(so100_station, tmp_path):
    from rio_so100.calibration import default_calibration, save_calibration

    calibration = save_calibration(default_calibration("so100", "follower", "bench"), tmp_path / "cal.json")
    # the station's stable path of an adapter that is not plugged in (not a closed pty's: its number is reused)
    port = str(tmp_path / "serial" / "by-id" / "usb-1a86_USB_Single_Serial_5A46083210-if00")
    r = rio("teleop", so100_station("thread", port=port, calibration=str(calibration)), "--duration", "1",
            env=SO100_ENV)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert error_line(r.stderr) == (f"error: node 'arm' failed to start: BusError: cannot open Feetech bus on "
                                    f"{port}: [Errno 2] could not open port {port}: [Errno 2] No such file or "
                                    f"directory: '{port}'")


# --- after start-up, and bugs --------------------------------------------------------------------------


def test_a_node_error_after_start_up_is_one_log_line(caplog, monkeypatch):
    from rio.runtime.manager import _log_node_error

    def logged(e: BaseException, after_start: bool) -> list[logging.LogRecord]:
        caplog.clear()
        try:
            raise e
        except BaseException as raised:
            _log_node_error("arm", raised, after_start)
        return caplog.records

    with caplog.at_level(logging.ERROR, logger="rio.runtime.manager"):
        (rec,) = logged(RioError("servo 3 overheated"), after_start=True)
        assert rec.getMessage() == "node 'arm' stopped with an error: RioError: servo 3 overheated"
        assert rec.exc_info is None
        assert logged(RioError("no calibration"), after_start=False) == []  # the manager says it
        (bug,) = logged(ZeroDivisionError("division by zero"), after_start=False)
        assert bug.exc_info is not None  # a bug keeps its traceback
        monkeypatch.setenv("RIO_DEBUG", "1")
        (rec,) = logged(RioError("servo 3 overheated"), after_start=True)
        assert rec.exc_info is not None


# --- rio bench without portal ----------------------------------------------------------------------------


def test_bench_without_portal_is_one_line_per_failure():
    """portal (danijar's package) is optional: the bench measures RIO's portal middleware (our own
    code) and says in one line that the raw portal transport could not be measured."""
    blocked = ("import builtins, sys\nreal = builtins.__import__\n"
               "def blocked(name, *a, **k):\n"
               "    if name == 'portal' or name.startswith('portal.'):\n"
               "        raise ImportError(f\"No module named '{name}'\")\n"
               "    return real(name, *a, **k)\n"
               "builtins.__import__ = blocked\n"
               "from rio.cli import main\n"
               "sys.exit(main(['bench', 'middleware', '--middlewares', 'portal', '--n', '5', '--warmup', '1',"
               " '--rounds', '1', '--no-images']))\n")
    r = subprocess.run([sys.executable, "-c", blocked], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "RIO_DEBUG": "0", "RIO_LOAD_PLUGINS": ""})
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    assert "portal: raw transport failed (ImportError: No module named 'portal'); ratio left out" in r.stderr
    assert "[failed: ImportError: No module named 'portal']" in r.stdout


def test_bench_raw_server_failure_ends_its_process_quietly(monkeypatch):
    """A raw transport's server process that fails sends its error to the bench (one line there) and
    ends without the traceback multiprocessing would print, unless RIO_DEBUG."""
    from rio.benchmarks import raw_transports

    with pytest.raises(SystemExit) as ended:
        try:
            raise ImportError("No module named 'zmq'")
        except ImportError as e:
            raw_transports._end_child(e)
    assert ended.value.code == 1 and ended.value.__suppress_context__
    monkeypatch.setenv("RIO_DEBUG", "1")
    with pytest.raises(ImportError):
        raw_transports._end_child(ImportError("No module named 'zmq'"))


# --- station files and names ----------------------------------------------------------------------------


def invoke(*args: str):
    r = CliRunner().invoke(APP, list(args))
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise AssertionError(f"rio {' '.join(args)} raised {r.exception!r}") from r.exception
    return r


def test_unknown_station_is_one_line():
    r = invoke("teleop", "no-such-station", "--teleop", "scripted")
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert error_line(r.stderr).startswith("error: Invalid value for 'station': unknown station 'no-such-station'")
    assert len(r.stderr.strip().splitlines()) == 1


@pytest.fixture
def malformed(tmp_path) -> str:
    path = tmp_path / "broken.toml"
    path.write_text('name = "broken"\n[middleware\nname = "thread"\n')
    return str(path)


@pytest.mark.parametrize("command", [("stations", "check"), ("teleop",)])
def test_malformed_station_file_is_one_message(malformed, command):
    r = invoke(*command, malformed, *(["--teleop", "scripted"] if command == ("teleop",) else []))
    assert r.exit_code == 1 and "Traceback" not in r.output, r.output
    assert r.stderr.startswith(f"error: {malformed}:2:12: TOML syntax error"), r.stderr


def test_debug_shows_a_commands_traceback(malformed):
    r = invoke("--debug", "stations", "check", malformed)
    assert r.exit_code == 1
    assert r.stderr.startswith("Traceback") and "ConfigError" in r.stderr, r.stderr
    assert f"\nerror: {malformed}:2:12: TOML syntax error" in r.stderr
    assert os.environ["RIO_DEBUG"] == "1"  # what node processes started by the command inherit


def test_unknown_driver_is_one_line_and_its_traceback_with_debug():
    r = invoke("drivers", "show", "no.such")
    assert r.exit_code == 1 and r.stderr.startswith("error: unknown driver 'no.such'"), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    r = invoke("--debug", "drivers", "show", "no.such")
    assert r.exit_code == 1 and "Traceback" in r.stderr and "in show" in r.stderr, r.stderr


def test_a_bug_keeps_its_traceback(monkeypatch):
    """An exception that is not a RioError is not turned into a tidy line: it is a bug to report."""
    def broken(*_a, **_k):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr("rio.plugins.registry.get_registry", broken)
    r = CliRunner().invoke(APP, ["stations", "list"])
    assert isinstance(r.exception, ZeroDivisionError)


# --- shell completion ----------------------------------------------------------------------------------

QUICK = {"RIO_LOAD_PLUGINS": ""}


def test_show_completion_prints_a_script_for_rio():
    # typer's documented way to name the shell instead of detecting it (what its own tests do)
    r = rio("--show-completion", "bash", env={**QUICK, "_TYPER_COMPLETE_TEST_DISABLE_SHELL_DETECTION": "1"})
    assert r.returncode == 0, r.stderr
    assert "_rio_completion()" in r.stdout and "_RIO_COMPLETE=complete_bash" in r.stdout
    assert "complete -o default -F _rio_completion rio" in r.stdout


def test_completion_completes_commands_and_options():
    r = rio(env={**QUICK, "_RIO_COMPLETE": "complete_bash", "COMP_WORDS": "rio find-p", "COMP_CWORD": "1"})
    assert (r.returncode, r.stdout.split()) == (0, ["find-port"]), r.stderr
    r = rio(env={**QUICK, "_RIO_COMPLETE": "complete_bash", "COMP_WORDS": "rio find-port --", "COMP_CWORD": "2"})
    assert {"--timeout", "--replug", "--json"} <= set(r.stdout.split()), r.stdout


def test_help_lists_completion_and_debug():
    r = CliRunner().invoke(build_app(load_plugins=False), ["--help"], env={"COLUMNS": "200"})
    assert r.exit_code == 0
    assert all(opt in r.stdout for opt in ("--install-completion", "--show-completion", "--debug")), r.stdout


def test_install_completion_writes_the_shells_rc(tmp_path):
    """`--install-completion bash` adds the script to ~/.bashrc (a home of its own here)."""
    r = rio("--install-completion", "bash",
            env={**QUICK, "HOME": str(tmp_path), "_TYPER_COMPLETE_TEST_DISABLE_SHELL_DETECTION": "1"})
    assert r.returncode == 0, r.stderr
    assert "bash completion installed" in r.stdout
    assert "rio" in Path(tmp_path, ".bashrc").read_text()
