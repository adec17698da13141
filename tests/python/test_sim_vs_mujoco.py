"""The naic simulator's rigid-body physics against MuJoCo on the authors' MJCF.

With contact off and friction zero, the same joint-torque sequence applied
from the same state must give the same joint trajectory over 1 s.

How: MuJoCo (shared/reference/jk5/jk5_table.nomesh.mjcf.xml, contact and joint
limits disabled, torques through qfrc_applied so the ±100 N·m ctrlrange does not
clip) runs a computed-torque controller (M(q)·PD + bias) along a joint-space sine sweep
for 1 s at 1 ms; the torque it applied in every period is recorded. `naic sim
--replay` then applies that torque sequence open loop (zero-order hold per
period, the same integration scheme) from the same initial state, and the
trajectories are compared.

Tolerance and why. Both sides integrate the same equations with the same
scheme and step (MuJoCo's default `Euler` is semi-implicit Euler — v += h·q̈,
q += h·v — for a model without joint damping; `--integrator euler` is the same;
likewise RK4 on both sides), and urdf/jk5.urdf is an exact conversion of the
MJCF (tests/python/test_urdf_vs_mjcf.py: ≤ 1e-12 on M, bias and frames). What
remains is floating-point rounding (ABA vs MuJoCo's LDL factorisation; ~1e-14
relative per step, amplified by cond(M) ≤ 2e4) accumulated over 1000 open-loop
steps. Measured (mujoco 4.0.0, this 2-core VM): max |Δq| = 4e-14 rad,
max |Δq̇| = 1.2e-13 rad/s for Euler, 1e-14 / 1e-13 for RK4. We assert
max |Δq| ≤ 1e-10 rad and max |Δq̇| ≤ 1e-9 rad/s: ~1000x above the measured
rounding (room for other CPUs and libm), and 10⁸ times below the difference
between the two integration schemes on the same torques (Euler vs RK4:
2.7e-2 rad, asserted > 1e-7 here), so the check would catch a different
scheme, a wrong sign of a term, or a 0.01 % inertia error.
"""
import csv
import math
import subprocess

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

DT = 1e-3
T = 1.0
Q0 = np.deg2rad([0.0, -30.0, 120.0, 0.0, -90.0, 0.0])
TOL_Q = 1e-10
TOL_DQ = 1e-9


def mujoco_model(shared, integrator):
    m = mujoco.MjModel.from_xml_path(str(shared / "reference/jk5/jk5_table.nomesh.mjcf.xml"))
    m.opt.timestep = DT
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    m.opt.integrator = integrator
    assert np.all(m.dof_damping == 0) and np.all(m.dof_armature == 0) and np.all(m.dof_frictionloss == 0)
    return m


def mujoco_run(shared, integrator, torques=None):
    """Run 1 s; with torques=None generate them by PD + bias compensation."""
    m = mujoco_model(shared, integrator)
    d = mujoco.MjData(m)
    d.qpos[:] = Q0
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    n = int(round(T / DT))
    amp = np.array([0.4, 0.3, 0.4, 0.8, 0.6, 1.0])
    freq = np.array([0.7, 1.1, 0.9, 1.3, 1.7, 2.0])
    wn = 20.0  # computed-torque gains: every joint a critically damped 20 rad/s loop
    M = np.zeros((m.nv, m.nv))
    taus, qs, dqs = [], [d.qpos.copy()], [d.qvel.copy()]
    for k in range(n):
        t = k * DT
        if torques is None:
            q_ref = Q0 + amp * np.sin(2 * math.pi * freq * t)
            mujoco.mj_fullM(m, d, M)
            tau = d.qfrc_bias.copy() + M @ (wn * wn * (q_ref - d.qpos) - 2.0 * wn * d.qvel)
        else:
            tau = torques[k]
        d.qfrc_applied[:] = tau
        mujoco.mj_step(m, d)
        taus.append(np.array(tau))
        qs.append(d.qpos.copy())
        dqs.append(d.qvel.copy())
    return np.array(taus), np.array(qs), np.array(dqs)


def naic_replay(naic_bin, tmp_path, taus, integrator, name):
    path = tmp_path / f"tau_{name}.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow([f"tau{i}" for i in range(1, 7)])
        for row in taus:
            w.writerow([repr(float(x)) for x in row])
    out = tmp_path / name
    q0 = ",".join(repr(float(x)) for x in Q0)
    subprocess.run(
        [str(naic_bin), "sim", "--replay", str(path), "--q0", q0, "--integrator", integrator, "--out", str(out)],
        check=True,
        capture_output=True,
    )
    data = np.loadtxt(out / "replay.csv", delimiter=",", skiprows=1)
    return data[:, 1:7], data[:, 7:13]


@pytest.fixture(scope="module")
def euler_reference(shared):
    return mujoco_run(shared, int(mujoco.mjtIntegrator.mjINT_EULER))


def test_same_torques_same_trajectory_semi_implicit_euler(shared, naic_bin, tmp_path, euler_reference):
    taus, q_mj, dq_mj = euler_reference
    # the sweep moves every joint substantially (the comparison is not trivial)
    assert np.all(np.ptp(q_mj, axis=0) > 0.2)
    q, dq = naic_replay(naic_bin, tmp_path, taus, "euler", "euler")
    assert q.shape == q_mj.shape
    eq, edq = np.abs(q - q_mj).max(), np.abs(dq - dq_mj).max()
    print(f"semi-implicit Euler 1 ms, 1 s: max|dq| = {eq:.3e} rad, max|dqd| = {edq:.3e} rad/s")
    assert eq <= TOL_Q, f"joint positions differ by {eq:.3e} rad"
    assert edq <= TOL_DQ, f"joint velocities differ by {edq:.3e} rad/s"


def test_same_torques_same_trajectory_rk4(shared, naic_bin, tmp_path, euler_reference):
    taus = euler_reference[0]
    _, q_mj, dq_mj = mujoco_run(shared, int(mujoco.mjtIntegrator.mjINT_RK4), torques=taus)
    q, dq = naic_replay(naic_bin, tmp_path, taus, "rk4", "rk4")
    eq, edq = np.abs(q - q_mj).max(), np.abs(dq - dq_mj).max()
    print(f"RK4 1 ms, 1 s: max|dq| = {eq:.3e} rad, max|dqd| = {edq:.3e} rad/s")
    assert eq <= TOL_Q and edq <= TOL_DQ, (eq, edq)
    # sensitivity: the two schemes differ far more than the tolerance
    q_e, _ = naic_replay(naic_bin, tmp_path, taus, "euler", "euler2")
    scheme = np.abs(q_e - q).max()
    print(f"Euler vs RK4 on the same torques: max|dq| = {scheme:.3e} rad")
    assert scheme > 1e3 * TOL_Q  # 1e-7 rad
