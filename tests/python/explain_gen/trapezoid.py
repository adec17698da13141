"""A third generator of measured-like JK5 data for `naic explain` (issue 38), written from the
issue's description alone. It imports nothing from this package, from
`crates/naic_explain/src/generate.rs` or from any other code of the project: numpy and
Pinocchio (`pin`) only. The scorer (`check.score`) may read its truth, which uses the report's
parameter names.

Motion (closed form at the sample instants):
  * each joint in turn makes **trapezoidal velocity moves**, out and back, at four cruise speeds
    drawn in 0.02–0.4 rad/s; every speed change is a 50 ms ramp of constant acceleration, so the
    acceleration *steps* at the trapezoid's four corners (the other joints hold still);
  * then 30 s of a multi-sine on all joints, q = q₀ + Σ a_k (1 − cos ω_k t) (starts at rest).
Dynamics: Pinocchio RNEA on the JK5 URDF (`urdf/jk5.urdf`, the model the analysis gets) plus
eq. 5 friction with the exact sign, τ_f = sgn(q̇)[f_a + (f_b − f_a) e^{−(q̇/q_s)²}] + f_v q̇,
evaluated at the true velocity, plus at most one hidden effect.
Measurement: encoders of 2²⁰ counts per turn; the `dq` column is the encoder difference over
one sample (`velocity="difference"`) or the true velocity with 0.002 rad/s of white noise
(`velocity="noisy"`); torque noise 0.05 N·m; 100 Hz–2 kHz.

`nominal_yaml(...)` writes the `--nominal` file with the exact friction shape (each joint's
f_a, f_b, q_s, f_v, both directions alike).
"""
import dataclasses
import json
import pathlib
import zlib

import numpy as np
import pinocchio as pin

ROOT = pathlib.Path(__file__).resolve().parents[3]
URDF = ROOT / "urdf" / "jk5.urdf"
COUNTS = 2**20
RAMP_S = 0.05
HOME = np.array([0.3, 1.0, -1.4, 0.8, 1.2, 0.5])
EFFECTS = ("friction_asymmetry", "position_ripple", "position_torque", "payload", "torque_offset", "delay", "drift",
           "torque_scale", "inertial_parameters")


@dataclasses.dataclass
class TrapCase:
    effect: str | None = None
    rate_hz: float = 1000.0
    velocity: str = "noisy"  # noisy | difference
    friction: str = "drawn"  # drawn (seeded levels) | table1 (the paper's Table 1, directions averaged)
    # the q̈ the torque is computed with: exact, or `backward` = (q̇_k − q̇_{k−1})/dt as a
    # discrete-time producer may take it (the torque's inertia part then lags by half a sample)
    accel: str = "exact"
    torque_noise: float = 0.05
    seed: int = 0

    def label(self):
        return f"trap_{self.effect or 'clean'}_{self.rate_hz:g}Hz_{self.velocity}_{self.friction}_{self.accel}_s{self.seed}"


def _rng(case):
    return np.random.default_rng([case.seed, zlib.crc32(f"trap|{case.effect}|{case.rate_hz}".encode())])


class Trapezoids:
    """Piecewise-constant acceleration per joint: a list of (t_start, joint, acceleration)
    changes; q, q̇, q̈ integrate it exactly."""

    def __init__(self, rng):
        self.events = []  # (t, joint, new acceleration)
        t = 0.5
        for j in range(6):
            speeds = np.sort(np.exp(rng.uniform(np.log(0.02), np.log(0.4), 4)))
            speeds[0], speeds[-1] = 0.02 * rng.uniform(1.0, 1.2), 0.4 * rng.uniform(0.85, 1.0)
            for v in speeds:
                cruise = float(np.clip(0.3 / v, 0.8, 1.6))
                for sign in (1.0, -1.0):
                    a = sign * v / RAMP_S
                    self.events += [(t, j, a), (t + RAMP_S, j, 0.0), (t + RAMP_S + cruise, j, -a),
                                    (t + 2 * RAMP_S + cruise, j, 0.0)]
                    t += 2 * RAMP_S + cruise + rng.uniform(0.3, 0.5)
            t += 0.3
        self.end = t

    def __call__(self, t):
        n = len(t)
        q, dq, ddq = np.tile(HOME, (n, 1)), np.zeros((n, 6)), np.zeros((n, 6))
        for j in range(6):
            ev = [(te, a) for te, jj, a in self.events if jj == j]
            if not ev:
                continue
            # state at each event, then integrate from the last event before each instant
            te = np.array([e[0] for e in ev])
            acc = np.array([e[1] for e in ev])
            p0, v0 = np.zeros(len(ev)), np.zeros(len(ev))
            for k in range(1, len(ev)):
                h = te[k] - te[k - 1]
                v0[k] = v0[k - 1] + acc[k - 1] * h
                p0[k] = p0[k - 1] + v0[k - 1] * h + 0.5 * acc[k - 1] * h * h
            k = np.searchsorted(te, t, side="right") - 1
            act = k >= 0
            kk = np.clip(k, 0, None)
            h = t - te[kk]
            ddq[act, j] = acc[kk][act]
            vel = v0[kk] + acc[kk] * h
            # at rest exactly at rest: the sums above leave ~1e-17 rad/s, whose sign would put
            # the full Coulomb level into a joint that stands still
            vel[np.abs(vel) < 1e-12] = 0.0
            dq[act, j] = vel[act]
            q[act, j] += (p0[kk] + v0[kk] * h + 0.5 * acc[kk] * h * h)[act]
        return q, dq, ddq


class MultiSine:
    def __init__(self, rng, start):
        self.start = start
        self.w = 2 * np.pi * 0.1 * np.array([1, 2, 3, 5])
        self.amp = rng.uniform(0.02, 0.12, (6, 4)) * rng.choice([-1.0, 1.0], (6, 4))

    def __call__(self, t):
        s = np.clip(t - self.start, 0.0, None)[:, None, None]
        on = (t >= self.start)[:, None]
        w, a = self.w[None, None, :], self.amp[None, :, :]
        q = HOME + on * np.sum(a * (1 - np.cos(w * s)), axis=2)
        dq = on * np.sum(a * w * np.sin(w * s), axis=2)
        ddq = on * np.sum(a * w * w * np.cos(w * s), axis=2)
        return q, dq, ddq


def _friction(rng, kind="drawn"):
    if kind == "table1":  # the JK5's measured friction (params/friction_jk5.yaml), both directions averaged
        import yaml

        js = yaml.safe_load((ROOT / "params" / "friction_jk5.yaml").read_text())["joints"]
        avg = lambda k: np.array([0.5 * (j["positive"][k] + j["negative"][k]) for j in js])  # noqa: E731
        return avg("f_a"), avg("f_b"), avg("q_s"), avg("f_v")
    if kind != "drawn":
        raise ValueError(f"unknown friction `{kind}`; use drawn or table1")
    big = np.arange(6) < 3
    f_a = np.where(big, rng.uniform(2.0, 6.0, 6), rng.uniform(0.6, 2.0, 6))
    f_b = f_a * rng.uniform(1.1, 1.5, 6)
    q_s = rng.uniform(0.01, 0.06, 6)
    f_v = np.where(big, rng.uniform(1.0, 4.0, 6), rng.uniform(0.3, 1.2, 6))
    return f_a, f_b, q_s, f_v


def eq5(dq, f_a, f_b, q_s, f_v):
    return np.sign(dq) * (f_a + (f_b - f_a) * np.exp(-((dq / q_s) ** 2))) + f_v * dq


def nominal_yaml(path, f_a, f_b, q_s, f_v):
    lines = ["# the exact friction shape of a trapezoid-generator data set (eq. 5, symmetric)",
             'source: "tests/python/explain_gen/trapezoid.py: the generating law"', "joints:"]
    for j in range(6):
        lines.append(f"  - joint: {j + 1}\n    model: stribeck\n    f_a: {f_a[j]:.9g}\n    f_b: {f_b[j]:.9g}\n"
                     f"    q_s: {q_s[j]:.9g}\n    f_v: {f_v[j]:.9g}")
    pathlib.Path(path).write_text("\n".join(lines) + "\n")


def generate(case, workdir, arrays=False):
    """Writes the CSV, the nominal YAML and the truth JSON; returns (csv, nominal, urdf, truth)."""
    workdir = pathlib.Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    rng = _rng(case)
    model = pin.buildModelFromUrdf(str(URDF))
    assert model.nv == 6
    trap = Trapezoids(rng)
    ms = MultiSine(rng, trap.end)
    total = trap.end + 30.0
    dt = 1.0 / case.rate_hz
    t = np.arange(int(total / dt)) * dt
    q, dq, ddq = trap(t)
    qm, dqm, ddqm = ms(t)
    on = t >= trap.end
    q[on], dq[on], ddq[on] = qm[on], dqm[on], ddqm[on]
    f_a, f_b, q_s, f_v = _friction(rng, case.friction)

    e = case.effect
    jk = lambda j: f"joint{j + 1}"  # noqa: E731
    joint = int(rng.integers(6))
    big = int(rng.integers(3))
    params, joints, extra = {}, [], {}
    true_model = model
    delay, scale, offset = 0.0, np.ones(6), np.zeros(6)
    asym = np.zeros(6)
    ripple = np.zeros((6, 3))
    cog = np.zeros((6, 3))
    drift = np.zeros(6)
    if e is None:
        pass
    elif e == "friction_asymmetry":
        d = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.5) * f_a[joint]
        asym[joint] = d  # the negative direction's level minus the positive's
        joints, params = [joint + 1], {jk(joint): {"f_c_difference": -d}}
    elif e == "position_ripple":
        a, k = rng.uniform(0.25, 0.45) * f_a[joint], rng.uniform(8.0, 40.0)
        ripple[joint] = (a, k, rng.uniform(0, 2 * np.pi))
        joints, params = [joint + 1], {jk(joint): {"amplitude_nm": a, "k_per_rad": k}}
    elif e == "position_torque":  # cogging: the 0.6 N·m at about 30 rad⁻¹
        a, k = rng.uniform(0.4, 0.8) * (1.0 if joint < 3 else 0.5), rng.uniform(15.0, 40.0)
        cog[joint] = (a, k, rng.uniform(0, 2 * np.pi))
        joints, params = [joint + 1], {jk(joint): {"amplitude_nm": a, "k_per_rad": k}}
    elif e == "torque_offset":
        offset[joint] = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.8)
        joints, params = [joint + 1], {jk(joint): {"offset_nm": offset[joint]}}
    elif e == "drift":
        drift[joint] = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.5) * f_a[joint]
        joints, params = [joint + 1], {jk(joint): {"delta_f_c_nm": drift[joint]}}
    elif e == "torque_scale":
        scale[big] = 1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.15)
        joints, params = [big + 1], {jk(big): {"scale": scale[big]}}
    elif e == "delay":
        delay = rng.uniform(0.004, 0.02)
        joints, params = list(range(1, 7)), {jk(j): {"delay_s": delay} for j in range(6)}
    elif e == "payload":
        m = rng.uniform(0.8, 2.5)
        true_model = model.copy()
        f = true_model.frames[true_model.getFrameId("tip")]
        true_model.inertias[f.parentJoint] = true_model.inertias[f.parentJoint] + pin.Inertia(
            m, np.array(f.placement.translation), np.zeros((3, 3)))
        joints, params, extra = list(range(1, 7)), {jk(j): {"mass_kg": m} for j in range(6)}, {"mass_kg": m}
    elif e == "inertial_parameters":
        true_model = model.copy()
        link = int(rng.choice([2, 3]))
        old = model.inertias[link]
        mass0, lever0, inertia0 = float(old.mass), np.array(old.lever), np.array(old.inertia)
        fm, shift = rng.uniform(1.2, 1.4), rng.uniform(-0.03, 0.03, 3)
        true_model.inertias[link] = pin.Inertia(mass0 * fm, lever0 + shift, inertia0 * fm)
        joints = list(range(1, link + 1))
        extra = {"joint_index": link, "mass_kg": mass0 * fm, "com_m": (lever0 + shift).tolist(),
                 "inertia_about_com": (inertia0 * fm).tolist()}
    else:
        raise ValueError(f"unknown effect `{e}`; known: {', '.join(EFFECTS)}")

    def torque(tt, qq, vv, aa, mdl):
        data = mdl.createData()
        if case.accel == "backward":
            aa = np.vstack([aa[:1], np.diff(vv, axis=0) / dt])
        elif case.accel != "exact":
            raise ValueError(f"unknown accel `{case.accel}`; use exact or backward")
        rb = np.array([pin.rnea(mdl, data, qq[i], vv[i], aa[i]) for i in range(len(tt))])
        s = np.sign(vv)
        fr = eq5(vv, f_a, f_b, q_s, f_v) + s * asym * (vv < 0)
        fr += s * ripple[:, 0] * np.sin(ripple[:, 1] * qq + ripple[:, 2])
        fr += cog[:, 0] * np.sin(cog[:, 1] * qq + cog[:, 2])
        fr += s * drift * (tt[:, None] / total - 0.5)
        return rb, fr

    rb, fr = torque(t, q, dq, ddq, true_model)
    if delay:
        td = t - delay
        qd, dqd, ddqd = trap(td)
        qm, dqm, ddqm = ms(td)
        ond = td >= trap.end
        qd[ond], dqd[ond], ddqd[ond] = qm[ond], dqm[ond], ddqm[ond]
        rbd, frd = torque(td, qd, dqd, ddqd, true_model)
        tau = rbd + frd
    else:
        tau = rb + fr
    tau = tau * scale + offset
    rb_nominal = rb if true_model is model else torque(t, q, dq, ddq, model)[0]
    nominal = rb_nominal + eq5(dq, f_a, f_b, q_s, f_v)
    effect_tau = (scale - 1.0) * rb_nominal if e == "torque_scale" else tau - nominal

    quant = 2 * np.pi / COUNTS
    q_meas = np.round(q / quant) * quant
    if case.velocity == "difference":
        dq_meas = np.vstack([np.zeros((1, 6)), np.diff(q_meas, axis=0) / dt])
    elif case.velocity == "noisy":
        dq_meas = dq + rng.normal(0.0, 0.002, dq.shape)
    else:
        raise ValueError(f"unknown velocity `{case.velocity}`; use noisy or difference")
    tau_meas = tau + rng.normal(0.0, case.torque_noise, tau.shape)

    csv = workdir / f"{case.label()}.csv"
    header = "t," + ",".join(f"{p}{j}" for p in ("q", "dq", "tau") for j in range(1, 7))
    np.savetxt(csv, np.column_stack([t, q_meas, dq_meas, tau_meas]), delimiter=",", header=header, comments="",
               fmt=["%.7f"] + ["%.10g"] * 12 + ["%.6f"] * 6)
    nominal_path = workdir / f"{case.label()}_nominal.yaml"
    nominal_yaml(nominal_path, f_a, f_b, q_s, f_v)
    moving = np.abs(dq) > 2e-3
    rms = {jk(j): float(np.sqrt(np.mean(effect_tau[moving[:, j], j] ** 2))) if moving[:, j].any() else 0.0 for j in range(6)}
    truth = {
        "generator": "tests/python/explain_gen/trapezoid.py (numpy + Pinocchio RNEA, trapezoidal moves)",
        "case": dataclasses.asdict(case), "urdf": str(URDF), "n_joints": 6, "samples": int(len(t)),
        "effect": e, "joints": joints, "params": params, "extra": extra,
        "noise_sigma_nm": case.torque_noise,
        "noise_after_smoother_nm": case.torque_noise * 1.6 / np.sqrt(max(7.0, 0.051 * case.rate_hz)),
        "effect_rms_nm": rms,
        "friction": {"f_a": f_a.tolist(), "f_b": f_b.tolist(), "q_s": q_s.tolist(), "f_v": f_v.tolist()},
        "timestamps": {"jitter": "none", "median_step_s": dt},
    }
    csv.with_suffix(".json").write_text(json.dumps(truth, indent=1, default=float))
    if arrays:
        truth["arrays"] = {"t": t, "q": q, "dq": dq, "ddq": ddq, "tau": tau, "tau_nominal": nominal}
    return csv, nominal_path, URDF, truth


if __name__ == "__main__":
    import argparse

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True)
    p.add_argument("--effect", default=None)
    p.add_argument("--rate", type=float, default=1000.0)
    p.add_argument("--velocity", default="noisy")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    c, n, _, tr = generate(TrapCase(effect=a.effect, rate_hz=a.rate, velocity=a.velocity, seed=a.seed), a.out)
    print(c, n, tr["params"])
