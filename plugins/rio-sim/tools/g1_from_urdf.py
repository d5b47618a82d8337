"""Writes rio-sim's Unitree G1 models (`assets/g1.xml`, `assets/g1_hands.xml`) from Unitree's URDFs.

Run once by a maintainer, not at install or run time; the generated XML is what rio-sim ships:

    pip download --no-deps example-robot-data==6.0.0 -d /tmp/erd && unzip -q /tmp/erd/*.whl -d /tmp/erd
    python plugins/rio-sim/tools/g1_from_urdf.py \
        /tmp/erd/cmeel.prefix/share/example-robot-data/robots/g1_description plugins/rio-sim/src/rio_sim/assets

Kinematics, limits, masses and inertias are copied from the URDF as they are; the meshes are only read
for their bounding boxes, which size one primitive geom per link (a capsule for a long link, else a box),
so the models stay a few tens of kilobytes and render fast on a CPU.
"""

from __future__ import annotations

import struct
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

#: Unitree's motor order (G1 29-DoF LowCmd/LowState indices 0-28), then each Dex3-1's (HandCmd indices 0-6,
#: as in Unitree's xr_teleoperate: the left hand thumb, middle, index; the right hand thumb, index, middle).
LEG = ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")
ARM = ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw")
BODY_MOTORS = ([f"left_{j}_joint" for j in LEG] + [f"right_{j}_joint" for j in LEG]
               + ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint"]
               + [f"left_{j}_joint" for j in ARM] + [f"right_{j}_joint" for j in ARM])
HAND_MOTORS = {"left": ("thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1"),
               "right": ("thumb_0", "thumb_1", "thumb_2", "index_0", "index_1", "middle_0", "middle_1")}

#: Reflected rotor inertia (kg m^2) of each Unitree motor, keyed by the joint's effort limit (N m), from
#: Unitree's rotor inertias and gear ratios (as used by the G1 configurations of unitree_rl_lab and mjlab);
#: the 35 N m joints (ankles, waist roll/pitch) are driven by two 5020 motors through a linkage.
ARMATURE = {139.0: 0.025101925, 88.0: 0.01017752, 35.0: 2 * 0.003609725, 25.0: 0.003609725, 5.0: 0.00425}
FINGER_ARMATURE = 1e-4  # Dex3-1 finger motors: small, but enough to keep their 1.5 N m/rad servo stable at 2 ms

DROP = {"pelvis_contour_link", "logo_link"}  # 1 g placeholder links of the meshes
SITES = {"imu_in_pelvis", "imu_in_torso", "d435_link", "mid360_link"}
REACH = ("elbow", "wrist", "hand", "rubber")  # forearms and hands: they also touch the torso, pelvis and legs
BODY = ("pelvis", "hip", "knee", "ankle", "torso", "head", "waist")  # what a forearm or hand may touch


def _fmt(v, digits: int = 6) -> str:
    """Numbers as the URDF writes them (`digits` significant), or geometry to 0.1 mm (`digits` < 0)."""
    if digits < 0:
        return " ".join(f"{round(float(x), -digits) + 0.0:g}" for x in np.atleast_1d(v))  # + 0.0: no "-0"
    return " ".join(f"{float(x):.{digits}g}" if abs(float(x)) > 1e-12 else "0" for x in np.atleast_1d(v))


def _rpy_quat(rpy) -> np.ndarray:
    r, p, y = (float(a) / 2 for a in rpy)
    qx = np.array([np.cos(r), np.sin(r), 0, 0])
    qy = np.array([np.cos(p), 0, np.sin(p), 0])
    qz = np.array([np.cos(y), 0, 0, np.sin(y)])
    return _qmul(_qmul(qz, qy), qx)


def _qmul(a, b) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _stl_box(path: Path) -> tuple[np.ndarray, np.ndarray]:
    raw = path.read_bytes()
    if raw[:5] == b"solid" and b"facet" in raw[:300]:
        v = np.array([[float(t) for t in line.split()[1:4]] for line in raw.decode().splitlines()
                      if line.strip().startswith("vertex")])
    else:
        n = struct.unpack("<I", raw[80:84])[0]
        rec = np.frombuffer(raw[84:84 + 50 * n], dtype=np.dtype([("n", "<3f4"), ("v", "<9f4"), ("a", "<u2")]))
        v = rec["v"].reshape(-1, 3).astype(float)
    return v.min(0), v.max(0)


def _vec(el, attr: str, default: str = "0 0 0") -> np.ndarray:
    return np.array([float(t) for t in (el.get(attr) if el is not None and el.get(attr) else default).split()])


def _geom(name: str, lo: np.ndarray, hi: np.ndarray, cls: str) -> str:
    """One primitive filling the box [lo, hi]: a capsule along a clearly longest axis, else a box."""
    ext, mid = hi - lo, (hi + lo) / 2
    order = np.argsort(ext)[::-1]
    if ext[order[0]] > 1.6 * ext[order[1]]:
        r = 0.5 * float(np.mean(ext[order[1:]]))
        a = np.zeros(3)
        a[order[0]] = max(ext[order[0]] / 2 - r, 1e-3)
        return (f'<geom name="{name}" class="{cls}" type="capsule" fromto="{_fmt(mid - a, -4)} {_fmt(mid + a, -4)}" '
                f'size="{r:.4f}"/>')
    return f'<geom name="{name}" class="{cls}" type="box" pos="{_fmt(mid, -4)}" size="{_fmt(ext / 2, -4)}"/>'


class Urdf:
    def __init__(self, path: Path, meshes: Path):
        root = ET.parse(path).getroot()
        self.links = {lk.get("name"): lk for lk in root.findall("link")}
        self.joints = [j for j in root.findall("joint") if j.find("parent") is not None]
        self.children: dict[str, list] = {}
        for j in self.joints:
            self.children.setdefault(j.find("parent").get("link"), []).append(j)
        self.meshes = meshes

    def box(self, link: str):
        mesh = self.links[link].find("visual/geometry/mesh")
        if mesh is None:
            return None
        return _stl_box(self.meshes / Path(mesh.get("filename")).name)


def _inertial(link) -> str:
    i = link.find("inertial")
    if i is None:
        return ""
    t = {k: float(v) for k, v in i.find("inertia").attrib.items()}
    full = [t["ixx"], t["iyy"], t["izz"], t["ixy"], t["ixz"], t["iyz"]]
    return (f'<inertial pos="{_fmt(_vec(i.find("origin"), "xyz"))}" mass="{float(i.find("mass").get("value")):.6g}" '
            f'fullinertia="{_fmt(full)}"/>')


def _link_geoms(u: Urdf, name: str) -> list[str]:
    if name.endswith("ankle_roll_link"):  # the sole: the URDF's four contact spheres, as one box
        return [f'<geom name="{name[:-5]}_sole" class="g1_foot" type="box" pos="0.035 0 -0.02" '
                'size="0.085 0.03 0.015"/>']
    box = u.box(name)
    if box is None:
        return []
    cls = "g1_reach" if any(k in name for k in REACH) else "g1_body" if any(k in name for k in BODY) else "g1"
    if "hand_" in name and "palm" not in name:
        cls = "g1_finger"
    return [_geom(name.removesuffix("_link"), *box, cls)]


def _sites(name: str, side: str) -> list[str]:
    """rio's sites: wrist tool frames, the head camera, and on Dex3-1 hands the palm and finger keypoints."""
    s = 1.0 if side == "left" else -1.0
    out = []
    if name.endswith("wrist_yaw_link"):
        out.append(f'<site name="{side}_wrist" pos="0.05 0 0" size="0.008" rgba="1 0.3 0.3 0.6" group="4"/>')
    if name == "torso_link":  # the D435 in the head: looks along the link's x, pitched down 0.83 rad
        p = 0.8307767239493009
        out.append(f'<camera name="head" pos="0.0576235 0.01753 0.42987" xyaxes="0 -1 0 {np.sin(p):.6g} 0 '
                   f'{np.cos(p):.6g}" fovy="58"/>')
    if name.endswith("hand_palm_link"):
        # RIO's palm frame (rio.kinematics.hand_retarget): x toward the fingers, z out of the palm (the side
        # the fingers curl to: -y on the left hand, +y on the right), y = z x x
        q = f"0.707107 {0.707107 * s:g} 0 0"
        out += [f'<site name="{side}_palm" quat="{q}" size="0.006" group="4"/>',
                f'<site name="{side}_index_knuckle" pos="0.0777 {0.0016 * s:g} 0.0285" size="0.005" group="4"/>',
                f'<site name="{side}_middle_knuckle" pos="0.0777 {0.0016 * s:g} -0.0285" size="0.005" group="4"/>']
    for finger in ("index", "middle"):
        if name.endswith(f"hand_{finger}_1_link"):
            out += [f'<site name="{side}_{finger}_pip" size="0.005" group="4"/>',
                    f'<site name="{side}_{finger}_tip" pos="0.048 0 0" size="0.005" group="4"/>']
    if name.endswith("hand_thumb_1_link"):
        out.append(f'<site name="{side}_thumb_mcp" size="0.005" group="4"/>')
    if name.endswith("hand_thumb_2_link"):
        out += [f'<site name="{side}_thumb_ip" size="0.005" group="4"/>',
                f'<site name="{side}_thumb_tip" pos="0 {-0.048 * s:g} 0" size="0.005" group="4"/>']
    return out


def _body(u: Urdf, name: str, joint, depth: int, efforts: dict[str, float]) -> str:
    pad = "  " * depth
    link = u.links[name]
    attrs = f'name="{name}"'
    if joint is not None:
        o = joint.find("origin")
        pos, q = _vec(o, "xyz"), _rpy_quat(_vec(o, "rpy"))
        attrs += f' pos="{_fmt(pos)}"' if np.any(pos) else ""
        attrs += f' quat="{_fmt(q)}"' if not np.allclose(q, [1, 0, 0, 0]) else ""
    lines = [f"{pad}<body {attrs}>", f"{pad}  {_inertial(link)}"]
    if name == "pelvis":
        lines.append(f'{pad}  <freejoint name="floating_base_joint"/>')
    if joint is not None and joint.get("type") == "revolute":
        lim = joint.find("limit")
        effort, vel = float(lim.get("effort")), float(lim.get("velocity"))
        efforts[joint.get("name")] = effort
        arm = FINGER_ARMATURE if "hand_" in name else ARMATURE[effort]
        lines.append(f'{pad}  <joint name="{joint.get("name")}" axis="{_fmt(_vec(joint.find("axis"), "xyz"))}" '
                     f'range="{float(lim.get("lower")):.6g} {float(lim.get("upper")):.6g}" '
                     f'actuatorfrcrange="{-effort:g} {effort:g}" armature="{arm:.6g}" user="{vel:g}"/>')
    side = "left" if name.startswith("left") else "right"
    lines += [f"{pad}  {g}" for g in _link_geoms(u, name) + _sites(name, side)]
    for child in u.children.get(name, []):
        cname = child.find("child").get("link")
        if cname in DROP:
            continue
        if cname in SITES:
            o = child.find("origin")
            lines.append(f'{pad}  <site name="{cname.removesuffix("_link")}" pos="{_fmt(_vec(o, "xyz"))}" '
                         f'size="0.006" group="4"/>')
            continue
        lines.append(_body(u, cname, child, depth + 1, efforts))
    lines.append(f"{pad}</body>")
    return "\n".join(lines)


HEADER = (
    "Unitree G1 (29 DoF{hands}), written for RIO from Unitree's URDF `{urdf}` as published in example-robot-data "
    "6.0.0 (robots/g1_description, BSD-3-Clause, upstream unitreerobotics/unitree_ros), by "
    "plugins/rio-sim/tools/g1_from_urdf.py: the link tree, joint origins, axes and limits (position; effort as "
    "`actuatorfrcrange`; velocity, rad/s, as the joint's `user` value, which MuJoCo does not enforce) and every "
    "link's mass and inertia are the URDF's. The geometry is simplified: one capsule or box per link, sized from "
    "the bounding box of Unitree's mesh; the sole is a box over the URDF's four contact spheres. Armature is the "
    "reflected inertia of each joint's Unitree motor; joint stops are stiff (solreflimit 5 ms).",
    "Names are the URDF's. Actuators are torque motors (N m, limited to each joint's effort) named after their "
    "joints, in Unitree's motor order: 0-5 left leg (hip pitch, roll, yaw, knee, ankle pitch, roll), 6-11 right "
    "leg, 12-14 waist (yaw, roll, pitch), 15-21 left arm (shoulder pitch, roll, yaw, elbow, wrist roll, pitch, "
    "yaw), 22-28 right arm{hand_order}. The joints (qpos) follow the tree{tree_note}. rio-sim's scenes turn the "
    "motors into joint PD servos (rio_sim.g1); a DDS bridge applies Unitree's LowCmd law (tau = kp (q* - q) + "
    "kd (dq* - dq) + tau_ff) through them as they are.",
    "Frames: pelvis at standing height on a free joint (`floating_base_joint`), x forward, z up. Sites "
    "`left_wrist` / `right_wrist`: tool frames 5 cm beyond the wrist-yaw joints, toward the palm; camera `head`: "
    "the head's D435.{hand_sites}",
    "Collision classes: robot geoms touch the world (contype 2, conaffinity 1); forearms and hands also touch the "
    "pelvis, torso and legs (bit 4); links never touch their neighbours or the other arm.",
)
HAND_ORDER = (", then the Dex3-1 hands: 29-35 left (thumb 0, 1, 2, middle 0, 1, index 0, 1), 36-42 right "
              "(thumb 0, 1, 2, index 0, 1, middle 0, 1), Unitree's HandCmd order")
HAND_SITES = (" Hands: site `<side>_palm` follows rio.kinematics.hand_retarget's palm frame (x toward the fingers, "
              "z out of the palm, y = z x x); `<side>_thumb_tip`, `_index_tip`, `_middle_tip`, `_index_knuckle`, "
              "`_middle_knuckle`, `_index_pip`, `_middle_pip`, `_thumb_mcp`, `_thumb_ip` are finger keypoints.")


def _header(**fields: str) -> str:
    paragraphs = (textwrap.fill(p.format(**fields), 108, initial_indent="  ", subsequent_indent="  ") for p in HEADER)
    return "<!--\n" + "\n\n".join(paragraphs) + "\n-->\n"


def model(u: Urdf, urdf_name: str, hands: bool, height: float) -> str:
    efforts: dict[str, float] = {}
    body = _body(u, "pelvis", None, 2, efforts).replace('<body name="pelvis">',
                                                         f'<body name="pelvis" pos="0 0 {height:.4f}" childclass="g1">',
                                                         1)
    motors = list(BODY_MOTORS)
    if hands:
        motors += [f"{s}_hand_{j}_joint" for s in ("left", "right") for j in HAND_MOTORS[s]]
    acts = "\n".join(f'    <motor name="{j}" joint="{j}" ctrlrange="{-efforts[j]:g} {efforts[j]:g}"/>' for j in motors)
    head = _header(hands=" + Dex3-1 hands" if hands else "", urdf=urdf_name,
                   hand_order=HAND_ORDER if hands else "", hand_sites=HAND_SITES if hands else "",
                   tree_note=" (each hand's joints after its wrist)" if hands else ", the same order")
    return f"""{head}<mujoco model="g1_29dof{'_dex3' if hands else ''}">
  <compiler angle="radian" autolimits="true" inertiafromgeom="false"/>
  <option timestep="0.002" integrator="implicitfast"/>
  <default>
    <default class="g1">
      <joint damping="0.05" solreflimit="0.005 1"/>
      <motor ctrllimited="true"/>
      <geom contype="2" conaffinity="1" rgba="0.72 0.73 0.76 1" friction="0.8 0.01 0.001"/>
      <default class="g1_body"><geom conaffinity="5"/></default>
      <default class="g1_reach"><geom contype="6" rgba="0.3 0.31 0.34 1"/></default>
      <default class="g1_finger">
        <geom contype="6" rgba="0.2 0.2 0.22 1" friction="1.5 0.02 0.001" condim="4"/>
      </default>
      <default class="g1_foot"><geom conaffinity="5" rgba="0.2 0.2 0.22 1" friction="1 0.01 0.001"/></default>
    </default>
  </default>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" diffuse="0.6 0.6 0.6"/>
    <geom name="floor" type="plane" size="0 0 0.05" rgba="0.55 0.55 0.58 1" contype="1" conaffinity="3"/>
{body}
  </worldbody>
  <actuator>
{acts}
  </actuator>
</mujoco>
"""


def main(src: str, out: str) -> None:
    import mujoco

    root = Path(src)
    for name, hands in (("g1.xml", False), ("g1_hands.xml", True)):
        urdf = "g1_29dof_with_hand_rev_1_0.urdf" if hands else "g1_29dof_rev_1_0.urdf"
        u = Urdf(root / "urdf" / urdf, root / "meshes")
        text = model(u, urdf, hands, 1.0)
        m = mujoco.MjModel.from_xml_string(text)
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        lowest = min(d.geom_xpos[g][2] - m.geom_size[g][2] for g in range(m.ngeom) if "sole" in m.geom(g).name)
        text = model(u, urdf, hands, 1.0 - lowest + 0.0005)  # soles 0.5 mm above the floor
        (Path(out) / name).write_text(text, encoding="utf-8")
        print(f"{name}: {len(text)} bytes, pelvis at {1.0 - lowest:.4f} m")


if __name__ == "__main__":
    main(*sys.argv[1:3])
