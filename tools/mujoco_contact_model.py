#!/usr/bin/env python3
"""MuJoCo's soft contact written as f = mu u + k_e (x - x_e) + b_e xdot (docs/controller.md).

For each contact state of a `naic sim --plant mujoco` run (its `<law>.truth.csv`: joints,
joint velocities, surface height), this rebuilds the scenario's table box the way
naic_sim's MuJoCo plant does (top face at naic's surface less the tip sphere's radius,
solref "-k_e -max(b_e, 0.1)", solimp "0.1 0.3 0.001 0.5 2", condim 1, a priority above every
other geom's so that the contact takes these and not a mix with the tip sphere's) and reads MuJoCo's
constraint row of the tip contact:

    A   = J M^-1 J^T        (the inverse of the apparent mass D along the normal)
    R   = efc_R             (the regulariser, (1 - d)/d times MuJoCo's diagonal estimate)
    k, b, d = efc_KBIP      (solref's k and b, and the impedance d(r))
    f   = (aref - a0) / (A + R),  aref = -b v - k d r   (MuJoCo's "Solver parameters")

so, along the normal into the surface with u the push on the arm other than the contact:
mu = A / (A + R), k_e = mu D k d, b_e = mu D b.  MuJoCo's own efc_aref and efc_force are
checked against these formulas on every row.

Usage: tools/mujoco_contact_model.py MJCF RUN_DIR SCENARIO [LAW [FIRST_MS]]
(FIRST_MS: only the first milliseconds after the first contact)
"""
import csv
import re
import sys

import mujoco
import numpy as np

SOLIMP = (0.1, 0.3, 0.001, 0.5, 2.0)
MATERIALS = {"paper": (2000.0, 0.0), "foam": (1000.0, 10.0), "acrylic": (50000.0, 50.0)}


def scene_xml(mjcf_text, surface_z, normal, k_e, b_e, center_xy):
    text = re.sub(r"<!--.*?-->", "", mjcf_text, flags=re.S)
    text = re.sub(r'<body name="table".*?</body>', "", text, flags=re.S)
    priority = 1 + int(max(mujoco.MjModel.from_xml_string(text).geom_priority, default=0))
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    # quaternion rotating z onto n
    z = np.array([0.0, 0.0, 1.0])
    ax = np.cross(z, n)
    s = np.linalg.norm(ax)
    if s < 1e-12:
        quat = (1.0, 0.0, 0.0, 0.0)
    else:
        ang = np.arctan2(s, z @ n)
        ax = ax / s
        quat = (np.cos(ang / 2), *(np.sin(ang / 2) * ax))
    r_tip, half = 0.01, 0.05
    p = np.array([center_xy[0], center_xy[1], surface_z])
    c = p - n * (r_tip + half)
    geom = (f'<geom name="naic_table" type="box" size="1 1 {half}" pos="{c[0]} {c[1]} {c[2]}" '
            f'quat="{quat[0]} {quat[1]} {quat[2]} {quat[3]}" condim="1" priority="{priority}" '
            f'solref="{-k_e} {-max(b_e, 0.1)}" solimp="{" ".join(map(str, SOLIMP))}"/>')
    i = text.rfind("</worldbody>")
    return text[:i] + geom + text[i:]


def contact_index(m, d, gid):
    for i in range(d.ncon):
        if gid in (d.contact[i].geom1, d.contact[i].geom2) and d.contact[i].efc_address >= 0:
            return i
    return None


def normal_force(m, d, gid):
    """The contact's normal force [N] (0 without contact)."""
    i = contact_index(m, d, gid)
    if i is None:
        return 0.0, None
    f = np.zeros(6)
    mujoco.mj_contactForce(m, d, i, f)
    return f[0], i


def measure(m, d, gid, tau):
    """f, mu, k_e, b_e, D along the contact normal at the state in d (finite differences)."""
    d.qfrc_applied[:6] = tau
    mujoco.mj_forward(m, d)
    f0, i = normal_force(m, d, gid)
    if i is None:
        return None
    con = d.contact[i]
    frame_n = np.array(con.frame[:3])
    # n_in: the direction the tool pushes into the surface (the table is geom gid)
    n_in = -frame_n if con.geom1 == gid else frame_n
    tip_body = m.geom_bodyid[con.geom2 if con.geom1 == gid else con.geom1]
    jp = np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jp, None, con.pos, tip_body)
    jn = n_in @ jp
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    D = 1.0 / (jn @ np.linalg.solve(M, jn))
    qpos0, qvel0 = d.qpos.copy(), d.qvel.copy()
    # mu: a push du along n_in on the arm
    du = 1.0
    d.qfrc_applied[:6] = tau + jn[:6] * du
    mujoco.mj_forward(m, d)
    mu = (normal_force(m, d, gid)[0] - f0) / du
    d.qfrc_applied[:6] = tau
    # k_e: the surface moved by dx against n_in (the penetration grows by dx)
    dx = 1e-6
    pos0 = m.geom_pos[gid].copy()
    m.geom_pos[gid] = pos0 - n_in * dx
    mujoco.mj_forward(m, d)
    k_e = (normal_force(m, d, gid)[0] - f0) / dx
    m.geom_pos[gid] = pos0
    # b_e: the tip moving along n_in by dv more (least-norm joint velocity, no tangential part)
    dv = 1e-4
    dq = np.linalg.pinv(jp) @ (n_in * dv)
    d.qvel[:6] = qvel0[:6] + dq[:6]
    mujoco.mj_forward(m, d)
    b_e = (normal_force(m, d, gid)[0] - f0) / dv
    d.qvel[:] = qvel0
    d.qpos[:] = qpos0
    e = con.efc_address
    k, b, imp, _ = d.efc_KBIP[e]
    return dict(f=f0, mu=mu, k_e=k_e, b_e=b_e, D=D, imp=imp, k=k, b=b, dim=con.dim, fric=con.friction[0] if con.dim > 1 else 0.0, pen=-(d.efc_pos[e] - d.efc_margin[e]))


def main():
    mjcf, run, scenario = sys.argv[1:4]
    law = sys.argv[4] if len(sys.argv) > 4 else "naic"
    first_ms = float(sys.argv[5]) if len(sys.argv) > 5 else None
    rows = list(csv.DictReader(open(f"{run}/{law}.truth.csv")))
    text = open(mjcf).read()
    con = [r for r in rows if float(r["penetration"]) > 0]
    if first_ms is not None:
        t0 = float(con[0]["t"])
        con = [r for r in con if float(r["t"]) - t0 <= first_ms * 1e-3]
    xs = np.array([float(r["tip_x"]) for r in con])
    zs = np.array([float(r["surface_z"]) for r in con])
    slope = np.polyfit(xs, zs, 1)[0] if np.ptp(zs) > 1e-6 else 0.0
    normal = (-slope, 0.0, 1.0)
    out = []
    for r in con[:: max(1, len(con) // 300)]:  # at most about 300 states
        k_ref = float(r["k_e"])
        b_ref = B_E[k_ref]
        x0, y0 = float(r["tip_x"]), float(r["tip_y"])
        m = mujoco.MjModel.from_xml_string(scene_xml(text, float(r["surface_z"]) - slope * 0.0, normal, k_ref, b_ref, (x0, y0)))
        d = mujoco.MjData(m)
        d.qpos[:6] = [float(r[f"q{i}"]) for i in range(1, 7)]
        d.qvel[:6] = [float(r[f"dq{i}"]) for i in range(1, 7)]
        gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "naic_table")
        o = measure(m, d, gid, np.array([float(r[f"tau{i}"]) for i in range(1, 7)]))
        if o is not None and (o["f"] > 0.5 or first_ms is not None):
            o["k_ref"] = k_ref
            out.append(o)
    for kr in sorted({o["k_ref"] for o in out}):
        o = [x for x in out if x["k_ref"] == kr]
        a = lambda f: np.array([x[f] for x in o])
        med = lambda f: np.median(a(f))
        rng = lambda f, fmt: f"{fmt.format(med(f))} [{fmt.format(np.percentile(a(f), 5))}-{fmt.format(np.percentile(a(f), 95))}]"
        print(f"| {scenario} | {kr:g} | {B_E[kr]:g} | {len(o)} | {1e3*np.percentile(a('pen'),5):.2f}-{1e3*np.percentile(a('pen'),95):.2f} | "
              f"{rng('D', '{:.2f}')} | {med('imp'):.3f} | {rng('mu', '{:.3f}')} | {med('k'):.4g} | {med('b'):.3g} | "
              f"{rng('k_e', '{:.4g}')} | {rng('b_e', '{:.3g}')} | {med('k_e')/(1-med('mu')):.4g} | {int(med('dim'))}, {med('fric'):g} |")


B_E = {2000.0: 0.0, 5000.0: 0.0, 1000.0: 10.0, 50000.0: 50.0}


if __name__ == "__main__":
    main()
