"""The packaged `cameras-fake` station: it validates, and its test-pattern camera's frames reach the
env's observation through the runtime (thread middleware), moving, with intrinsics."""

from __future__ import annotations

import numpy as np

from rio import ServerManager
from rio.station import make_station
from rio.station.load import load_station
from rio.testing import wait_until


def test_the_station_validates():
    st = load_station("cameras-fake")
    cam = st.components["front_camera"]
    assert cam.driver == "cameras.stream" and cam.config.url == "test:pattern"


def test_pattern_frames_reach_the_observation():
    servers, clients, env = make_station("cameras-fake")
    with ServerManager(servers), env:
        first = env.reset().observation.cameras["front"]
        assert first.rgb.shape == (120, 160, 3) and first.rgb.dtype == np.uint8
        assert tuple(first.rgb[2, 2]) == (255, 0, 0)  # the red bar, in RGB
        assert first.meta["intrinsics"].shape == (3, 3)
        assert wait_until(lambda: not np.array_equal(env.get_state().observation.cameras["front"].rgb, first.rgb))
        later = env.get_state().observation.cameras["front"]
        assert later.meta["timestamp"] > first.meta["timestamp"]
