"""The prompt between recorded episodes: single keys in a terminal (no Enter), keys that are not the keyboard
teleop's, and Ctrl+C asked about when interactive, kept (and said) when headless."""

from __future__ import annotations

import os
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

from rio import clock
from rio.cli.keypress import read_key
from rio.cli.teleop_cmd import KEYS, decider, record_episodes
from rio.loop.summary import RunSummary
from rio.recording import Dataset
from rio.recording.synthetic import synthetic_step
from rio.teleop.keyboard import _ANGULAR, _LINEAR

STATION = SimpleNamespace(name="fake", rate_hz=30.0, has_cameras=False, components={})


@pytest.fixture
def pty():
    """A terminal already in cbreak mode (a canonical one holds typed keys back until Enter)."""
    import tty

    master, slave = os.openpty()
    tty.setcbreak(slave)
    yield master, slave
    os.close(master)
    os.close(slave)


def test_no_prompt_key_is_a_keyboard_teleop_key():
    teleop_keys = set(_LINEAR) | set(_ANGULAR) | {" ", "m", "q", "\n", "\r"}
    assert not set(KEYS) & teleop_keys


def test_a_single_key_answers_without_enter_and_other_keys_are_ignored(pty):
    master, slave = pty
    os.write(master, b"kdrwY")  # teleop keys typed a moment too late, then the answer (no Enter)
    assert read_key(KEYS, tty=slave, flush=False) == "y"


def test_the_prompt_drops_keys_typed_before_it(pty):
    master, slave = pty
    os.write(master, b"n")  # typed during the episode
    got = []
    t = threading.Thread(target=lambda: got.append(read_key(KEYS, tty=slave)))
    t.start()
    clock.precise_wait(clock.now() + 0.5)
    os.write(master, b"e")
    t.join(5)
    assert got == ["e"]


def test_a_stop_signal_ends_the_wait_with_no_answer(pty):
    _, slave = pty
    calls = []

    def stopped():
        calls.append(1)
        return len(calls) > 3

    assert read_key(KEYS, tty=slave, stopped=stopped, poll_s=0.01) is None


def _fake_session(outcomes):
    """A session that records one short episode per run and asks `decide`, as record_session does: the runs end
    as `outcomes` say (None: normally; a signal name: stopped by it)."""
    asked = []

    def session(rec, decide):
        for signal in outcomes:
            for i in range(3):
                rec.add(synthetic_step(i, clock.now()))
            s = RunSummary("teleop", "fake")
            s.signal = signal
            choice, go_on = decide(s, rec, SimpleNamespace(received=signal))
            asked.append(choice)
            rec.keep() if choice == "keep" else rec.discard()
            if rec.done or signal or not go_on:
                return s
        return s

    return session, asked


def test_keep_discard_rerecord_by_single_keys_in_a_terminal(tmp_path: Path, pty):
    """n discards, e re-records, y keeps; the kept episodes are numbered without gaps."""
    master, slave = pty
    os.write(master, b"neyy")
    session, asked = _fake_session([None] * 4)
    root = tmp_path / "ds"
    record_episodes(session, str(root), 2, "ask", STATION, None, None, json_out=True,
                    read=lambda stopped: read_key(KEYS, tty=slave, stopped=stopped, flush=False))
    assert asked == ["discard", "rerecord", "keep", "keep"]
    assert [e["index"] for e in Dataset(root).episodes] == [0, 1]
    assert len(list((root / ".discarded").iterdir())) == 2


def test_ctrl_c_is_asked_about_when_interactive(tmp_path: Path, pty, capsys):
    master, slave = pty
    os.write(master, b"n")
    session, asked = _fake_session(["SIGINT", None])
    record_episodes(session, str(tmp_path / "ds"), 3, "ask", STATION, None, None, json_out=True,
                    read=lambda stopped: read_key(KEYS, tty=slave, stopped=stopped, flush=False))
    assert asked == ["discard"]  # asked, answered, and the session ended there
    assert "(stopped by SIGINT): [y] keep, [n] discard, [e] re-record?" in capsys.readouterr().err


def test_ctrl_c_keeps_the_episode_when_headless_and_says_so(capsys):
    decide = decider("auto", ask=False, json_out=True)
    s = RunSummary("teleop", "fake")
    s.signal = "SIGINT"
    assert decide(s, None, None) == ("keep", False)
    assert "stopped by SIGINT without a terminal to ask: the episode is kept" in capsys.readouterr().err
    s.signal = None
    assert decide(s, None, None) == ("keep", True)
    assert decider("discard", ask=False, json_out=True)(s, None, None) == ("discard", False)  # never loops forever
