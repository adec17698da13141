"""Synthetic "measured" joint data with one hidden effect, independent of
`crates/naic_explain/src/generate.rs` (no shared code, data or conventions beyond the CSV
format and the report's parameter names).

Truth torque per joint j at instant t (the instants are the controller's, jittered):

    τ_j = RNEA(q, q̇, q̈)_j  [Pinocchio, of the URDF; the payload / inertial cases use a changed model]
        + f_c,j · c(q̇_j) + f_v,j · q̇_j                      [Coulomb (sign or tanh) + viscous]
        + the hidden effect
    measured τ_j = τ_j(t − delay) · scale_j + offset + white noise σ
    measured q_j = q_j quantised to 2¹⁹ counts per turn; dq_j = q̇_j + white noise

The ground truth (`truth` dict, written as JSON) has the effect, its joints and the true
parameters under the names of `naic explain`'s report, plus the precondition numbers: the
RMS of the effect's torque on the samples the analysis can use (moving, away from a change
of direction) next to the noise after a 51 ms smoother.
"""
import dataclasses
import json
import pathlib
import zlib

import numpy as np
import pinocchio as pin

from . import motion as motion_mod
from . import robots

EFFECTS = (
    "friction_asymmetry", "stribeck", "position_ripple", "payload", "torque_offset", "delay", "drift",
    "rotor_inertia", "viscous_nonlinearity", "torque_scale", "position_torque", "inertial_parameters",
)
COUNTS_PER_TURN = 2**19
QS_RANGES = {"low": (0.002, 0.005), "mid": (0.01, 0.05), "high": (0.1, 0.3)}


@dataclasses.dataclass
class Case:
    """One generated data set. `effect=None` is noise only (nominal model + noise)."""
    arm: str = "jk5"
    effect: str | None = None
    excitation: str = "multisine"
    rate_hz: float = 1000.0
    duration_s: float = 60.0
    noise: float | None = None  # torque noise σ [N·m]; None: drawn in [0.02, 0.08]
    friction: str = "sign"  # Coulomb shape: sign | tanh (width 0.3–1 mrad/s)
    q_s: str = "mid"  # Stribeck q_s range (QS_RANGES) of a hidden `stribeck`
    jitter: str = "none"  # none | small (±25 % of a period, stamps still near-uniform) | controller (period 0.7–1.3×, 1 % late cycles 2–8×)
    tip: str = "tip"  # name of the tool frame in the URDF written for the analysis
    seed: int = 0

    def label(self):
        return f"{self.arm}/{self.effect or 'noise_only'}/{self.excitation}/{self.rate_hz:g}Hz/{self.duration_s:g}s/" \
               f"noise={self.noise}/{self.friction}/qs={self.q_s}/jitter={self.jitter}/tip={self.tip}/seed={self.seed}"


def _rng(case):
    tag = zlib.crc32(f"{case.arm}|{case.effect}|{case.excitation}|{case.q_s}".encode())
    return np.random.default_rng(np.random.SeedSequence([case.seed, tag]))


def _instants(case, rng):
    dt = 1.0 / case.rate_hz
    n = int(round(case.duration_s * case.rate_hz))
    if case.jitter == "none":
        return np.arange(n) * dt
    if case.jitter == "small":
        return np.arange(n) * dt + dt * np.clip(rng.normal(0.0, 0.08, n), -0.25, 0.25)
    if case.jitter == "controller":
        period = dt * np.clip(1.0 + rng.normal(0.0, 0.08, n), 0.7, 1.3)
        late = rng.random(n) < 0.01
        period[late] = dt * rng.uniform(2.0, 8.0, late.sum())
        t = np.concatenate([[0.0], np.cumsum(period[:-1])])
        return t[t < case.duration_s]
    raise ValueError(f"unknown jitter `{case.jitter}`; use none, small or controller")


def analysable(t, dq, window_s=0.06, v_min=2e-3):
    """Samples where a joint moves faster than `v_min` and keeps its direction for ± window/2
    (what any static friction analysis can use): bool (N, nj)."""
    moving = np.abs(dq) > v_min
    regime = np.sign(dq) * moving
    ok = moving.copy()
    for j in range(dq.shape[1]):
        c = t[1:][np.diff(regime[:, j]) != 0]
        mark = np.zeros(len(t) + 1, int)  # +1 from the first sample within a window of a change, −1 after the last
        np.add.at(mark, np.searchsorted(t, c - window_s / 2), 1)
        np.add.at(mark, np.searchsorted(t, c + window_s / 2, side="right"), -1)
        ok[np.cumsum(mark)[:-1] > 0, j] = False
    return ok


def _rnea(model, q, dq, ddq):
    data = model.createData()
    return np.array([pin.rnea(model, data, q[i], dq[i], ddq[i]) for i in range(len(q))])


def _base_friction(arm, rng):
    nj = arm.nj
    if arm.model.name == "panda":
        big = np.arange(nj) < 4
        fc = np.where(big, rng.uniform(0.4, 1.0, nj), rng.uniform(0.2, 0.6, nj))
        fv = np.where(big, rng.uniform(0.3, 1.0, nj), rng.uniform(0.1, 0.5, nj))
    else:
        big = np.arange(nj) < 3
        fc = np.where(big, rng.uniform(2.0, 6.0, nj), rng.uniform(0.8, 2.5, nj))
        fv = np.where(big, rng.uniform(1.0, 4.0, nj), rng.uniform(0.4, 1.5, nj))
    return fc, fv


def _big_joints(arm):
    return list(range(4 if arm.nj == 7 else 3))


def _tip_placement(model, tip):
    f = model.frames[model.getFrameId(tip)]
    return f.parentJoint, f.placement


class _Truth:
    """The hidden effect's terms; every field neutral unless the effect sets it."""

    def __init__(self, nj):
        self.asym = np.zeros(nj)  # f_c of the negative direction minus that of the positive
        self.strib = np.zeros((nj, 2))  # (f_s, q_s)
        self.ripple = np.zeros((nj, 3))  # (amplitude, k, phase), flips with direction
        self.pos_torque = np.zeros((nj, 3))  # (amplitude, k, phase), does not flip
        self.offset = np.zeros(nj)
        self.drift = np.zeros(nj)
        self.rotor = np.zeros(nj)
        self.visc2 = np.zeros(nj)
        self.scale = np.ones(nj)
        self.delay = 0.0
        self.model = None  # changed rigid-body model (payload, inertial_parameters)


def _draw_effect(case, arm, rng, fc, tr):
    """Sets the effect's terms in `tr`; returns (joints [1-based], params {jointK: {name: value}}, extra)."""
    e = case.effect
    nj = arm.nj
    big = _big_joints(arm)
    any_j = int(rng.integers(nj))
    jk = lambda j: f"joint{j + 1}"  # noqa: E731
    if e is None:
        return [], {}, {}
    if e == "friction_asymmetry":
        j = any_j
        d = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.5) * fc[j]
        tr.asym[j] = d
        return [j + 1], {jk(j): {"f_c_difference": -d}}, {}
    if e == "stribeck":
        j = any_j
        lo, hi = QS_RANGES[case.q_s]
        qs = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        fs = rng.uniform(0.5, 1.0) * fc[j]
        tr.strib[j] = (fs, qs)
        return [j + 1], {jk(j): {"f_s": fs, "q_s": qs}}, {}
    if e in ("position_ripple", "position_torque"):
        j = any_j
        if e == "position_ripple":
            a, k = rng.uniform(0.25, 0.45) * fc[j], rng.uniform(8.0, 40.0)
            tr.ripple[j] = (a, k, rng.uniform(0, 2 * np.pi))
        else:
            a, k = rng.uniform(0.5, 1.5) * (1.0 if j in big else 0.4), rng.uniform(3.0, 20.0)
            tr.pos_torque[j] = (a, k, rng.uniform(0, 2 * np.pi))
        return [j + 1], {jk(j): {"amplitude_nm": a, "k_per_rad": k}}, {}
    if e == "torque_offset":
        j = any_j
        tr.offset[j] = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.8)
        return [j + 1], {jk(j): {"offset_nm": tr.offset[j]}}, {}
    if e == "drift":
        j = any_j
        tr.drift[j] = rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.5) * fc[j]
        return [j + 1], {jk(j): {"delta_f_c_nm": tr.drift[j]}}, {}
    if e == "rotor_inertia":
        j = int(rng.choice(big))
        tr.rotor[j] = rng.uniform(0.2, 0.6) if arm.nj == 6 else rng.uniform(0.1, 0.4)
        return [j + 1], {jk(j): {"inertia_kgm2": tr.rotor[j]}}, {}
    if e == "viscous_nonlinearity":
        j = any_j
        tr.visc2[j] = rng.uniform(2.0, 5.0) * fc[j]
        return [j + 1], {jk(j): {"f_v2": tr.visc2[j]}}, {}
    if e == "torque_scale":
        # a drive gain on a joint that carries rigid-body torque (on the wrist joints it is
        # ~0.1 N·m, and a gain on the friction alone is a friction level, not a scale)
        j = int(rng.choice(big))
        eps = rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.15)
        tr.scale[j] = 1.0 + eps
        return [j + 1], {jk(j): {"scale": 1.0 + eps}}, {}
    if e == "delay":
        tr.delay = rng.uniform(0.004, 0.02)
        return list(range(1, nj + 1)), {jk(j): {"delay_s": tr.delay} for j in range(nj)}, {}
    if e == "payload":
        m = rng.uniform(0.8, 2.5) if arm.nj == 6 else rng.uniform(0.5, 1.5)
        model = arm.model.copy()
        parent, placement = _tip_placement(model, arm.tip)
        # a point mass at the tip frame's origin, merged into the link that carries it
        model.inertias[parent] = model.inertias[parent] + pin.Inertia(m, placement.translation, np.zeros((3, 3)))
        tr.model = model
        return list(range(1, nj + 1)), {jk(j): {"mass_kg": m} for j in range(nj)}, {"mass_kg": m}
    if e == "inertial_parameters":
        model = arm.model.copy()
        link = int(rng.choice([2, 3])) if arm.nj == 6 else int(rng.choice([3, 4]))  # joint index of a heavy mid link
        # copies: `model.inertias[link]` is a reference into the model, which the assignment
        # below overwrites (the truth then recorded the changed link as the URDF's and applied
        # the change twice: 56-59 % of the hidden error "left" by any estimate)
        old = model.inertias[link]
        mass0, lever0, inertia0 = float(old.mass), np.array(old.lever), np.array(old.inertia)
        f = rng.uniform(1.2, 1.4)
        shift = rng.uniform(-0.03, 0.03, 3)
        model.inertias[link] = pin.Inertia(mass0 * f, lever0 + shift, inertia0 * f)
        tr.model = model
        name = arm.model.names[link]
        return list(range(1, link + 1)), {}, {"joint": name, "joint_index": link, "mass_kg_urdf": mass0, "mass_kg": mass0 * f,
                                               "com_shift_m": shift.tolist(), "com_m": (lever0 + shift).tolist(),
                                               "inertia_about_com": (inertia0 * f).tolist()}
    raise ValueError(f"unknown effect `{e}`; known: {', '.join(EFFECTS)}")


def _terms(model, tr, fc, fv, coulomb, motion, t, t_total):
    """(rigid body, nominal friction, hidden-effect terms, motion) at the instants `t`."""
    q, dq, ddq = motion(t)
    rb = _rnea(model, q, dq, ddq)
    c = coulomb(dq)
    nominal = fc * c + fv * dq
    extra = c * (tr.asym * (dq < 0))
    fs, qs = tr.strib[:, 0], tr.strib[:, 1]
    extra += c * fs * np.exp(-((dq / np.where(qs > 0, qs, 1.0)) ** 2))
    a, k, ph = tr.ripple.T
    extra += c * a * np.sin(k * q + ph)
    a, k, ph = tr.pos_torque.T
    extra += a * np.sin(k * q + ph)
    extra += c * tr.drift * (t[:, None] / t_total - 0.5)
    extra += tr.rotor * ddq + tr.visc2 * c * dq**2
    return rb, nominal, extra, (q, dq, ddq)


def generate(case, workdir, arrays=False):
    """Writes `<label>.csv` (the `naic explain --measured` time-series format) and its ground
    truth `.json` into `workdir`; returns (csv path, urdf path, truth dict). With `arrays`,
    truth["arrays"] also holds the noise-free series (t, q, dq, ddq, tau, tau_without_effect)."""
    workdir = pathlib.Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    rng = _rng(case)
    arm = robots.make(case.arm, workdir)
    urdf = arm.urdf
    if case.tip != "tip":  # the analysis gets a URDF whose tool frame has another name
        urdf = workdir / f"{case.arm}_{case.tip}.urdf"
        # the link and every reference to it (a joint's <child link="tip"/>)
        text = arm.urdf.read_text().replace('name="tip"', f'name="{case.tip}"').replace('link="tip"', f'link="{case.tip}"')
        urdf.write_text(text)
    t = _instants(case, rng)
    exc = motion_mod.make(case.excitation, rng, arm.home, case.duration_s, arm.lower, arm.upper)
    fc, fv = _base_friction(arm, rng)
    if case.friction == "sign":
        coulomb = np.sign
        width = None
    elif case.friction == "tanh":
        width = rng.uniform(3e-4, 1e-3, arm.nj)
        coulomb = lambda v: np.tanh(v / width)  # noqa: E731
    else:
        raise ValueError(f"unknown friction shape `{case.friction}`; use sign or tanh")
    sigma = rng.uniform(0.02, 0.08) if case.noise is None else float(case.noise)
    tr = _Truth(arm.nj)
    joints, params, effect_info = _draw_effect(case, arm, rng, fc, tr)
    model = tr.model if tr.model is not None else arm.model
    t_total = t[-1] - t[0]

    rb, nominal, extra, (q, dq, ddq) = _terms(model, tr, fc, fv, coulomb, exc, t, t_total)
    if tr.delay:  # the torque channel shows the torque of `delay` seconds earlier (exact, not interpolated)
        rb_d, nominal_d, extra_d, _ = _terms(model, tr, fc, fv, coulomb, exc, t - tr.delay, t_total)
        tau = rb_d + nominal_d + extra_d
    else:
        tau = rb + nominal + extra
    tau = tau * tr.scale + tr.offset
    rb_nominal = rb if tr.model is None else _rnea(arm.model, q, dq, ddq)
    effect_tau = tau - (rb_nominal + nominal)
    if case.effect == "torque_scale":
        # what a scale can show: (k − 1)·τ_rb; (k − 1)·friction is a change of the friction levels
        effect_tau = (tr.scale - 1.0) * rb

    ok = analysable(t, dq)
    rms = {f"joint{j + 1}": float(np.sqrt(np.mean(effect_tau[ok[:, j], j] ** 2))) if ok[:, j].any() else 0.0
           for j in range(arm.nj)}
    n_win = max(7, 0.051 * case.rate_hz)
    sigma_f = sigma * 1.6 / np.sqrt(n_win)  # white noise after a 51 ms quintic Savitzky–Golay smoother (≈)

    quant = 2 * np.pi / COUNTS_PER_TURN
    q_meas = np.round(q / quant) * quant
    dq_meas = dq + rng.normal(0.0, 2e-4, dq.shape)
    tau_meas = tau + rng.normal(0.0, sigma, tau.shape)

    stem = case.label().replace("/", "_").replace("=", "-")
    csv = workdir / f"{stem}.csv"
    nj = arm.nj
    header = "t," + ",".join(f"{p}{j}" for p in ("q", "dq", "tau") for j in range(1, nj + 1))
    np.savetxt(csv, np.column_stack([t, q_meas, dq_meas, tau_meas]), delimiter=",", header=header, comments="",
               fmt=["%.9f"] + ["%.10g"] * (2 * nj) + ["%.6f"] * nj)
    truth = {
        "generator": "tests/python/explain_gen (Python + Pinocchio RNEA)",
        "case": dataclasses.asdict(case),
        "urdf": str(urdf),
        "n_joints": nj,
        "samples": int(len(t)),
        "effect": case.effect,
        "joints": joints,
        "params": params,
        "extra": effect_info,
        "noise_sigma_nm": sigma,
        "noise_after_smoother_nm": sigma_f,
        "effect_rms_nm": rms,
        "base_friction": {"f_c": fc.tolist(), "f_v": fv.tolist(), "shape": case.friction,
                          "tanh_width_rad_s": None if width is None else width.tolist()},
        "timestamps": {"jitter": case.jitter, "median_step_s": float(np.median(np.diff(t))),
                       "min_step_s": float(np.diff(t).min()), "max_step_s": float(np.diff(t).max())},
    }
    csv.with_suffix(".json").write_text(json.dumps(truth, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    if arrays:
        truth["arrays"] = {"t": t, "q": q, "dq": dq, "ddq": ddq, "tau": tau, "tau_without_effect": rb_nominal + nominal}
    return csv, urdf, truth
