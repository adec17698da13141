#!/usr/bin/env python3
"""Convert the authors' MuJoCo model of the JK5 (jk5_table.mjcf.xml) to urdf/jk5.urdf.

The conversion is exact up to floating-point rounding:

* body `pos`/`quat` -> joint origin xyz/rpy. The quaternion (MuJoCo order w x y z)
  is normalised the way MuJoCo's compiler does it (divide by its norm), turned into
  a rotation matrix, and that matrix into URDF roll-pitch-yaw (R = Rz(y) Ry(p) Rx(r)).
* `<inertial pos quat mass diaginertia>` -> URDF `<inertial>` with origin xyz = pos,
  rpy = 0 and the full tensor I = R diag(d) R^T (R from the normalised inertial quat),
  so no rotation is rounded through an rpy triple.
* each hinge joint -> revolute joint (axis as in the MJCF, in the child frame),
  position limits from `range`, effort limit from the `<motor>` acting on it
  (|ctrlrange| * gear), velocity limit = VELOCITY_LIMIT below.
* each body without a joint (other than the root) -> fixed joint.
* the root body (`jk5`) -> `base_link`; `ee_link` (the F/T sensor origin) -> `ft_sensor`.

Floats are printed with repr() (shortest string that round-trips to the same double),
and all arithmetic is done in plain Python floats in a fixed order, so the output is
byte-for-byte reproducible. Python standard library only.

Usage (from the repository root):
    python tools/mjcf_to_urdf.py                      # writes urdf/jk5.urdf
    python tools/mjcf_to_urdf.py MJCF -o -            # to stdout
    python tools/mjcf_to_urdf.py --check              # exit 1 if urdf/jk5.urdf is stale
"""
import argparse
import hashlib
import math
import pathlib
import sys
import xml.etree.ElementTree as ET

ROOT = pathlib.Path(__file__).resolve().parents[1]
DEFAULT_MJCF = ROOT.parent / "shared" / "reference" / "jk5" / "jk5_table.mjcf.xml"
DEFAULT_URDF = ROOT / "urdf" / "jk5.urdf"

ROOT_BODY = "jk5"
# MJCF body name -> URDF link name (others keep their name).
LINK_NAMES = {"jk5": "base_link", "ee_link": "ft_sensor"}
# URDF names of the fixed joints, by child link.
FIXED_JOINT_NAMES = {"ft_sensor": "ft_sensor_joint", "tip": "tip_joint"}

# 180 deg/s on every joint: the JAKA Zu 5 datasheet figure, as quoted in
# shared/reference/jk5/PROVENANCE.md (the MJCF has no velocity limit).
VELOCITY_LIMIT = math.pi

# Where the known input files come from (by sha256), for the generated header.
KNOWN_SOURCES = {
    "jk5_table.mjcf.xml": "github.com/yinzikang/torque-control, file jk5_table.xml, "
    "commit b77be752eb0aa01b8a6ccb3b7521a3265b24c517 (see shared/reference/jk5/PROVENANCE.md)",
    "jk5_table.nomesh.mjcf.xml": "jk5_table.mjcf.xml of github.com/yinzikang/torque-control "
    "commit b77be752eb0aa01b8a6ccb3b7521a3265b24c517 with the mesh assets/geoms removed "
    "(see shared/reference/jk5/PROVENANCE.md)",
}


class ConversionError(Exception):
    """Input the converter cannot translate exactly; the message names the element."""


def fmt(x):
    """Shortest decimal string that reads back as the same double; -0.0 printed as 0.0."""
    x = float(x)
    if x == 0.0:
        x = 0.0
    return repr(x)


def fmt_vec(v):
    return " ".join(fmt(x) for x in v)


def floats(elem, attr, n, default=None):
    text = elem.get(attr)
    if text is None:
        if default is None:
            raise ConversionError(f"<{elem.tag} name={elem.get('name')!r}> has no {attr}=")
        return list(default)
    try:
        vals = [float(t) for t in text.split()]
    except ValueError:
        raise ConversionError(f"<{elem.tag} name={elem.get('name')!r}> {attr}={text!r} is not {n} numbers")
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise ConversionError(f"<{elem.tag} name={elem.get('name')!r}> {attr}={text!r} must be {n} finite numbers")
    return vals


def normalize_quat(q, where):
    """As MuJoCo's compiler (mjuu_normvec): divide each component by the norm."""
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if norm < 1e-10:
        raise ConversionError(f"{where}: quat {q} has zero norm")
    return [c / norm for c in q]


def quat_to_mat(q):
    """Rotation matrix of a unit quaternion (w, x, y, z), as MuJoCo's mju_quat2Mat."""
    w, x, y, z = q
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    return [
        [ww + xx - yy - zz, 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), ww - xx + yy - zz, 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), ww - xx - yy + zz],
    ]


def mat_to_rpy(r):
    """URDF roll, pitch, yaw with R = Rz(yaw) Ry(pitch) Rx(roll)."""
    roll = math.atan2(r[2][1], r[2][2])
    pitch = math.atan2(-r[2][0], math.sqrt(r[2][1] * r[2][1] + r[2][2] * r[2][2]))
    yaw = math.atan2(r[1][0], r[0][0])
    if abs(abs(pitch) - math.pi / 2) < 1e-6:
        raise ConversionError("rotation is at the rpy singularity (pitch = +-90 deg); not converted")
    return [roll, pitch, yaw]


def rotated_inertia(r, d):
    """Full tensor R diag(d) R^T, summed in a fixed order, exactly symmetric."""
    i = [[0.0] * 3 for _ in range(3)]
    for a in range(3):
        for b in range(a, 3):
            s = r[a][0] * d[0] * r[b][0] + r[a][1] * d[1] * r[b][1] + r[a][2] * d[2] * r[b][2]
            i[a][b] = s
            i[b][a] = s
    return i


def body_pose(body):
    name = body.get("name")
    for attr in ("axisangle", "euler", "xyaxes", "zaxis"):
        if body.get(attr) is not None:
            raise ConversionError(f"body {name!r}: orientation given as {attr}=; only quat= is supported")
    pos = floats(body, "pos", 3, (0.0, 0.0, 0.0))
    quat = normalize_quat(floats(body, "quat", 4, (1.0, 0.0, 0.0, 0.0)), f"body {name!r}")
    return pos, quat


def convert_inertial(body):
    """URDF <inertial> lines for a body, or [] for a massless body without inertial."""
    name = body.get("name")
    inertials = body.findall("inertial")
    if len(inertials) > 1:
        raise ConversionError(f"body {name!r} has {len(inertials)} <inertial> elements")
    if not inertials:
        return []
    el = inertials[0]
    if el.get("fullinertia") is not None:
        raise ConversionError(f"body {name!r}: fullinertia= is not supported, only diaginertia=")
    pos = floats(el, "pos", 3)
    mass = floats(el, "mass", 1)[0]
    d = floats(el, "diaginertia", 3)
    quat = normalize_quat(floats(el, "quat", 4, (1.0, 0.0, 0.0, 0.0)), f"inertial of body {name!r}")
    if mass < 0 or min(d) < 0:
        raise ConversionError(f"body {name!r}: negative mass or inertia")
    if mass == 0.0:
        if max(d) != 0.0:
            raise ConversionError(f"body {name!r}: zero mass with non-zero inertia")
        return []  # massless (the tip): no <inertial>, as URDF allows
    i = rotated_inertia(quat_to_mat(quat), d)
    return [
        "    <inertial>",
        f'      <origin xyz="{fmt_vec(pos)}" rpy="0 0 0"/>',
        f'      <mass value="{fmt(mass)}"/>',
        f'      <inertia ixx="{fmt(i[0][0])}" ixy="{fmt(i[0][1])}" ixz="{fmt(i[0][2])}" '
        f'iyy="{fmt(i[1][1])}" iyz="{fmt(i[1][2])}" izz="{fmt(i[2][2])}"/>',
        "    </inertial>",
    ]


def motor_efforts(root):
    """joint name -> effort limit |ctrlrange| * |gear| of the <motor> driving it."""
    efforts = {}
    act = root.find("actuator")
    if act is None:
        return efforts
    for m in act:
        if m.tag != "motor":
            raise ConversionError(f"actuator <{m.tag} name={m.get('name')!r}>: only <motor> is supported")
        joint = m.get("joint")
        lo, hi = floats(m, "ctrlrange", 2)
        gear = floats(m, "gear", 1, (1.0,))[0]
        if joint in efforts:
            raise ConversionError(f"joint {joint!r} is driven by more than one motor")
        efforts[joint] = max(abs(lo), abs(hi)) * abs(gear)
    return efforts


def convert(mjcf_text, source_name):
    try:
        root = ET.fromstring(mjcf_text)
    except ET.ParseError as e:
        raise ConversionError(f"{source_name} is not valid XML: {e}")
    if root.tag != "mujoco":
        raise ConversionError(f"{source_name}: root element is <{root.tag}>, expected <mujoco>")
    compiler = root.find("compiler")
    angle = compiler.get("angle", "degree") if compiler is not None else "degree"
    if angle not in ("radian", "degree"):
        raise ConversionError(f"<compiler angle={angle!r}> must be radian or degree")
    if root.find("default") is not None:
        raise ConversionError("<default> classes are not supported (attributes would be inherited)")
    world = root.find("worldbody")
    if world is None:
        raise ConversionError(f"{source_name} has no <worldbody>")
    base = world.find(f"body[@name='{ROOT_BODY}']")
    if base is None:
        raise ConversionError(f"{source_name}: no top-level body named {ROOT_BODY!r}")
    pos, quat = body_pose(base)
    if pos != [0.0, 0.0, 0.0] or quat != [1.0, 0.0, 0.0, 0.0]:
        raise ConversionError(f"body {ROOT_BODY!r} must be at the world origin (base_link = world frame)")
    if base.find("joint") is not None:
        raise ConversionError(f"body {ROOT_BODY!r} has a joint; the root must be fixed to the world")
    efforts = motor_efforts(root)

    sha = hashlib.sha256(mjcf_text if isinstance(mjcf_text, bytes) else mjcf_text.encode()).hexdigest()
    origin = KNOWN_SOURCES.get(source_name, "unknown origin")
    out = [
        '<?xml version="1.0"?>',
        "<!--",
        "  JAKA JK5 with ATI mini45 F/T sensor and rod tool.",
        "  GENERATED by tools/mjcf_to_urdf.py from the MuJoCo model",
        f"    {source_name} (sha256 {sha})",
        f"    = {origin}.",
        "  Do not edit by hand: change the converter and regenerate (see urdf/README.md).",
        "  Frames: base_link = MJCF world frame (z up); q = 0 is the arm straight up.",
        "  ft_sensor = MJCF body ee_link (sensor origin, inertia = sensor + rod);",
        "  tip = contact point (MJCF body tip / site ee), 0.169 m along ft_sensor z.",
        "  Effort limits: MJCF <motor> ctrlrange. Velocity limits: 180 deg/s (JAKA datasheet).",
        "-->",
        '<robot name="jk5">',
    ]
    links, joints = [], []

    def visit(body, link_name):
        links.append((link_name, convert_inertial(body)))
        for child in body.findall("body"):
            cname = child.get("name")
            if cname is None:
                raise ConversionError(f"a child body of {link_name!r} has no name")
            clink = LINK_NAMES.get(cname, cname)
            cpos, cquat = body_pose(child)
            rpy = mat_to_rpy(quat_to_mat(cquat))
            origin_line = f'    <origin xyz="{fmt_vec(cpos)}" rpy="{fmt_vec(rpy)}"/>'
            cjoints = child.findall("joint")
            if len(cjoints) > 1:
                raise ConversionError(f"body {cname!r} has {len(cjoints)} joints; one at most is supported")
            if child.find("freejoint") is not None:
                raise ConversionError(f"body {cname!r} has a freejoint; not supported")
            if cjoints:
                j = cjoints[0]
                jname = j.get("name")
                if jname is None:
                    raise ConversionError(f"the joint of body {cname!r} has no name")
                if j.get("type", "hinge") != "hinge":
                    raise ConversionError(f"joint {jname!r}: type {j.get('type')!r}, only hinge is supported")
                if floats(j, "pos", 3, (0.0, 0.0, 0.0)) != [0.0, 0.0, 0.0]:
                    raise ConversionError(f"joint {jname!r}: pos must be 0 0 0 (joint at the body origin)")
                for attr in ("armature", "damping", "frictionloss", "stiffness", "springref", "ref"):
                    if j.get(attr) is not None and float(j.get(attr)) != 0.0:
                        raise ConversionError(f"joint {jname!r}: {attr}= is not representable in URDF here")
                axis = floats(j, "axis", 3, (0.0, 0.0, 1.0))
                n = math.sqrt(axis[0] ** 2 + axis[1] ** 2 + axis[2] ** 2)
                axis = [a / n for a in axis]
                if j.get("limited", "true") == "false" or j.get("range") is None:
                    raise ConversionError(f"joint {jname!r} has no range; URDF revolute needs limits")
                lo, hi = floats(j, "range", 2)
                if angle == "degree":
                    lo, hi = math.radians(lo), math.radians(hi)
                if jname not in efforts:
                    raise ConversionError(f"joint {jname!r} has no <motor>; no effort limit to take")
                joints.extend([
                    f'  <joint name="{jname}" type="revolute">',
                    f'    <parent link="{link_name}"/>',
                    f'    <child link="{clink}"/>',
                    origin_line,
                    f'    <axis xyz="{fmt_vec(axis)}"/>',
                    f'    <limit lower="{fmt(lo)}" upper="{fmt(hi)}" effort="{fmt(efforts[jname])}" '
                    f'velocity="{fmt(VELOCITY_LIMIT)}"/>',
                    "  </joint>",
                ])
            else:
                jname = FIXED_JOINT_NAMES.get(clink, f"{clink}_joint")
                joints.extend([
                    f'  <joint name="{jname}" type="fixed">',
                    f'    <parent link="{link_name}"/>',
                    f'    <child link="{clink}"/>',
                    origin_line,
                    "  </joint>",
                ])
            visit(child, clink)

    visit(base, LINK_NAMES.get(ROOT_BODY, ROOT_BODY))
    for name, inertial in links:
        if inertial:
            out.append(f'  <link name="{name}">')
            out += inertial
            out.append("  </link>")
        else:
            out.append(f'  <link name="{name}"/>')
    out += joints
    out.append("</robot>")
    return "\n".join(out) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mjcf", nargs="?", default=str(DEFAULT_MJCF), help="input MJCF (default: %(default)s)")
    ap.add_argument("-o", "--output", default=str(DEFAULT_URDF), help="output URDF, - for stdout")
    ap.add_argument("--check", action="store_true", help="do not write; exit 1 if OUTPUT differs")
    args = ap.parse_args(argv)
    src = pathlib.Path(args.mjcf)
    try:
        data = src.read_bytes()
    except OSError as e:
        print(f"mjcf_to_urdf: cannot read the MJCF {src}: {e.strerror}. "
              f"Pass the path of jk5_table.mjcf.xml (from shared/reference/jk5/).", file=sys.stderr)
        return 2
    try:
        urdf = convert(data, src.name)
    except ConversionError as e:
        print(f"mjcf_to_urdf: {src}: {e}", file=sys.stderr)
        return 2
    if args.check:
        try:
            current = pathlib.Path(args.output).read_text()
        except OSError as e:
            print(f"mjcf_to_urdf: cannot read {args.output}: {e.strerror}", file=sys.stderr)
            return 1
        if current != urdf:
            print(f"mjcf_to_urdf: {args.output} differs from what {src} converts to; "
                  f"regenerate with: python tools/mjcf_to_urdf.py", file=sys.stderr)
            return 1
        return 0
    if args.output == "-":
        sys.stdout.write(urdf)
    else:
        pathlib.Path(args.output).parent.mkdir(parents=True, exist_ok=True)
        with open(args.output, "w", newline="\n") as f:
            f.write(urdf)
    return 0


if __name__ == "__main__":
    sys.exit(main())
