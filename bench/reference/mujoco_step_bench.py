#!/usr/bin/env python3
"""MuJoCo `mj_step` throughput on the authors' JK5 model, as a reference for the
Rust simulator's step rate in BENCHMARKS.md.

Model: shared/reference/jk5/jk5_table.nomesh.mjcf.xml, unchanged (timestep 1 ms, Euler,
table contact solref -2000 -0.1), one thread.

Scenarios (both run as open-loop rollouts in C via mujoco.rollout, so Python overhead per
step is not counted; each repeat restarts from the same initial state):
  table ("mj_step_per_s"): the tool pointing down with the tip sphere resting on the table
        top at (-0.5, 0, .), constant torques = gravity compensation + 10 N pressing force
        (tau = G(q0) - J_tip^T (0, 0, 10)). Open loop, so the tip slowly slides (table
        friction 0.1); over the 0.5 s rollout it stays pressing (contact force 1.6-17 N), and
        the script checks that the tip contact force is non-zero in every step.
  friction ("mj_step_friction_per_s"): the table scenario on the same MJCF with joint
        frictionloss/damping from --friction (default params/friction_jk5.yaml), made by
        jk5_friction_mjcf.py (frictionloss = f_a, damping = f_v, directions averaged):
        the reference for the plant with joint friction. Skipped with --no-friction.
  free ("mj_step_free_per_s"): contacts disabled, no torque, the arm swings under gravity
        from q = (0, 0.5, -1.0, 0.5, 0.3, 0) -- rigid-body dynamics only.
Steps/s = steps per rollout / wall time; the printed figure is the median over repeats.

Prints ONE JSON line: {"mj_step_per_s": ..., "mj_step_friction_per_s": ..., "mj_step_free_per_s": ..., ...}.
Usage: python bench/reference/mujoco_step_bench.py [--mjcf PATH] [--friction YAML | --no-friction]
       [--steps N] [--repeats R]
"""
import argparse
import json
import os
import pathlib
import statistics
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
# ../shared beside the repository, or NAIC_SHARED (a git worktree elsewhere).
SHARED = pathlib.Path(os.environ["NAIC_SHARED"]) if os.environ.get("NAIC_SHARED") else ROOT.parent / "shared"
DEFAULT_MJCF = SHARED / "reference" / "jk5" / "jk5_table.nomesh.mjcf.xml"
PRESS_N = 10.0
TIP_RADIUS = 0.01  # the tip sphere geom


def press_pose(m, d, mujoco):
    """Damped least-squares IK: tip over the table centre, tool axis pointing down,
    tip sphere touching the table top."""
    table = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "table")
    table_geom = m.body_geomadr[table]
    top = m.body_pos[table][2] + m.geom_size[table_geom][2]
    target = np.array([m.body_pos[table][0], m.body_pos[table][1], top + TIP_RADIUS])
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "ee")
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "tip")
    q = np.array([0.0, 0.6, -1.6, 1.0, -1.57, 0.0])
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for _ in range(500):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        z_axis = d.xmat[body].reshape(3, 3)[:, 2]
        err = np.concatenate([target - d.site_xpos[site], np.cross(z_axis, [0, 0, -1.0])])
        if np.linalg.norm(err) < 1e-12:
            break
        mujoco.mj_jacSite(m, d, jp, jr, site)
        J = np.vstack([jp, jr])
        q = q + J.T @ np.linalg.solve(J @ J.T + 1e-8 * np.eye(6), err)
    else:
        sys.exit(f"mujoco_step_bench: IK for the pressing pose did not converge (error {np.linalg.norm(err):.2e})")
    q = (q + np.pi) % (2 * np.pi) - np.pi  # same pose, inside the joint range +-3.14
    if np.any(np.abs(q) > 3.14):
        sys.exit(f"mujoco_step_bench: pressing pose {q} is outside the joint range")
    d.qpos[:] = q
    d.qvel[:] = 0
    mujoco.mj_forward(m, d)
    mujoco.mj_jacSite(m, d, jp, jr, site)
    tau = d.qfrc_bias.copy() - jp.T @ np.array([0.0, 0.0, PRESS_N])
    return q, tau


def time_rollouts(m, d, q0, ctrl, steps, repeats, mujoco, rollout):
    d.qpos[:] = q0
    d.qvel[:] = 0
    d.ctrl[:] = 0
    d.time = 0
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x0 = np.zeros(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, x0, spec)
    control = np.tile(ctrl, (1, steps, 1))
    state = np.zeros((1, steps, x0.size))
    sensordata = np.zeros((1, steps, m.nsensordata))
    rates = []
    rollout.rollout(m, d, x0[None], control, state=state, sensordata=sensordata)  # warm-up
    for _ in range(repeats):
        t0 = time.perf_counter()
        rollout.rollout(m, d, x0[None], control, state=state, sensordata=sensordata)
        rates.append(steps / (time.perf_counter() - t0))
    return statistics.median(rates), sensordata[0]


def pressing_force(m, sensors, mujoco, what):
    """Tip contact force per step; the scenario is what it says: the tip presses on
    the table in every step (else exit)."""
    adr = m.sensor_adr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, "contact_force")]
    force = np.linalg.norm(sensors[:, adr:adr + 3], axis=1)
    if not np.all(force > 0):
        sys.exit(f"mujoco_step_bench: the tip left the table{what} at step {int(np.argmin(force > 0))}; "
                 f"use fewer --steps")
    return force


def main():
    ap = argparse.ArgumentParser(description="MuJoCo mj_step/s on the JK5 table model")
    ap.add_argument("--mjcf", default=str(DEFAULT_MJCF))
    ap.add_argument("--steps", type=int, default=500, help="steps per rollout (default 500 = 0.5 s)")
    ap.add_argument("--repeats", type=int, default=100)
    ap.add_argument("--friction", default=str(ROOT / "params" / "friction_jk5.yaml"),
                    help="friction file for the joint-friction variant (default params/friction_jk5.yaml)")
    ap.add_argument("--no-friction", action="store_true", help="skip the joint-friction variant")
    args = ap.parse_args()
    if args.steps < 1 or args.repeats < 1:
        sys.exit("mujoco_step_bench: --steps and --repeats must be positive")
    try:
        import mujoco
        from mujoco import rollout
    except ImportError as e:
        sys.exit(f"mujoco_step_bench: {e}; install it with: pip install -r tests/requirements.txt")
    try:
        m = mujoco.MjModel.from_xml_path(args.mjcf)
    except (ValueError, FileNotFoundError) as e:
        sys.exit(f"mujoco_step_bench: cannot load {args.mjcf}: {e}")
    d = mujoco.MjData(m)

    q_press, tau_press = press_pose(m, d, mujoco)
    table_rate, sensors = time_rollouts(m, d, q_press, tau_press, args.steps, args.repeats, mujoco, rollout)
    force = pressing_force(m, sensors, mujoco, "")

    friction = {}
    if not args.no_friction:
        sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
        from jk5_friction_mjcf import friction_variant
        text, levels = friction_variant(args.mjcf, args.friction)
        mf = mujoco.MjModel.from_xml_string(text)
        if not (np.all(mf.dof_frictionloss > 0) and np.all(mf.dof_damping > 0)):
            sys.exit(f"mujoco_step_bench: the friction variant has frictionloss {mf.dof_frictionloss}, "
                     f"damping {mf.dof_damping}")
        df = mujoco.MjData(mf)
        rate_f, sensors_f = time_rollouts(mf, df, q_press, tau_press, args.steps, args.repeats, mujoco, rollout)
        force_f = pressing_force(mf, sensors_f, mujoco, " with joint friction")
        friction = {
            "mj_step_friction_per_s": round(rate_f),
            "friction_contact_force_n": [round(float(force_f.min()), 2), round(float(force_f.max()), 2)],
            "friction_levels": levels,
        }

    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    free_rate, _ = time_rollouts(m, d, np.array([0.0, 0.5, -1.0, 0.5, 0.3, 0.0]), np.zeros(m.nu),
                                 args.steps, args.repeats, mujoco, rollout)
    print(json.dumps({
        "mj_step_per_s": round(table_rate),
        **({"mj_step_friction_per_s": friction["mj_step_friction_per_s"]} if friction else {}),
        "mj_step_free_per_s": round(free_rate),
        "table_contact_force_n": [round(float(force.min()), 2), round(float(force.max()), 2)],
        "steps_per_rollout": args.steps,
        "repeats": args.repeats,
        "mujoco": mujoco.__version__,
        **{k: v for k, v in friction.items() if k != "mj_step_friction_per_s"},
    }))


if __name__ == "__main__":
    main()
