"""The real Franka Panda identification trajectory (../shared/data/panda-gaz2019) as a
`naic explain` CSV, and the published identified model (Gaz et al. 2019: rigid body of
urdf/panda.urdf = p-hat, plus the Supp. Table I sigmoid friction) evaluated on the
analysis instants of `naic explain`, estimated the same way (Savitzky–Golay, order 5, the
same window, on the same uniform grid, every 10th sample, samples within a filter window
of a direction change left out). Used by test_explain_panda.py."""
import numpy as np
import pinocchio as pin
from scipy.signal import savgol_filter

# Supp. Table I: phi1 [N·m], phi2 [s/rad], phi3 [rad/s] per joint
PHI = np.array([
    [0.54615, 5.1181, 0.039533], [0.87224, 9.0657, 0.025882], [0.64068, 10.136, -0.046070],
    [1.2794, 5.5903, 0.036194], [0.83904, 8.3469, 0.026226], [0.30301, 17.133, -0.021047],
    [0.56489, 10.336, 0.0035526]])


def published_friction(v):
    p1, p2, p3 = PHI[:, 0], PHI[:, 1], PHI[:, 2]
    return p1 / (1 + np.exp(-p2 * (v + p3))) - p1 / (1 + np.exp(-p2 * p3))


def load(shared):
    b = shared / "data/panda-gaz2019/rbt_log"
    t = np.loadtxt(b / "exciting_traj_time.txt")
    q, dq, tau = (np.loadtxt(b / f"exciting_traj_{k}.txt").reshape(-1, 7) for k in ("positions", "velocity", "torques"))
    return t, q, dq, tau


def write_csv(shared, path):
    t, q, dq, tau = load(shared)
    hdr = "t," + ",".join([f"q{j}" for j in range(1, 8)] + [f"dq{j}" for j in range(1, 8)] + [f"tau{j}" for j in range(1, 8)])
    np.savetxt(path, np.column_stack([t, q, dq, tau]), delimiter=",", header=hdr, comments="", fmt="%.9g")


def published_rmse(shared, urdf, window_s, stride=10, v_rest=1e-3):
    """Per joint RMSE of τ − RNEA(q, q̇, q̈) − τ_f(q̇) on the analysis instants, and the
    same without friction (rigid body only)."""
    t, q, _, tau = load(shared)
    dt = 1e-3
    tg = np.arange(t[0], t[-1], dt)
    qi = np.column_stack([np.interp(tg, t, q[:, j]) for j in range(7)])
    ti = np.column_stack([np.interp(tg, t, tau[:, j]) for j in range(7)])
    h = int(round(window_s / dt / 2))
    w = 2 * h + 1
    qs = savgol_filter(qi, w, 5, axis=0, mode="interp")
    v = savgol_filter(qi, w, 5, deriv=1, delta=dt, axis=0, mode="interp")
    a = savgol_filter(qi, w, 5, deriv=2, delta=dt, axis=0, mode="interp")
    ts = savgol_filter(ti, w, 5, axis=0, mode="interp")
    idx = np.arange(h, len(tg) - h, stride)
    m = pin.buildModelFromUrdf(str(urdf))
    d = m.createData()
    rb = np.array([pin.rnea(m, d, qs[i], v[i], a[i]) for i in idx])
    vi = v[idx]
    reg = np.where(vi > v_rest, 1, np.where(vi < -v_rest, -1, 0))
    margin = -(-h // stride) + 1
    change = np.zeros_like(reg, dtype=bool)
    change[1:] = reg[1:] != reg[:-1]
    keep = np.ones_like(change)
    for k in range(len(idx)):
        lo, hi = max(k - margin + 1, 0), min(k + margin, len(idx) - 1)
        keep[k] = ~change[lo:hi + 1].any(axis=0)
    r_rb = ts[idx] - rb
    r_pub = r_rb - published_friction(vi)
    rms = lambda r: np.sqrt(np.array([np.mean(r[keep[:, j], j] ** 2) for j in range(7)]))
    return rms(r_pub), rms(r_rb), keep.sum(axis=0)
