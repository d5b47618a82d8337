"""Scenes: a table, one or more arms mounted on it, objects to pick and fixed cameras, composed in
code with MuJoCo's MjSpec (each robot's MJCF attached under a name prefix, `"<arm>/"`).

Every node of a station compiles the same scene from its name, so they agree on every index
(joint addresses, actuators, bodies) without shipping a model between processes. World frame: the
table top's center, z up; an arm's base frame is its mount.

A scene may also hold a humanoid (the Unitree G1 or the Booster T1, `rio_sim.humanoid_models`) standing
at the table, under its own prefix (`"g1/"`, `"t1/"`); `get_scene("<name>:floating")` is the same scene
with its base free instead of welded.

Objects sit where the packaged teleop script (`teleop.scripted`, preset "pick_place") expects them:
a cube `PICK_OFFSET` from each arm's home tool position and a flat target pad at `PLACE_OFFSET`, so
one script picks and places on every packaged scene, whatever the arm. A scene names those pairs
(`Scene.pick_place`: arm, cube, pad), which a task (`rio_sim.task`) moves at every episode start and
judges at the end.

The pad is a free body too, but weightless (gravity compensated) and without collisions: it stays
where it is put, and since its pose is part of the state every node reads from the world bus, a pad
moved at an episode start is where the cameras render it and where the world publishes it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache, lru_cache

import numpy as np

from .robots import get_robot
from .wrist_ft import add_wrist_ft

#: Where the cube and the place pad are, relative to an arm's home tool position (its base frame).
PICK_OFFSET = (0.0, 0.06, -0.085)
PLACE_OFFSET = (0.0, -0.06, -0.08)
CUBE = 0.025  # edge (m)
PAD = 0.06    # edge of the square place pad (m)
TABLE_HEIGHT = 0.75


@dataclass(frozen=True)
class ArmMount:
    name: str                 # prefix of the arm's names in the scene ("arm", "left", "right")
    robot: str                # key of rio_sim.robots.ROBOTS
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0          # rad, about z

    def to_world(self, p) -> np.ndarray:
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        x, y, z = p
        return np.array([c * x - s * y, s * x + c * y, z]) + np.asarray(self.pos)

    @property
    def quat(self) -> list[float]:
        return [float(np.cos(self.yaw / 2)), 0.0, 0.0, float(np.sin(self.yaw / 2))]


@dataclass(frozen=True)
class HumanoidMount:
    """A humanoid at the table: its root above `pos` (x, y) at standing height (the soles on the floor
    at home), facing `yaw`; `mounted`: welded there, as on a stand, else on a free joint."""

    name: str = "g1"          # prefix of its names in the scene
    hands: bool = True        # the G1's Dex3-1 hands, else Unitree's rubber hands (the T1 has none)
    robot: str = "g1"         # key of rio_sim.humanoid_models (g1, t1)
    pos: tuple[float, float] = (0.0, 0.0)
    yaw: float = 0.0
    mounted: bool = True


@dataclass(frozen=True)
class BaseMount:
    """A mobile base on the floor carrying the scene's arms on its deck: a planar body that slides in x and
    y and turns about z (joints `<name>/x`, `<name>/y`, `<name>/yaw`, in the world frame), each driven by a
    velocity actuator of the same name; `sim.base` turns a body twist into them. Its omni wheels are drawn
    (at `wheel_mounts_deg` around the center, `wheel_radius`) but carry nothing: the base is driven by its
    body twist, not by wheel contacts, so it never slips and its odometry error is the driver's alone."""

    name: str = "base"
    radius: float = 0.16          # chassis (m)
    height: float = 0.12          # deck above the floor (m): the arms' mount
    wheel_radius: float = 0.05
    wheel_mounts_deg: tuple[float, ...] = (60.0, 180.0, -60.0)
    arm_pos: tuple[float, float] = (0.06, 0.0)   # arm mount on the deck (base frame, m)


@dataclass(frozen=True)
class SceneObject:
    name: str
    shape: str                # "box" | "cylinder" | "sphere"
    size: tuple[float, ...]   # MuJoCo half-sizes
    pos: tuple[float, float, float]
    rgba: tuple[float, float, float, float]
    mass: float = 0.03
    free: bool = True         # a free joint: its pose is state (published, settable); False: fixed
    solid: bool = True        # False: a weightless marker that never collides (a place pad)


@dataclass(frozen=True)
class SceneCamera:
    name: str
    pos: tuple[float, float, float]
    lookat: tuple[float, float, float]
    fovy: float = 55.0


@dataclass(frozen=True)
class Scene:
    name: str
    description: str
    arms: tuple[ArmMount, ...]
    objects: tuple[SceneObject, ...] = ()
    cameras: tuple[SceneCamera, ...] = ()
    table: tuple[float, float] = (0.45, 0.6)   # half extents x, y
    table_center: tuple[float, float] = (0.15, 0.0)
    humanoid: HumanoidMount | None = None
    #: (arm, object, target): the arm that picks `object` and puts it on the pad `target`
    pick_place: tuple[tuple[str, str, str], ...] = ()
    #: a mobile base carrying the arms (their mounts are then on its deck)
    base: BaseMount | None = None

    def arm(self, name: str) -> ArmMount:
        for a in self.arms:
            if a.name == name:
                return a
        raise KeyError(f"scene '{self.name}' has no arm '{name}'; arms: {[a.name for a in self.arms]}")

    def camera_names(self) -> list[str]:
        """Fixed cameras, then each arm's wrist camera as `<arm>/<camera>`, then a humanoid's head camera."""
        wrists = [f"{a.name}/{get_robot(a.robot).wrist_camera}" for a in self.arms]
        return [c.name for c in self.cameras] + wrists + ([f"{self.humanoid.name}/head"] if self.humanoid else [])

    @property
    def free_objects(self) -> list[SceneObject]:
        return [o for o in self.objects if o.free]

    def reported_objects(self, chosen: list[str] | None = None) -> list[str]:
        """The free objects whose poses a world reports (`object_poses`, the recorded environment state):
        `chosen`, in its order, or all of them. ValueError naming an object the scene does not move."""
        free = [o.name for o in self.free_objects]
        if chosen is None:
            return free
        unknown = [n for n in chosen if n not in free]
        why = (f"scene '{self.name}' does not move {unknown}" if unknown else "name at least one" if not chosen
               else "each once" if len(set(chosen)) != len(chosen) else None)
        if why:
            raise ValueError(f"{why} (the scene's free objects: {', '.join(free)})")
        return list(chosen)

    def object(self, name: str) -> SceneObject:
        for o in self.objects:
            if o.name == name:
                return o
        raise KeyError(f"scene '{self.name}' has no object '{name}'; objects: {[o.name for o in self.objects]}")


def _pick_place_objects(arm: ArmMount, tag: str, colors: tuple) -> list[SceneObject]:
    home = np.asarray(get_robot(arm.robot).home_tool)
    cube = arm.to_world(home + PICK_OFFSET)
    pad = arm.to_world(home + PLACE_OFFSET)
    return [
        SceneObject(f"cube{tag}", "box", (CUBE / 2,) * 3, (cube[0], cube[1], CUBE / 2), colors[0]),
        SceneObject(f"pad{tag}", "box", (PAD / 2, PAD / 2, 0.001), (pad[0], pad[1], 0.001), colors[1], solid=False),
    ]


def _pairs(arms: tuple[ArmMount, ...], tags: tuple[str, ...]) -> tuple[tuple[str, str, str], ...]:
    return tuple((a.name, f"cube{t}", f"pad{t}") for a, t in zip(arms, tags, strict=True))


def _look(pos, lookat, fovy=55.0, name="front") -> SceneCamera:
    return SceneCamera(name, tuple(pos), tuple(lookat), fovy)


def _so100() -> Scene:
    arm = ArmMount("arm", "so100")
    objs = _pick_place_objects(arm, "", ((0.85, 0.2, 0.2, 1), (0.2, 0.4, 0.9, 1)))
    objs += [SceneObject("can", "cylinder", (0.016, 0.03), (0.27, -0.14, 0.03), (0.2, 0.7, 0.3, 1), mass=0.05),
             SceneObject("block", "box", (0.02, 0.012, 0.012), (0.13, 0.16, 0.012), (0.95, 0.8, 0.2, 1))]
    return Scene("so100", "SO-100 on a table: a red cube to pick, a blue pad to place it on, a can and a block",
                 (arm,), tuple(objs), (_look((0.55, 0.0, 0.35), (0.18, 0.0, 0.02)),),
                 table=(0.35, 0.4), table_center=(0.15, 0.0), pick_place=_pairs((arm,), ("",)))


def _bimanual() -> Scene:
    left, right = ArmMount("left", "so100", (0.0, 0.16, 0.0)), ArmMount("right", "so100", (0.0, -0.16, 0.0))
    objs = _pick_place_objects(left, "_left", ((0.85, 0.2, 0.2, 1), (0.2, 0.4, 0.9, 1)))
    objs += _pick_place_objects(right, "_right", ((0.95, 0.6, 0.1, 1), (0.3, 0.8, 0.4, 1)))
    return Scene("so100_bimanual", "two SO-100 side by side, a cube and a pad in front of each",
                 (left, right), tuple(objs), (_look((0.6, 0.0, 0.45), (0.18, 0.0, 0.0), 60),),
                 table=(0.35, 0.5), table_center=(0.15, 0.0), pick_place=_pairs((left, right), ("_left", "_right")))


def _one_arm(robot: str, label: str, can: tuple[float, float, float, float, float], camera: tuple,
             table: tuple[float, float], table_center: tuple[float, float]) -> Scene:
    """An industrial arm's table scene: the pick-and-place cube and pad in front of its home tool
    position, a can (`can` = radius, half height, x, y, mass) and a front camera (`camera` = position,
    look-at point)."""
    arm = ArmMount("arm", robot)
    objs = _pick_place_objects(arm, "", ((0.85, 0.2, 0.2, 1), (0.2, 0.4, 0.9, 1)))
    r, h, x, y, mass = can
    objs += [SceneObject("can", "cylinder", (r, h), (x, y, h), (0.2, 0.7, 0.3, 1), mass=mass)]
    return Scene(robot, f"{label} on a table: a red cube to pick, a blue pad, a can", (arm,), tuple(objs),
                 (_look(*camera, 55),), table=table, table_center=table_center, pick_place=_pairs((arm,), ("",)))


def _xarm7() -> Scene:
    return _one_arm("xarm7", "xArm7", (0.02, 0.04, 0.45, -0.18, 0.08), ((0.9, 0.0, 0.55), (0.35, 0.0, 0.05)),
                    (0.5, 0.5), (0.3, 0.0))


def _xarm6() -> Scene:
    return _one_arm("xarm6", "xArm6", (0.02, 0.04, 0.45, -0.18, 0.08), ((0.9, 0.0, 0.55), (0.35, 0.0, 0.05)),
                    (0.5, 0.5), (0.3, 0.0))


def _lite6() -> Scene:
    return _one_arm("lite6", "Lite 6", (0.018, 0.035, 0.33, -0.16, 0.06), ((0.7, 0.0, 0.45), (0.25, 0.0, 0.05)),
                    (0.4, 0.45), (0.2, 0.0))


def _panda() -> Scene:
    return _one_arm("panda", "Panda", (0.02, 0.04, 0.55, -0.2, 0.08), ((1.0, 0.0, 0.6), (0.45, 0.0, 0.05)),
                    (0.55, 0.5), (0.35, 0.0))


def _ur5e() -> Scene:
    return _one_arm("ur5e", "UR5e", (0.02, 0.04, 0.5, -0.2, 0.08), ((0.95, 0.0, 0.6), (0.4, 0.0, 0.05)),
                    (0.55, 0.55), (0.3, 0.0))


def _gen3() -> Scene:
    return _one_arm("gen3", "Kinova Gen3", (0.02, 0.04, 0.55, -0.2, 0.08), ((1.0, 0.0, 0.6), (0.45, 0.0, 0.05)),
                    (0.55, 0.5), (0.35, 0.0))


def _g1() -> Scene:
    """The G1's wrists are 0.08-0.12 m above this table at home, 0.25 m in front of the pelvis: the cube
    is a short reach forward and down for the right hand, the pad for the left."""
    objs = (SceneObject("cube", "box", (CUBE / 2,) * 3, (0.33, -0.12, CUBE / 2), (0.85, 0.2, 0.2, 1)),
            SceneObject("pad", "box", (PAD / 2, PAD / 2, 0.001), (0.33, 0.12, 0.001), (0.2, 0.4, 0.9, 1), solid=False))
    return Scene("g1", "Unitree G1 (29 DoF, Dex3-1 hands) on a stand at a table: a red cube, a blue pad", (),
                 objs, (_look((1.3, -0.6, 0.55), (0.2, 0.0, 0.1), 50),), table=(0.25, 0.5),
                 table_center=(0.45, 0.0), humanoid=HumanoidMount())


def _t1() -> Scene:
    """The T1 is shorter than the G1: at home its hands are ~0.09 m above this (same) table, 0.35 m in
    front of the trunk, its elbows just below the top, so the table starts 0.28 m in front of the trunk,
    clear of the forearms. The cube is a reach forward and down for the right hand, the pad for the left."""
    objs = (SceneObject("cube", "box", (CUBE / 2,) * 3, (0.4, -0.12, CUBE / 2), (0.85, 0.2, 0.2, 1)),
            SceneObject("pad", "box", (PAD / 2, PAD / 2, 0.001), (0.4, 0.12, 0.001), (0.2, 0.4, 0.9, 1), solid=False))
    return Scene("t1", "Booster T1 (23 DoF) on a stand at a table: a red cube, a blue pad", (), objs,
                 (_look((1.3, -0.6, 0.55), (0.3, 0.0, 0.05), 50),), table=(0.25, 0.5), table_center=(0.53, 0.0),
                 humanoid=HumanoidMount(name="t1", hands=False, robot="t1"))


def _lekiwi() -> Scene:
    """LeKiwi-like: an SO-100-class arm on a three-wheel base on the floor (world z = 0 is the table height
    of the other scenes, so the floor is at -TABLE_HEIGHT), a cube on the floor ahead to drive to, a low
    table off to the side as a landmark, a camera watching from the front."""
    base = BaseMount()
    floor = -TABLE_HEIGHT
    objs = (SceneObject("cube", "box", (CUBE / 2,) * 3, (0.6, 0.0, floor + CUBE / 2), (0.85, 0.2, 0.2, 1)),)
    return Scene("lekiwi", "LeKiwi-like mobile manipulator: an SO-100-class arm on a three-wheel base, a cube on "
                 "the floor ahead", (ArmMount("arm", "so100"),), objs,
                 (_look((1.6, -0.9, floor + 1.1), (0.3, 0.0, floor), 60),), table=(0.2, 0.3),
                 table_center=(0.9, -1.2), base=base)


SCENES = {"so100": _so100, "so100_bimanual": _bimanual, "xarm7": _xarm7, "xarm6": _xarm6, "lite6": _lite6,
          "panda": _panda, "ur5e": _ur5e, "gen3": _gen3, "g1": _g1, "t1": _t1,
          "lekiwi": _lekiwi}
FLOATING = ":floating"


@cache
def get_scene(name: str) -> Scene:
    base = name.removesuffix(FLOATING)
    if base not in SCENES:
        raise KeyError(f"unknown sim scene '{base}'; rio-sim ships: {', '.join(sorted(SCENES))}")
    scene = SCENES[base]()
    if name == base:
        return scene
    if scene.humanoid is None:
        raise ValueError(f"scene '{base}' has no humanoid: only a humanoid's base can float (mounted = false)")
    return replace(scene, name=name, humanoid=replace(scene.humanoid, mounted=False))


def scene_key(scene: str, mounted: bool = True) -> str:
    """The name every node of a world compiles: `scene`, or its free-floating variant."""
    return scene if mounted else f"{scene}{FLOATING}"


def _xyaxes(pos, lookat) -> list[float]:
    """Camera axes (MuJoCo looks along -z) for a camera at `pos` looking at `lookat`, image up ~ +z."""
    fwd = np.asarray(lookat, float) - np.asarray(pos, float)
    fwd /= np.linalg.norm(fwd)
    x = np.cross(fwd, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(x, fwd)
    return [*x, *y]


def build_spec(scene: Scene, max_render: tuple[int, int] = (1280, 960)):
    """The scene as an MjSpec (compile with `.compile()`)."""
    import mujoco

    spec = mujoco.MjSpec()
    spec.modelname = f"rio_sim_{scene.name}"
    spec.option.timestep = 0.002
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.visual.global_.offwidth, spec.visual.global_.offheight = max_render
    # CPU rendering (Mesa llvmpipe): no multisampling and no shadow maps roughly double the frame rate
    spec.visual.quality.offsamples = 0
    spec.visual.quality.shadowsize = 0
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    wb = spec.worldbody
    wb.add_light(pos=[0.3, 0.0, 1.5], dir=[0.0, 0.0, -1.0], diffuse=[0.6, 0.6, 0.6])
    wb.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.05], pos=[0, 0, -TABLE_HEIGHT],
                rgba=[0.55, 0.55, 0.58, 1], contype=1, conaffinity=3)
    (tx, ty), (cx, cy) = scene.table, scene.table_center
    wb.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=[tx, ty, TABLE_HEIGHT / 2],
                pos=[cx, cy, -TABLE_HEIGHT / 2], rgba=[0.62, 0.48, 0.34, 1], contype=1, conaffinity=3,
                friction=[1.0, 0.01, 0.001])
    mount = wb if scene.base is None else _add_base(spec, scene.base)
    for arm in scene.arms:
        robot = get_robot(arm.robot)
        child = mujoco.MjSpec.from_file(str(robot.path))
        frame = mount.add_frame(pos=list(arm.pos), quat=arm.quat)
        spec.attach(child, prefix=f"{arm.name}/", frame=frame)
        add_wrist_ft(spec, arm.name, robot.tool_site)
    if scene.humanoid is not None:
        _add_humanoid(spec, scene.humanoid)
    shapes = {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
              "sphere": mujoco.mjtGeom.mjGEOM_SPHERE}
    for obj in scene.objects:
        body = wb.add_body(name=obj.name, pos=list(obj.pos))
        kw = dict(name=obj.name, type=shapes[obj.shape], size=list(obj.size) + [0.0] * (3 - len(obj.size)),
                  rgba=list(obj.rgba))
        if obj.free:
            body.add_freejoint(name=obj.name)
        if obj.free and obj.solid:
            body.add_geom(**kw, mass=obj.mass, contype=1, conaffinity=3, condim=4, friction=[1.2, 0.02, 0.001],
                          solref=[0.004, 1.0])
        elif obj.free:  # a marker that moves only when put somewhere: weightless, touching nothing
            body.gravcomp = 1.0
            body.add_geom(**kw, mass=obj.mass, contype=0, conaffinity=0)
        else:
            body.add_geom(**kw, contype=0, conaffinity=0)
    for cam in scene.cameras:
        c = wb.add_camera(name=cam.name, pos=list(cam.pos), fovy=cam.fovy)
        c.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        c.alt.xyaxes = _xyaxes(cam.pos, cam.lookat)
    return spec


def _add_base(spec, b: BaseMount):
    """The mobile base (`BaseMount`): its body, planar joints, velocity actuators and drawn wheels; returns
    the deck frame the arms are mounted on."""
    import mujoco

    body = spec.worldbody.add_body(name=b.name, pos=[0.0, 0.0, -TABLE_HEIGHT + b.height])
    body.add_joint(name=f"{b.name}/x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    body.add_joint(name=f"{b.name}/y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0])
    body.add_joint(name=f"{b.name}/yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    body.add_geom(name=f"{b.name}/chassis", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                  size=[b.radius, b.height / 2 - 0.01, 0], pos=[0, 0, -b.height / 2 + 0.01], rgba=[0.9, 0.9, 0.88, 1],
                  mass=3.0, contype=0, conaffinity=0)
    for k, deg in enumerate(b.wheel_mounts_deg):
        a = np.radians(deg)
        c = [b.radius * np.cos(a), b.radius * np.sin(a), -b.height + b.wheel_radius]
        axis = [float(np.cos(a)), float(np.sin(a)), 0.0]  # the wheel's axle points out from the center
        q = _quat_z_to(axis)
        body.add_geom(name=f"{b.name}/wheel{k + 1}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                      size=[b.wheel_radius, 0.012, 0], pos=c, quat=q, rgba=[0.15, 0.15, 0.15, 1], mass=0.1,
                      contype=0, conaffinity=0)
    for joint, kv in (("x", 400.0), ("y", 400.0), ("yaw", 40.0)):
        act = spec.add_actuator(name=f"{b.name}/{joint}", target=f"{b.name}/{joint}",
                                trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_velocity(kv=kv)
    return body


def _quat_z_to(axis) -> list[float]:
    """The quaternion turning z onto the horizontal unit vector `axis` (a cylinder's axis)."""
    x, y, _ = axis
    # rotate 90 deg about the horizontal vector perpendicular to `axis`: (-y, x, 0)
    h = np.sqrt(0.5)
    return [h, -y * h, x * h, 0.0]


def _add_humanoid(spec, h: HumanoidMount) -> None:
    """The humanoid's asset, its motors made servos (`rio_sim.humanoid_models.to_servos`), standing on the
    floor below `h.pos`; the asset's own floor and light give way to the scene's."""
    import mujoco

    from .humanoid_models import get_humanoid, to_servos

    robot = get_humanoid(h.robot)
    child = mujoco.MjSpec.from_string(robot.asset_text(h.hands))
    child.delete(child.geom("floor"))
    for light in list(child.lights):
        child.delete(light)
    child.body(robot.BASE).pos = [0.0, 0.0, robot.STANDING_HEIGHT]
    to_servos(child, robot, h.mounted)
    quat = [float(np.cos(h.yaw / 2)), 0.0, 0.0, float(np.sin(h.yaw / 2))]
    frame = spec.worldbody.add_frame(pos=[*h.pos, -TABLE_HEIGHT], quat=quat)
    spec.attach(child, prefix=f"{h.name}/", frame=frame)


@lru_cache(maxsize=8)
def build_model(name: str):
    """The compiled MjModel of a packaged scene (cached per process; treat it as read-only)."""
    return build_spec(get_scene(name)).compile()
