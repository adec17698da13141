"""The classical baseline of `naic explain` (base parameters on the joint-torque
regressor + viscous/Coulomb/offset friction) against Pinocchio, on a 7-joint arm.

The data are made here with Pinocchio (RNEA of urdf/panda.urdf along a multi-sine
trajectory, known friction, jittered timestamps), none of the project's code. Pinocchio's
own `computeJointTorqueRegressor` gives the true base parameters for the column
selection the report names (π_B = least squares of Y_B β = Y π over random states), and
its rank gives the number of base parameters.
"""
import json
import subprocess

import numpy as np
import pinocchio as pin

PARAMS = ["m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz"]
F_V = np.array([0.07, 0.2, 0.04, 0.22, 0.1, 0.05, 0.06])
F_C = np.array([0.25, 0.15, 0.18, 0.36, 0.27, 0.17, 0.21])
F_O = np.array([-0.1, -0.15, -0.07, -0.25, 0.0, 0.09, -0.01])


def panda(root):
    m = pin.buildModelFromUrdf(str(root / "urdf/panda.urdf"))
    return m, m.createData()


def trajectory(m, t, seed):
    rng = np.random.default_rng(seed)
    mid = 0.5 * (m.lowerPositionLimit + m.upperPositionLimit)
    half = 0.5 * (m.upperPositionLimit - m.lowerPositionLimit)
    q = np.zeros((len(t), 7))
    dq = np.zeros_like(q)
    ddq = np.zeros_like(q)
    for j in range(7):
        for _ in range(4):
            w = rng.uniform(0.3, 1.6)
            a = rng.uniform(0.08, 0.16) * half[j] / 4 * 4
            ph = rng.uniform(0, 2 * np.pi)
            q[:, j] += a * np.sin(w * t + ph)
            dq[:, j] += a * w * np.cos(w * t + ph)
            ddq[:, j] -= a * w * w * np.sin(w * t + ph)
        q[:, j] += mid[j]
    return q, dq, ddq


def write_run(path, m, d, seed, dur=60.0, noise=0.02):
    rng = np.random.default_rng(seed + 100)
    steps = 1e-3 * rng.uniform(0.8, 1.25, int(dur * 1000))  # jittered clock, ~1 kHz
    t = np.concatenate([[0.0], np.cumsum(steps)])
    q, dq, ddq = trajectory(m, t, seed)
    tau = np.array([pin.rnea(m, d, q[i], dq[i], ddq[i]) for i in range(len(t))])
    tau += F_V * dq + F_C * np.tanh(dq / 1e-3) + F_O + rng.normal(0, noise, tau.shape)
    hdr = "t," + ",".join([f"q{j}" for j in range(1, 8)] + [f"dq{j}" for j in range(1, 8)] + [f"tau{j}" for j in range(1, 8)])
    np.savetxt(path, np.column_stack([t, q, dq, tau]), delimiter=",", header=hdr, comments="", fmt="%.12g")


def pinocchio_base(m, d, names, k=300, seed=3):
    """True values of the named base parameters: least squares Y_B β = Y π over random states."""
    rng = np.random.default_rng(seed)
    pi = np.concatenate([m.inertias[i].toDynamicParameters() for i in range(1, m.njoints)])
    rows = []
    for _ in range(k):
        q = rng.uniform(m.lowerPositionLimit, m.upperPositionLimit)
        rows.append(pin.computeJointTorqueRegressor(m, d, q, rng.uniform(-2, 2, 7), rng.uniform(-2, 2, 7)).copy())
    w = np.vstack(rows)
    link = {m.names[i]: i - 1 for i in range(1, m.njoints)}
    # the URDF's joint i carries link i (joint names jointK, links linkK)
    cols = [10 * link[n.split(".")[0].replace("link", "joint")] + PARAMS.index(n.split(".")[1]) for n in names]
    beta, *_ = np.linalg.lstsq(w[:, cols], w @ pi, rcond=None)
    sv = np.linalg.svd(w, compute_uv=False)
    rank = int((sv > 1e-9 * sv[0]).sum())
    return dict(zip(names, beta)), rank, np.abs(w @ pi - w[:, cols] @ beta).max()


def test_baseline_recovers_pinocchio_base_parameters_and_friction(naic_bin, root, tmp_path):
    m, d = panda(root)
    fit = [tmp_path / "fit1.csv", tmp_path / "fit2.csv"]
    val = tmp_path / "val.csv"
    for k, p in enumerate(fit + [val]):
        write_run(p, m, d, seed=k + 1)
    out = tmp_path / "out"
    r = subprocess.run([str(naic_bin), "explain", "--quiet", "--measured", *map(str, fit), "--validate", str(val),
                        "--urdf", str(root / "urdf/panda.urdf"), "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rep = json.loads((out / "report.json").read_text())
    b = rep["baseline"]
    assert b is not None, "the report has no baseline"
    names = list(b["base_parameters"])
    truth, rank, resid = pinocchio_base(m, d, names)
    # the project's column selection spans Pinocchio's regressor exactly, with its rank
    assert len(names) == rank, (len(names), rank)
    assert resid < 1e-8, resid
    # identified base parameters: relative to the regressor's scale, compared column by column
    scale = max(abs(v) for v in truth.values())
    worst = max(abs(b["base_parameters"][n] - truth[n]) for n in names) / scale
    assert worst < 0.05, {n: (b["base_parameters"][n], truth[n]) for n in names}
    for j in range(7):
        jb = b["joints"][f"joint{j + 1}"]
        assert abs(jb["f_c"] - F_C[j]) < 0.03, (j, jb)
        assert abs(jb["f_v"] - F_V[j]) < 0.03, (j, jb)
        assert abs(jb["f_o"] - F_O[j]) < 0.03, (j, jb)
        # scored on the validation run: near the noise (0.02 N·m) and the estimation error
        assert jb["validation_rmse"] < 0.08, (j, jb)
        assert jb["heldout_rmse"] < 0.08, (j, jb)
    # the report says it resampled the jittered clock
    assert "resampled" in rep["method"]["sampling of " + str(fit[0])]
