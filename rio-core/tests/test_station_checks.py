"""`rio stations check` says what a start would say: a node placed on another machine at an address
beyond loopback without keys is refused there as at every start (it printed `ok`); and every number of a
station file is finite and every rate in range, the field named (`rate_hz = inf` passed validation, and
`inf`/`nan` in a component's safety fields would have switched the safety off)."""

from __future__ import annotations

import pytest

from rio.cli import main as rio_main

BASE = 'name = "checks"\n{top}[middleware]\nname = "{mw}"\n{mw_extra}[components.arm]\ndriver = "rio.fake_arm"\n{arm}'
PLACED = '[machines.robot]\naddress = "{address}"\nnodes = ["arm"]\n'


def _station(tmp_path, *, top="", mw="zmq", mw_extra="", arm="", machines=""):
    path = tmp_path / "station.toml"
    path.write_text(BASE.format(top=top, mw=mw, mw_extra=mw_extra, arm=arm) + machines)
    return str(path)


def _check(path, capsys) -> tuple[int, str]:
    code = rio_main(["stations", "check", path])
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err
    return code, " ".join((out.out + out.err).split())


@pytest.mark.parametrize("mw", ["zmq", "zenoh"])
def test_a_node_placed_beyond_loopback_without_keys_is_refused_as_a_start_would(tmp_path, capsys, mw):
    path = _station(tmp_path, mw=mw, machines=PLACED.format(address="192.168.1.20"))
    code, text = _check(path, capsys)
    assert code == 1 and "machines.robot" in text and "192.168.1.20 is reachable from other machines" in text
    assert not text.endswith("ok")
    assert rio_main(["serve", path, "--machine", "robot"]) == 1  # what every start says
    assert "192.168.1.20 is reachable" in capsys.readouterr().err


def test_placements_on_loopback_with_insecure_or_with_keys_pass(tmp_path, capsys):
    pytest.importorskip("cryptography")
    from rio.machine import keys

    assert _check(_station(tmp_path, machines=PLACED.format(address="127.0.0.1")), capsys)[0] == 0
    insecure = _station(tmp_path, mw_extra="insecure = true\n", machines=PLACED.format(address="10.0.0.2"))
    assert _check(insecure, capsys)[0] == 0
    keys.generate(tmp_path / "keys", ["robot", "laptop"])
    keyed = _station(tmp_path, mw_extra=f'keys = "{tmp_path / "keys" / "laptop"}"\n',
                     machines=PLACED.format(address="10.0.0.2"))
    code, text = _check(keyed, capsys)
    assert code == 0 and text.endswith("ok"), text


@pytest.mark.parametrize(("where", "value", "said"), [
    ("top", "rate_hz = inf", "rate_hz: Input should be a finite number"),
    ("top", "rate_hz = nan", "rate_hz: Input should be a finite number"),
    ("top", "rate_hz = 1e-9", "rate_hz: Input should be greater than or equal to 1"),
    ("top", "rate_hz = 1e6", "rate_hz: Input should be less than or equal to 10000"),
    ("arm", "max_step_rad = inf", "components.arm.max_step_rad: Input should be a finite number"),
    ("arm", "watchdog_s = nan", "components.arm.watchdog_s: Input should be a finite number"),
    ("arm", "joint_limits = [[nan, 1.0], [-1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0]]",
     "components.arm.joint_limits.0.0: Input should be a finite number"),
    ("mw_extra", "call_timeout = inf", "middleware.call_timeout: Input should be a finite number"),
])
def test_every_number_of_a_station_is_finite_the_field_named(tmp_path, capsys, where, value, said):
    code, text = _check(_station(tmp_path, **{where: value + "\n"}), capsys)
    assert code == 1 and said in text, text
