"""The core's own plugin: the built-in middlewares, embodiments, fake devices and workflows, registered
through the same hooks a third-party plugin uses (so nothing in core is special-cased)."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec


@hookimpl
def rio_middlewares() -> list[Spec]:
    return [
        Spec("thread", "middleware", "rio.middleware.thread:ThreadMiddleware",
             "nodes as threads of one process; one stack trace, best for debugging"),
        Spec("shm", "middleware", "rio.middleware.shm:ShmMiddleware",
             "a process per node; state and requests in shared memory, zero-copy reads"),
        Spec("zmq", "middleware", "rio.middleware.zmq:ZmqMiddleware",
             "pyzmq over TCP; multi-machine; state mirrored into a local ring buffer"),
        Spec("zenoh", "middleware", "rio.middleware.zenoh:ZenohMiddleware",
             "eclipse-zenoh 1.x; multi-machine through routers; key expressions rio/<station>/<node>/*"),
        Spec("portal", "middleware", "rio.middleware.portal:PortalMiddleware",
             "danijar's portal RPC wire format, as in the RIO paper (our own client and server)"),
    ]


@hookimpl
def rio_workflows() -> list[Spec]:
    return [
        Spec("teleop", "workflow", "rio.cli.teleop_cmd:teleop",
             "teleoperate a station's arms, hands or humanoid (twist devices, leader arms, hand trackers)"),
        Spec("deploy", "workflow", "rio.cli.deploy_cmd:deploy", "run a policy on a station"),
        Spec("eval", "workflow", "rio.cli.eval_cmd:eval_",
             "a policy's success rate on a station's task: N seeded trials, completion times"),
        Spec("replay", "workflow", "rio.cli.replay_cmd:replay", "play a recorded episode back on a station"),
        Spec("run", "workflow", "rio.cli.run_cmd:run", "your own controller (module:Class) on a station"),
    ]


@hookimpl
def rio_embodiments() -> list[Spec]:
    return [
        Spec("single_arm", "embodiment", "rio.embodiments.single_arm:SingleArm",
             "arm [+ gripper] [+ hand] -> SingleArmObs"),
        Spec("bimanual", "embodiment", "rio.embodiments.bimanual:Bimanual",
             "arm + arm2, each [+ gripper] [+ hand] -> BimanualObs"),
        Spec("humanoid", "embodiment", "rio.embodiments.humanoid:Humanoid",
             "humanoid [+ hand, hand2] -> HumanoidObs"),
        Spec("mobile_manipulator", "embodiment", "rio.embodiments.mobile:MobileManipulator",
             "base + arm [+ gripper] [+ hand] -> MobileManipulatorObs"),
    ]


_FAKE = "in-process fake, no hardware or simulator (tests, examples)"


@hookimpl
def rio_drivers() -> list[Spec]:
    f = "rio.fakes"
    return [
        Spec("rio.fake_arm", "arm", f"{f}.arms:FakeArm", f"arm: {_FAKE}"),
        Spec("rio.fake_model_arm", "arm", f"{f}.arms:FakeModelArm",
             "6-joint arm with a robot model and no Cartesian control (end-effector poses by FK/IK); tests"),
        Spec("rio.fake_gripper", "gripper", f"{f}.arms:FakeGripper", f"gripper: {_FAKE}"),
        Spec("rio.fake_base", "base", f"{f}.base:FakeBase", f"three-wheel omni base: {_FAKE}"),
        Spec("rio.fake_camera", "camera", f"{f}.sensors:FakeCamera", f"camera: {_FAKE}"),
        Spec("rio.fake_teleop", "teleop", f"{f}.teleop:FakeTeleop", f"teleop: {_FAKE}"),
        Spec("rio.fake_hand_tracker", "teleop", f"{f}.teleop:FakeHandTracker",
             "a headset's hand tracking, scripted (wrist motion, finger curl, pinch, loss); tests"),
        Spec("rio.fake_hand", "hand", f"{f}.hands:FakeHand", f"hand: {_FAKE}"),
        Spec("rio.fake_humanoid", "humanoid", f"{f}.humanoid:FakeHumanoid", f"humanoid: {_FAKE}"),
        Spec("rio.fake_model_hand", "hand", f"{f}.hands:FakeModelHand",
             "20-joint five-finger hand with a robot model (hand-tracking retargeting); tests"),
        Spec("rio.fake_model_humanoid", "humanoid", f"{f}.humanoid:FakeModelHumanoid",
             "21-joint humanoid upper body with a robot model (wrist IK, legs left alone); tests"),
        Spec("rio.fake_sensor", "sensor", f"{f}.sensors:FakeSensor", f"sensor (a constant reading): {_FAKE}"),
        Spec("rio.fake_wrench", "sensor", f"{f}.sensors:FakeWrench",
             f"force/torque sensor (wrench kind; a constant load with noise): {_FAKE}"),
        # Teleop devices that need no hardware
        Spec("teleop.scripted", "teleop", "rio.teleop.scripted:ScriptedTeleop",
             "scripted end-effector moves (pick and place); headless demos and tests"),
        Spec("teleop.keyboard", "teleop", "rio.teleop.keyboard:KeyboardTeleop",
             "terminal keys (works over SSH): move, rotate, gripper, mode, finish"),
    ]


@hookimpl
def rio_requirements() -> list[Requirement]:
    """The core's optional extras: each is needed only by the feature named in its purpose."""
    ik = "pip install 'rio-core[ik]'"
    return [
        Requirement("zenoh", "pip install 'rio-core[zenoh]'", "the zenoh middleware (multi-machine through routers)"),
        Requirement("cryptography", "pip install 'rio-core[keys]'", "`rio keys`: the certificates of multi-machine "
                                                                     "stations"),
        Requirement("copier", "pip install 'rio-core[new]'", "`rio new plugin` templates"),
        Requirement("av", "pip install 'rio-core[record]'", "recording: camera streams encoded as video"),
        Requirement("mujoco", ik, "rio.kinematics: MuJoCo models (MinkSolver)"),
        Requirement("mink", ik, "rio.kinematics: inverse kinematics on MuJoCo models (MinkSolver)"),
        Requirement("pinocchio", ik, "rio.kinematics: inverse kinematics on URDF models (PinocchioSolver)"),
    ]
