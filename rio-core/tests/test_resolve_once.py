"""A station is resolved once and a node is built once, where it runs (Core v3): counted, so that a layer that
starts loading the station again, or a client that builds its node again, fails here. Also: options that
change the station (`--teleop`) are applied to the validated station, never to the file's raw tables, and a
plugin adds a workflow (`rio <name>`) through the `rio_workflows` hook without editing core."""

from __future__ import annotations

import collections
import json
import sys
import textwrap

import pytest

from rio.cli import main
from rio.fakes.arms import FakeArm
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec
from rio.runtime.node import Node
from rio.station import load as station_load
from rio.testing import fake_eef_station

EPISODES = 3


@pytest.fixture
def counts(monkeypatch):
    """Station validations and node constructions (by class) in this process."""
    seen: collections.Counter[str] = collections.Counter()
    parse, init = station_load.parse_station, Node.__init__

    def counted_parse(*args, **kwargs):
        seen["station"] += 1
        return parse(*args, **kwargs)

    def counted_init(self, *args, **kwargs):
        seen[type(self).__name__] += 1
        init(self, *args, **kwargs)

    monkeypatch.setattr(station_load, "parse_station", counted_parse)
    monkeypatch.setattr(Node, "__init__", counted_init)
    return seen


def _station(tmp_path, mw: str = "thread"):
    path = tmp_path / "st.toml"
    text = fake_eef_station("once", 'driver = "rio.fake_teleop"\n').replace('name = "thread"', f'name = "{mw}"')
    path.write_text(text)
    return path


def test_teleop_recording_three_episodes_loads_the_station_once_and_builds_each_node_once(
        tmp_path, counts, capsys):
    data = tmp_path / "data"
    rc = main(["teleop", str(_station(tmp_path)), "--teleop", "scripted", "--record", str(data), "--episodes",
               str(EPISODES), "--on-end", "keep", "--duration", "0.4"])
    assert rc == 0, capsys.readouterr().err
    assert len([p for p in data.iterdir() if p.name.startswith("episode")]) == EPISODES
    # one station session for every episode: each node built once (it used to be once per episode); clients
    # build none
    assert counts == {"station": 1, "FakeArm": 1, "FakeGripper": 1, "ScriptedTeleop": 1}, counts


@pytest.mark.slow
def test_a_process_middleware_builds_no_node_in_the_callers_process(tmp_path, counts, capsys):
    rc = main(["teleop", str(_station(tmp_path, "shm")), "--teleop", "scripted", "--duration", "0.5", "--json"])
    assert rc == 0, capsys.readouterr().err
    assert json.loads(capsys.readouterr().out)["ticks"] > 0
    assert counts == {"station": 1}, counts  # each node was built in its own process, and only there


def test_a_client_reads_what_its_server_derived_without_building_the_node(tmp_path, counts):
    from rio import ServerManager, connect, serve

    with ServerManager("shm", [serve(FakeArm, name="arm", dof=4)], station="once"):
        with connect(FakeArm, "shm", name="arm", station="once", dof=4) as arm:
            assert arm.joint_names() == ["joint1", "joint2", "joint3", "joint4"] and arm.num_joints() == 4
            arm.move_joints([0.1, 0.0, 0.0, 0.0])
            assert arm.get_state()["joint_pos"].shape == (4,)
    assert counts["FakeArm"] == 0, counts


def test_a_teleop_option_on_a_malformed_station_is_refused_naming_the_field(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\ncomponents = 5\n')
    assert main(["teleop", str(bad), "--teleop", "scripted"]) == 1
    err = capsys.readouterr().err
    assert "components" in err and "Traceback" not in err and "AttributeError" not in err, err


def test_a_teleop_option_is_checked_like_the_line_it_stands_for(tmp_path, capsys):
    assert main(["teleop", str(_station(tmp_path)), "--teleop-set", "speed=-1", "--duration", "0.2"]) == 1
    assert "components.teleop" in capsys.readouterr().err


def test_a_plugin_adds_a_workflow_through_the_hook(tmp_path, registry, monkeypatch, capsys):
    (tmp_path / "lab_wave.py").write_text(textwrap.dedent('''
        """A lab's own workflow: hold the arm still for a while."""
        import typer

        from rio.cli.run_cmd import DurationOption, StationArgument, finish
        from rio.workflows import run_workflow


        class Hold:
            name = "hold"

            def reset(self, loop):
                pass

            def step(self, tick):
                return None

            def done(self):
                return None


        def hold(station: StationArgument, duration: DurationOption = 0.3) -> None:
            """Hold a station's arm still."""
            finish(run_workflow(station, lambda session: Hold(), duration=duration, log=None), json_out=True)
    '''))
    monkeypatch.syspath_prepend(str(tmp_path))
    mod = type(sys)("lab_plugin")
    mod.rio_workflows = hookimpl(lambda: [Spec("hold", "workflow", "lab_wave:hold", "hold the arm still")])
    registry.register(mod, name="lab", dist="rio-lab")
    assert main(["hold", str(_station(tmp_path)), "--duration", "0.3"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["workflow"] == "hold" and summary["reason"] == "duration reached"
    assert main(["plugins", "list", "--json"]) == 0
    listed = {p["distribution"]: p for p in json.loads(capsys.readouterr().out)["plugins"]}
    assert listed["rio-lab"]["provides"] == {"workflow": ["hold"]}


def test_a_workflow_cannot_take_a_command_name(registry, capsys):
    mod = type(sys)("clash_plugin")
    mod.rio_workflows = hookimpl(lambda: [Spec("doctor", "workflow", "json:dumps", "clashes")])
    registry.register(mod, name="clash", dist="rio-clash")
    assert main(["plugins", "list", "--json"]) == 0
    problems = json.loads(capsys.readouterr().out)["problems"]
    assert any("`rio doctor` is a command already" in p["message"] for p in problems), problems
