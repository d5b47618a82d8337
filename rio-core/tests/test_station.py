"""Station files: validation with actionable errors (closest driver, full field paths, file:line)."""

from __future__ import annotations

import sys
import textwrap
import types

import pytest

from rio.errors import ConfigError
from rio.plugins import Registry
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec
from rio.station import load_station, make_station, parse_station

SERIAL_ARM = """
from pydantic import Field
from rio.fakes.arms import FakeArm


class SerialArm(FakeArm):
    class Config(FakeArm.Config):
        port: str
        baudrate: int = Field(1_000_000, gt=0)
"""


@pytest.fixture
def reg(tmp_path):
    """Core plugin plus an inline one: an arm with a required `port` and a packaged station."""
    reg = Registry(load_entry_points=False)
    mod = types.ModuleType("station_test_plugin")
    pkg = tmp_path / "stpkg"
    (pkg / "stations").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "serial_arm.py").write_text(SERIAL_ARM)
    (pkg / "stations" / "demo.toml").write_text('name = "pkg-demo"\n[components.arm]\ndriver = "rio.fake_arm"\n')
    (tmp_path / "abs.toml").write_text('name = "abs-demo"\n[components.humanoid]\ndriver = "rio.fake_humanoid"\n')

    @hookimpl
    def rio_drivers():
        return [Spec("acme.serial_arm", "arm", "stpkg.serial_arm:SerialArm", "needs a port")]

    @hookimpl
    def rio_stations():
        return [Spec("pkg-demo", "station", "stpkg:stations/demo.toml"),
                Spec("abs-demo", "station", str(tmp_path / "abs.toml"))]

    mod.rio_drivers, mod.rio_stations = rio_drivers, rio_stations
    reg.register(mod, name="st-test")
    sys.path.insert(0, str(tmp_path))
    yield reg
    sys.path.remove(str(tmp_path))
    sys.modules.pop("stpkg", None)
    sys.modules.pop("stpkg.serial_arm", None)


def write(tmp_path, text: str, name: str = "station.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


GOOD = """
    name = "bench-1"
    description = "an arm, a gripper and a camera"
    rate_hz = 50

    [middleware]
    name = "thread"
    call_timeout = 2.5

    [components.arm]
    driver = "rio.fake_arm"
    dof = 7

    [components.gripper]
    driver = "rio.fake_gripper"
    max_width = 0.085

    [components.wrist_camera]
    driver = "rio.fake_camera"
    depth = true
"""


def test_valid_station(tmp_path, reg):
    st = load_station(write(tmp_path, GOOD), registry=reg)
    assert (st.name, st.rate_hz, st.middleware) == ("bench-1", 50.0, "thread")
    assert st.middleware_options == {"call_timeout": 2.5}
    assert st.roles() == {"arm", "gripper", "wrist_camera"}
    arm = st.components["arm"]
    assert (arm.kind, arm.driver, arm.spec.plugin) == ("arm", "rio.fake_arm", "rio-core")
    assert arm.kwargs()["dof"] == 7 and arm.kwargs()["rate_hz"] == 100.0 and arm.kwargs()["home"] is None
    assert isinstance(arm.config, arm.node_class().Config)  # the validated object the node receives
    assert st.components["wrist_camera"].kwargs()["depth"] is True
    assert st.embodiment is None and st.embodiment_options == {}


def test_unknown_driver_lists_registered_names_with_closest(tmp_path, reg):
    path = write(tmp_path, """
        name = "s"
        [components.arm]
        driver = "rio.fake_amr"
    """)
    with pytest.raises(ConfigError) as e:
        load_station(path, registry=reg)
    msg = str(e.value)
    assert str(path) in msg
    assert "components.arm.driver: unknown arm driver 'rio.fake_amr'; did you mean 'rio.fake_arm'?" in msg
    assert "registered: acme.serial_arm, rio.fake_arm" in msg


def test_driver_of_the_wrong_kind(reg):
    with pytest.raises(ConfigError, match=r"components\.arm\.driver: 'rio.fake_gripper' is a gripper driver; "
                                          r"role 'arm' needs a arm driver"):
        parse_station({"name": "s", "components": {"arm": {"driver": "rio.fake_gripper"}}}, registry=reg)


def test_field_errors_give_full_paths_all_at_once(reg):
    data = {"name": "s", "components": {
        "arm": {"driver": "acme.serial_arm", "baudrate": -1},            # port missing, baudrate bad
        "gripper": {"driver": "rio.fake_gripper", "max_widht": 0.1},     # typo
        "amr2": {"driver": "rio.fake_arm"},                              # unknown role
        "front_camera": {"width": 64},                                   # no driver
    }}
    with pytest.raises(ConfigError) as e:
        parse_station(data, registry=reg)
    lines = str(e.value).splitlines()
    assert lines[0] == "invalid station <dict>:"
    body = "\n".join(lines[1:])
    assert "components.arm.port: required field missing" in body
    assert "components.arm.baudrate: Input should be greater than 0 (got -1)" in body
    assert ("components.gripper.max_widht: unknown field; did you mean 'max_width'? "
            "(allowed: disable_on_close, enable_on_open, force, max_step_m, max_width, rate_hz, watchdog_s)") in body
    assert "components.amr2: unknown role 'amr2'; did you mean 'arm2'?" in body
    assert ("components.front_camera.driver: required field missing "
            "(a registered camera driver: rio.fake_camera)") in body


def test_top_level_errors(reg):
    with pytest.raises(ConfigError, match=r"rate_hz: Input should be greater than or equal to 1"):
        parse_station({"name": "s", "rate_hz": 0, "components": {"arm": {"driver": "rio.fake_arm"}}}, registry=reg)
    with pytest.raises(ConfigError, match=r"name: required field missing"):
        parse_station({"components": {"arm": {"driver": "rio.fake_arm"}}}, registry=reg)
    with pytest.raises(ConfigError, match=r"contrl_rate: unknown field"):
        parse_station({"name": "s", "contrl_rate": 3, "components": {"arm": {"driver": "rio.fake_arm"}}}, registry=reg)


def test_toml_syntax_error_gives_file_and_line(tmp_path, reg):
    path = write(tmp_path, 'name = "s"\n[components.arm]\ndriver = rio.fake_arm\n')
    with pytest.raises(ConfigError) as e:
        load_station(path, registry=reg)
    first = str(e.value).splitlines()[0]
    assert first.startswith(f"{path}:3:10: TOML syntax error: Invalid value")
    assert "driver = rio.fake_arm" in str(e.value)


def test_station_by_registered_name(reg):
    assert load_station("pkg-demo", registry=reg).name == "pkg-demo"        # package resource
    assert load_station("abs-demo", registry=reg).roles() == {"humanoid"}   # absolute path
    with pytest.raises(ConfigError, match=r"unknown station 'pkg-dmeo'; did you mean 'pkg-demo'\?"):
        load_station("pkg-dmeo", registry=reg)
    with pytest.raises(ConfigError, match="station file not found"):
        load_station("does/not/exist.toml", registry=reg)


def test_middleware_options_are_checked_by_the_middleware(tmp_path, reg):
    path = write(tmp_path, """
        name = "s"
        [middleware]
        name = "thread"
        call_timout = 1
        [components.arm]
        driver = "rio.fake_arm"
    """)
    with pytest.raises(ConfigError, match=r"middleware\.call_timout: unknown field; did you mean 'call_timeout'\?"):
        make_station(path, registry=reg)
    st = load_station(path, registry=reg)  # the file itself is structurally valid
    assert st.middleware_options == {"call_timout": 1}
    with pytest.raises(ConfigError, match=r"middleware\.name: unknown middleware 'thred'; did you mean 'thread'\?"):
        make_station(path, middleware="thred", registry=reg)


def test_embodiment_options_are_checked_by_the_embodiment(reg):
    data = {"name": "s", "embodiment": {"action_space": "cartesian"},
            "middleware": {"name": "thread"}, "components": {"arm": {"driver": "rio.fake_arm"}}}
    with pytest.raises(ConfigError, match=r"embodiment\.action_space: Input should be 'joint_pos' or 'eef_pose'"):
        make_station(parse_station(data, registry=reg), registry=reg)


def test_unknown_station_and_driver_say_which_plugin_provides_them(reg):
    """A name from one of RIO's own plugins that is not loaded says which distribution to get."""
    with pytest.raises(ConfigError, match=r"unknown station 'sim-so100'.*rio-sim"):
        load_station("sim-so100", registry=reg)
    with pytest.raises(ConfigError, match=r"components\.arm\.driver: unknown arm driver 'so101.follower'.*rio-so100"):
        parse_station({"name": "s", "components": {"arm": {"driver": "so101.follower", "port": "x"}}}, registry=reg)


@pytest.mark.parametrize("content, words", [
    (bytes(range(0xF2, 0xFF)) * 20, r"not UTF-8 text \(byte 0xf2 at offset 0\)"),
    (b'name = "s"\nx = ' + b"[" * 5000 + b"]" * 5000 + b"\n", "nested too deeply"),
    (b"# " + b"x" * (1 << 20) + b"\n", "too large for a station or config file"),
])
def test_any_bytes_end_in_one_line_naming_the_file(tmp_path, reg, content, words):
    """The hardening probe's station files: random binary, a 5000-deep array, a huge file; each was a
    traceback (UnicodeDecodeError, RecursionError) or a long parse."""
    path = tmp_path / "bad.toml"
    path.write_bytes(content)
    with pytest.raises(ConfigError, match=words) as e:
        load_station(path, registry=reg)
    assert str(e.value).startswith(str(path)) and len(str(e.value).splitlines()) == 1


@pytest.mark.parametrize("role", ["../../escaped_camera", "a/b_camera", "front cam_camera", "x.y_sensor",
                                  "_camera", "1st_camera"])
def test_camera_and_sensor_names_are_identifiers(reg, role):
    """A role names files and columns in datasets: "../../escaped_camera" made the recorder write outside
    the dataset directory."""
    with pytest.raises(ConfigError, match=r"unknown role .*<name>: letters, digits, _"):
        parse_station({"name": "s", "components": {"arm": {"driver": "rio.fake_arm"},
                                                   role: {"driver": "rio.fake_camera"}}}, registry=reg)
