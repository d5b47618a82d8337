"""The hardware-free teleop devices as running nodes: the keyboard device reading a real terminal
(a pseudo-terminal here, as over SSH) and the scripted device's start-on-reset and done button."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from rio.runtime.manager import ServerManager, connect, serve
from rio.teleop.keyboard import KeyboardTeleop
from rio.teleop.scripted import ScriptedTeleop
from rio.testing import wait_until


def test_keyboard_reads_keys_from_a_terminal_and_restores_it():
    import termios

    master, slave = os.openpty()
    path = os.ttyname(slave)
    before = termios.tcgetattr(slave)
    try:
        with ServerManager([serve(KeyboardTeleop, "thread", name="kb", tty=path, hold_s=0.3)]):
            with connect(KeyboardTeleop, "thread", name="kb", tty=path) as kb:
                assert termios.tcgetattr(slave)[3] & termios.ICANON == 0  # cbreak while running
                assert np.allclose(kb.get_state()["twist"], 0)
                os.write(master, b"w")
                assert wait_until(lambda: kb.get_state()["twist"][0] > 0)
                os.write(master, b" ")
                assert wait_until(lambda: kb.get_state()["gripper"] == 0.0)
                os.write(master, b"q")
                assert wait_until(lambda: bool(kb.get_state()["buttons"][1]))
                assert "space gripper" in kb.help()
        assert termios.tcgetattr(slave) == before  # terminal settings restored on close
    finally:
        os.close(master)
        os.close(slave)


def test_a_paused_keyboard_leaves_the_terminal_to_the_prompt_until_its_reset():
    """Between recorded episodes the keyboard device reads nothing: the key waits in the terminal for the
    keep / discard prompt; after `reset()` (the next episode) it reads keys again."""
    import select

    master, slave = os.openpty()
    path = os.ttyname(slave)
    try:
        with ServerManager([serve(KeyboardTeleop, "thread", name="kb3", tty=path, hold_s=0.3)]):
            with connect(KeyboardTeleop, "thread", name="kb3", tty=path) as kb:
                kb.pause()
                os.write(master, b"y")
                time.sleep(0.3)  # many device cycles
                assert select.select([slave], [], [], 0)[0]  # still there, unread
                assert os.read(slave, 1) == b"y"  # what the prompt reads
                kb.reset()
                os.write(master, b"w")
                assert wait_until(lambda: kb.get_state()["twist"][0] > 0)
    finally:
        os.close(master)
        os.close(slave)


def test_keyboard_without_a_terminal_says_what_to_do(tmp_path):
    from rio.errors import RioError

    not_a_tty = tmp_path / "plain-file"
    not_a_tty.write_text("")
    with pytest.raises(RioError, match="scripted"):
        with ServerManager([serve(KeyboardTeleop, "thread", name="kb2", tty=str(not_a_tty))]):
            pass


def test_scripted_device_waits_for_reset_then_plays_and_presses_done():
    moves = [[0.02, 0, 0, 1.0, 0.3], [0, 0, 0, 0.0, 0.2]]
    with ServerManager([serve(ScriptedTeleop, "thread", name="sc", script="moves", moves=moves)]):
        with connect(ScriptedTeleop, "thread", name="sc", script="moves", moves=moves) as sc:
            time.sleep(0.1)
            s = sc.get_state()
            assert s["phase"] == -1 and np.allclose(s["twist"], 0) and not s["buttons"][1]
            assert sc.reset() == pytest.approx(0.5)
            assert wait_until(lambda: sc.get_state()["twist"][0] > 0.01)
            assert wait_until(lambda: sc.get_state()["gripper"] == 0.0)
            assert wait_until(lambda: bool(sc.get_state()["buttons"][1]), 2.0)
            assert np.allclose(sc.get_state()["offset"], [0.02, 0, 0])
