"""The arms the generator drives: the JK5 of the repository (`urdf/jk5.urdf`, 6 joints) and a
Franka Panda (7 joints) written here as URDF from the MuJoCo Menagerie MJCF kinematics
(`../shared/reference/panda/panda_nohand.xml`: body positions, quaternions, joint ranges)
and Franka's `inertial.yaml` (the link inertials of Gaz et al. 2019)."""
import pathlib
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[3]
SHARED = ROOT.parent / "shared"
PANDA_DIR = SHARED / "reference" / "panda"

# Franka datasheet: joint velocity limits [rad/s] and torque limits [N·m]
PANDA_VEL = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]
PANDA_EFFORT = [87, 87, 87, 87, 12, 12, 12]


def _rpy(quat_wxyz):
    w, x, y, z = quat_wxyz
    return pin.rpy.matrixToRpy(pin.Quaternion(w, x, y, z).normalized().matrix())


def panda_urdf_text(mjcf=PANDA_DIR / "panda_nohand.xml", inertial=PANDA_DIR / "inertial.yaml"):
    """URDF of the 7-joint Panda arm with a `tip` frame at the MJCF `attachment` body."""
    inert = yaml.safe_load(pathlib.Path(inertial).read_text())
    root = ET.parse(mjcf).getroot()
    default_range = root.find("default/default/joint").get("range")
    links, joints = [], []

    def link_xml(name):
        if name not in inert:
            return f'  <link name="{name}"/>'
        p = inert[name]
        i = p["inertia"]
        return (
            f'  <link name="{name}">\n    <inertial>\n      <origin xyz="{p["origin"]["xyz"]}" rpy="{p["origin"]["rpy"]}"/>\n'
            f'      <mass value="{p["mass"]}"/>\n'
            f'      <inertia ixx="{i["xx"]}" iyy="{i["yy"]}" izz="{i["zz"]}" ixy="{i["xy"]}" ixz="{i["xz"]}" iyz="{i["yz"]}"/>\n'
            "    </inertial>\n  </link>"
        )

    def walk(body, parent):
        name = body.get("name")
        links.append(link_xml(name))
        if parent is not None:
            xyz = body.get("pos", "0 0 0")
            rpy = _rpy([float(v) for v in body.get("quat", "1 0 0 0").split()])
            rpy_s = " ".join(f"{v:.12g}" for v in rpy)
            j = body.find("joint")
            if j is None:
                jname = "tip_joint" if name == "attachment" else f"{name}_fixed"
                joints.append(f'  <joint name="{jname}" type="fixed">\n    <parent link="{parent}"/>\n    <child link="{name if name != "attachment" else "tip"}"/>\n'
                              f'    <origin xyz="{xyz}" rpy="{rpy_s}"/>\n  </joint>')
            else:
                k = int(j.get("name")[-1]) - 1
                lo, hi = j.get("range", default_range).split()
                joints.append(
                    f'  <joint name="{j.get("name")}" type="revolute">\n    <parent link="{parent}"/>\n    <child link="{name}"/>\n'
                    f'    <origin xyz="{xyz}" rpy="{rpy_s}"/>\n    <axis xyz="0 0 1"/>\n'
                    f'    <limit lower="{lo}" upper="{hi}" effort="{PANDA_EFFORT[k]}" velocity="{PANDA_VEL[k]}"/>\n  </joint>'
                )
        for child in body.findall("body"):
            walk(child, name)

    walk(root.find("worldbody/body"), None)
    links = [l.replace('name="attachment"', 'name="tip"') for l in links]
    return ('<?xml version="1.0"?>\n<!-- Franka Panda arm written by tests/python/explain_gen/robots.py from the MuJoCo Menagerie\n'
            "     MJCF kinematics (panda_nohand.xml) and franka_description inertial.yaml (Gaz et al. 2019). -->\n"
            '<robot name="panda">\n' + "\n".join(links) + "\n" + "\n".join(joints) + "\n</robot>\n")


def write_panda_urdf(path):
    path = pathlib.Path(path)
    path.write_text(panda_urdf_text())
    return path


class Arm:
    """A URDF loaded with Pinocchio, with its posture for the excitations."""

    def __init__(self, urdf, home, tip="tip"):
        self.urdf = pathlib.Path(urdf)
        self.model = pin.buildModelFromUrdf(str(self.urdf))
        self.nj = self.model.nv
        if not self.model.existFrame(tip):
            raise ValueError(f"{urdf}: no frame `{tip}`")
        self.tip = tip
        self.home = np.asarray(home, float)
        if len(self.home) != self.nj:
            raise ValueError(f"{urdf}: {self.nj} joints, home posture has {len(self.home)}")
        self.lower = self.model.lowerPositionLimit.copy()
        self.upper = self.model.upperPositionLimit.copy()


def jk5():
    # elbow bent, wrist clear of singularities (not the Rust generator's posture)
    return Arm(ROOT / "urdf" / "jk5.urdf", [0.3, 0.9, -1.3, 0.4, -1.0, 0.5])


def panda(urdf_path):
    """`urdf_path`: where to write (or find) the Panda URDF."""
    p = pathlib.Path(urdf_path)
    if not p.exists():
        write_panda_urdf(p)
    return Arm(p, [0.0, -0.3, 0.0, -2.0, 0.0, 1.9, 0.8])


def make(name, workdir):
    if name == "jk5":
        return jk5()
    if name == "panda":
        return panda(pathlib.Path(workdir) / "panda.urdf")
    raise ValueError(f"unknown arm `{name}`; use jk5 or panda")
