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


def _instants(shared, urdf, window_s, stride=10, v_rest=1e-3):
    """The analysis instants: (q̇ there, keep mask, τ − RNEA(q, q̇, q̈))."""
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
    return vi, keep, ts[idx] - rb


def published_rmse(shared, urdf, window_s, stride=10, v_rest=1e-3):
    """Per joint RMSE of τ − RNEA(q, q̇, q̈) − τ_f(q̇) on the analysis instants, and the
    same without friction (rigid body only)."""
    vi, keep, r_rb = _instants(shared, urdf, window_s, stride, v_rest)
    r_pub = r_rb - published_friction(vi)
    rms = lambda r: np.sqrt(np.array([np.mean(r[keep[:, j], j] ** 2) for j in range(7)]))
    return rms(r_pub), rms(r_rb), keep.sum(axis=0)


def friction_vs_published(shared, urdf, window_s, friction):
    """An identified friction law next to the published one (Supp. Table I) on the analysis
    instants: per joint the RMS and the largest |τ_f,identified(q̇) − τ_f,published(q̇)|, and the
    published model's scatter there (the RMS of τ − RNEA − τ_f,published, its residual).
    `friction(v)` maps the (N, 7) velocities to the identified friction torques."""
    vi, keep, r_rb = _instants(shared, urdf, window_s)
    diff = friction(vi) - published_friction(vi)
    scatter = r_rb - published_friction(vi)
    pick = lambda r, j: r[keep[:, j], j]  # noqa: E731
    rms_diff = np.array([np.sqrt(np.mean(pick(diff, j) ** 2)) for j in range(7)])
    max_diff = np.array([np.abs(pick(diff, j)).max() for j in range(7)])
    sc = np.array([np.sqrt(np.mean(pick(scatter, j) ** 2)) for j in range(7)])
    return rms_diff, max_diff, sc


def baseline_friction(report):
    """The baseline's f_v q̇ + f_c sgn(q̇) + f_o per joint from a report.json."""
    b = [report["baseline"]["joints"][f"joint{j}"] for j in range(1, 8)]
    fv, fc, fo = (np.array([x[k] for x in b]) for k in ("f_v", "f_c", "f_o"))
    return lambda v: fv * v + fc * np.sign(v) + fo


def extended_friction(report, params_yaml):
    """The extended model's friction: the eq. 5 law of extended_params.yaml (exact sign) plus
    a `torque_offset` finding, per joint."""
    import yaml

    joints = {j["joint"]: j for j in yaml.safe_load(open(params_yaml))["joints"]}
    off = np.zeros(7)
    for f in report["findings"]:
        if f["significant"] and f["effect"] == "torque_offset":
            for k, p in f["params"].items():
                off[int(k.removeprefix("joint")) - 1] = p["offset_nm"]

    def law(v):
        out = np.zeros_like(v)
        for j in range(7):
            p = joints[j + 1]
            x = v[:, j]
            if "positive" in p:  # per direction
                pp, pn = p["positive"], p["negative"]
                for sel, q in ((x > 0, pp), (x < 0, pn)):
                    out[sel, j] = np.sign(x[sel]) * (q["f_a"] + (q["f_b"] - q["f_a"]) * np.exp(-(x[sel] / q["q_s"]) ** 2)) + q["f_v"] * x[sel]
            elif "f_c" in p:  # eq. 4
                out[:, j] = p["f_c"] * np.sign(x) + p["f_v"] * x
            else:
                out[:, j] = np.sign(x) * (p["f_a"] + (p["f_b"] - p["f_a"]) * np.exp(-(x / p["q_s"]) ** 2)) + p["f_v"] * x
        return out + off

    return law
