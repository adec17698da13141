"""Robustness of `naic explain` on data from an independent generator (tests/python/explain_gen:
Python + Pinocchio, no code shared with crates/naic_explain/src/generate.rs).

Goal (issue 14): each hidden effect named first in ≥ 19 of 20 seeds with its parameters within
the stated tolerances (explain_gen/check.py), and noise-only data giving any finding in ≤ 1 of
20 seeds, across sample rates, excitations, friction shapes, Stribeck q_s, noise, durations and
6 / 7 joints.

Default run: one seed per case and a subset of the cases (27 s CPU; 3.4 min wall on a loaded 2-core VM).
`NAIC_EXPLAIN_FULL=1`: every case with 20 seeds (seeds 0–19), `NAIC_EXPLAIN_LONG=1` adds the
one-hour recordings, `NAIC_EXPLAIN_SWEEP_LOG=FILE` appends each case's per-seed results as
JSON lines (`python -m explain_gen.table FILE` prints the table).

Cases where `naic explain` misses the goal are marked xfail(strict=True, raises=GoalNotMet)
with the full sweep's numbers: an unexpected pass fails the run (remove the mark), and any
other error (the generator's precondition, a crash of the CLI) fails as usual. Cases needing a
CLI feature this binary lacks (7 joints, `--tip`, resampling, a catalogue entry) are skipped
with the feature named, found from `naic explain --help` and its list of known effects.
"""
import json
import os
import pathlib
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from explain_gen import Case, check, generate, robots

FULL = os.environ.get("NAIC_EXPLAIN_FULL") == "1"
LONG = os.environ.get("NAIC_EXPLAIN_LONG") == "1"
LOG = os.environ.get("NAIC_EXPLAIN_SWEEP_LOG")
SHARD = os.environ.get("NAIC_EXPLAIN_SHARD")  # "i/n": run only every n-th case from the i-th (parallel sweeps)
N_SEEDS = 20
CURRENT = ("friction_asymmetry", "stribeck", "position_ripple", "payload", "torque_offset", "delay", "drift",
           "rotor_inertia", "viscous_nonlinearity", "inertial_parameters", "torque_scale", "position_torque")
NEW = ()


class GoalNotMet(AssertionError):
    """`naic explain` missed the issue's goal on a valid case (precondition met)."""


# Excitation each effect is shown with first: friction shapes need the slow stepped plateaus,
# inertia and delay need acceleration; the three excitations are all used.
BASE_EXCITATION = {
    "friction_asymmetry": "stepped", "stribeck": "stepped", "viscous_nonlinearity": "stepped", "drift": "stepped",
    "position_ripple": "multisine", "rotor_inertia": "multisine", "delay": "multisine", "torque_scale": "multisine",
    "position_torque": "multisine", "payload": "ptp", "torque_offset": "ptp", "inertial_parameters": "ptp",
}

# (id, Case fields, in the default run)
GRID = []
for e in CURRENT + NEW:
    GRID.append((f"{e}-base", dict(effect=e, excitation=BASE_EXCITATION[e]), e in CURRENT))
    GRID.append((f"{e}-panda", dict(effect=e, excitation=BASE_EXCITATION[e], arm="panda"), e in ("payload", "stribeck")))
# one condition changed at a time
GRID += [
    ("stribeck-qs_low", dict(effect="stribeck", excitation="stepped", q_s="low"), True),
    ("stribeck-qs_high", dict(effect="stribeck", excitation="stepped", q_s="high"), False),
    ("stribeck-tanh", dict(effect="stribeck", excitation="stepped", friction="tanh"), False),
    ("stribeck-qs_high-multisine", dict(effect="stribeck", excitation="multisine", q_s="high"), False),
    ("delay-100Hz", dict(effect="delay", excitation="multisine", rate_hz=100.0), False),
    ("delay-2kHz", dict(effect="delay", excitation="multisine", rate_hz=2000.0), False),
    ("delay-ptp", dict(effect="delay", excitation="ptp"), False),
    ("payload-noise0.2", dict(effect="payload", excitation="ptp", noise=0.2), False),
    ("payload-multisine", dict(effect="payload", excitation="multisine"), False),
    ("payload-tip_tool0", dict(effect="payload", excitation="ptp", tip="tool0"), True),
    ("rotor_inertia-ptp", dict(effect="rotor_inertia", excitation="ptp"), False),
    ("rotor_inertia-100Hz", dict(effect="rotor_inertia", excitation="multisine", rate_hz=100.0), False),
    ("position_ripple-stepped", dict(effect="position_ripple", excitation="stepped"), False),
    ("torque_offset-30s", dict(effect="torque_offset", excitation="ptp", duration_s=30.0), False),
    ("torque_offset-jitter_controller", dict(effect="torque_offset", excitation="ptp", jitter="controller"), True),
    ("friction_asymmetry-100Hz", dict(effect="friction_asymmetry", excitation="stepped", rate_hz=100.0), False),
    ("friction_asymmetry-tanh", dict(effect="friction_asymmetry", excitation="stepped", friction="tanh"), False),
    ("drift-300s", dict(effect="drift", excitation="stepped", duration_s=300.0), False),
    ("viscous_nonlinearity-noise0.01", dict(effect="viscous_nonlinearity", excitation="stepped", noise=0.01), False),
]
# noise only, across the grid
for cid, kw, dflt in [
    ("multisine", {}, True), ("stepped", dict(excitation="stepped"), True), ("ptp", dict(excitation="ptp"), True),
    ("tanh", dict(friction="tanh"), False), ("stepped-tanh", dict(excitation="stepped", friction="tanh"), False),
    ("100Hz", dict(rate_hz=100.0), False), ("2kHz", dict(rate_hz=2000.0), False),
    ("noise0.01", dict(noise=0.01), False), ("noise0.2", dict(noise=0.2), False),
    ("30s", dict(duration_s=30.0), False), ("300s", dict(duration_s=300.0, excitation="stepped"), False),
    ("jitter_small", dict(jitter="small"), False), ("jitter_controller", dict(jitter="controller"), False),
    ("panda", dict(arm="panda"), True),
]:
    GRID.append((f"noise_only-{cid}", dict(effect=None, **kw), dflt))
GRID.append(("noise_only-1h-200Hz", dict(effect=None, excitation="stepped", duration_s=3600.0, rate_hz=200.0), False))
GRID.append(("stribeck-1h-200Hz", dict(effect="stribeck", excitation="stepped", duration_s=3600.0, rate_hz=200.0), False))

# Cases where the full sweep (20 seeds) missed the goal: id -> (reason with the numbers, a
# failing seed: the one the default run uses). Empty since issue 14's third round (inert14
# branch, docs/explain.md "Issue 14, third round"): `torque_offset-base` went 18 → 19/20 and
# `inertial_parameters-base` 13 → 20/20.
KNOWN_FAILS = {}


def _seeds(cid):
    if FULL:
        return list(range(N_SEEDS))
    return [KNOWN_FAILS[cid][1]] if cid in KNOWN_FAILS else [0]


def _params():
    out = []
    for k, (cid, kw, dflt) in enumerate(GRID):
        marks = []
        if SHARD and k % int(SHARD.split("/")[1]) != int(SHARD.split("/")[0]):
            marks.append(pytest.mark.skip(reason=f"another shard of NAIC_EXPLAIN_SHARD={SHARD}"))
        if "3600" in cid.replace("1h", "3600") and not LONG:
            marks.append(pytest.mark.skip(reason="one-hour recording: set NAIC_EXPLAIN_LONG=1"))
        elif not FULL and not dflt:
            marks.append(pytest.mark.skip(reason="full robustness grid: set NAIC_EXPLAIN_FULL=1"))
        if cid in KNOWN_FAILS:
            marks.append(pytest.mark.xfail(strict=True, raises=GoalNotMet, reason=KNOWN_FAILS[cid][0]))
        out.append(pytest.param(cid, kw, id=cid, marks=marks))
    return out


def _visible(truth):
    """Precondition: the generator put the effect into the torque at a size the data can show:
    RMS on the usable samples of its joint(s) ≥ the noise after a 51 ms smoother (and ≥ 0.02 N·m)."""
    if truth["effect"] is None:
        return True, ""
    need = max(0.02, truth["noise_after_smoother_nm"])
    rms = [truth["effect_rms_nm"][f"joint{j}"] for j in truth["joints"]]
    # a payload is kept only when significant on ≥ 2 joints; a delay is one number, seen on any joint
    n_needed = 2 if truth["effect"] in ("payload", "inertial_parameters") else 1
    seen = sum(r >= need for r in rms)
    return seen >= n_needed, f"effect RMS {np.round(rms, 4).tolist()} N·m vs needed {need:.4f} on ≥ {n_needed} joint(s)"


@pytest.mark.parametrize("cid,kw", _params())
def test_explain_independent(naic_bin, tmp_path, cid, kw):
    base = Case(**kw)
    miss = check.missing_features(naic_bin, base)
    if miss:
        pytest.skip("naic explain lacks: " + "; ".join(miss))
    results = []
    for seed in _seeds(cid):
        case = Case(**{**kw, "seed": seed})
        work = tmp_path / f"s{seed}"
        csv, urdf, truth = generate(case, work, arrays=case.effect == "inertial_parameters")
        ok, why = _visible(truth)
        assert ok, f"generator precondition failed for {case.label()}: {why}"
        report = check.run_explain(naic_bin, csv, urdf, work / "out", tip=case.tip)
        r = check.score(report, truth)
        r.update(seed=seed, truth_params=truth["params"], effect_rms=truth["effect_rms_nm"], noise=truth["noise_sigma_nm"])
        results.append(r)
        csv.unlink()  # keep tmp small on long sweeps
    n_ok = sum(r["ok"] for r in results)
    n = len(results)
    if LOG:
        with open(LOG, "a") as f:
            f.write(json.dumps({"case": cid, "kw": kw, "n": n, "n_ok": n_ok, "results": results}, default=float) + "\n")
    if base.effect is None:
        n_false = n - n_ok
        if n_false > n // 20:
            bad = [(r["seed"], r["findings"]) for r in results if not r["ok"]]
            raise GoalNotMet(f"{cid}: noise only gave a finding in {n_false} of {n} seeds (allowed {n // 20}): {bad}")
    elif n - n_ok > n // 20:
        bad = [(r["seed"], r["first"], r["param_err"], r["errors"]) for r in results if not r["ok"]]
        raise GoalNotMet(f"{cid}: {n_ok} of {n} seeds passed (need {n - n // 20}); failures: {bad}")


@pytest.mark.parametrize("effect", ["torque_scale", "position_torque"])
@pytest.mark.parametrize("excitation", ["multisine", "stepped", "ptp"])
def test_new_effect_not_found_on_noise_only(naic_bin, tmp_path, effect, excitation):
    """A catalogue entry added since the noise-only sweep is never named on noise-only data
    (seeds 0–2 of each excitation; the noise-only cases above also count any other finding,
    some of them are known to give `stribeck`)."""
    if effect not in check.features(naic_bin)["effects"]:
        pytest.fail(f"`{effect}` is not in naic explain's catalogue")
    for seed in range(3):
        case = Case(effect=None, excitation=excitation, seed=seed)
        csv, urdf, _ = generate(case, tmp_path / f"s{seed}")
        report = check.run_explain(naic_bin, csv, urdf, tmp_path / f"s{seed}" / "out")
        found = [(f["effect"], f["targets"], f["params"]) for f in check.significant(report) if f["effect"] == effect]
        assert not found, f"{case.label()}: `{effect}` found on noise only: {found}"
        csv.unlink()


def test_panda_urdf_matches_mujoco(tmp_path):
    """The generator's Panda URDF (MJCF kinematics + inertial.yaml) has MuJoCo's dynamics:
    Pinocchio RNEA on it equals `mj_inverse` on the Menagerie MJCF (meshes dropped, the MJCF's
    armature and damping set to 0) at random states."""
    import mujoco
    import pinocchio as pin

    urdf = robots.write_panda_urdf(tmp_path / "panda.urdf")
    model = pin.buildModelFromUrdf(str(urdf))
    assert model.nv == 7 and model.existFrame("tip")
    root = ET.parse(robots.PANDA_DIR / "panda_nohand.xml").getroot()
    for parent in root.iter():
        for child in list(parent):
            if child.tag in ("geom", "mesh", "material", "light"):
                parent.remove(child)
    mj = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    mj.dof_armature[:] = 0.0
    mj.dof_damping[:] = 0.0
    d = mujoco.MjData(mj)
    data = model.createData()
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(20):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        v, a = rng.normal(size=7), rng.normal(size=7)
        d.qpos[:], d.qvel[:], d.qacc[:] = q, v, a
        mujoco.mj_inverse(mj, d)
        tau = pin.rnea(model, data, q, v, a)
        worst = max(worst, np.abs(tau - d.qfrc_inverse).max())
    assert worst < 1e-6, f"Pinocchio on the generated URDF vs MuJoCo on the MJCF: max |Δτ| = {worst} N·m"
    # the tip frame is the MJCF attachment site
    q = np.array(mj.key_qpos[0])
    d.qpos[:] = q
    mujoco.mj_kinematics(mj, d)
    pin.framesForwardKinematics(model, data, q)
    site = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_SITE, "attachment_site")
    assert np.allclose(data.oMf[model.getFrameId("tip")].translation, d.site_xpos[site], atol=1e-9)


def test_generator_writes_what_it_claims(tmp_path):
    """The CSV holds what the truth says: torque = Pinocchio RNEA + the stated friction + white
    noise of σ; encoder steps of 2π/2¹⁹; timestamps with the requested jitter; a delayed torque
    channel is the undelayed torque `delay` seconds earlier."""
    import pinocchio as pin

    c = Case(effect=None, excitation="ptp", duration_s=20.0, noise=0.05, seed=3)
    csv, urdf, truth = generate(c, tmp_path, arrays=True)
    d = np.loadtxt(csv, delimiter=",", skiprows=1)
    nj = truth["n_joints"]
    ar = truth["arrays"]
    t, q, tau = d[:, 0], d[:, 1:1 + nj], d[:, 1 + 2 * nj:]
    step = 2 * np.pi / 2**19
    assert np.abs(q / step - np.round(q / step)).max() < 1e-3
    assert np.abs(q - ar["q"]).max() <= step
    assert np.allclose(np.diff(t), 1e-3, atol=1e-9)
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    fc, fv = np.array(truth["base_friction"]["f_c"]), np.array(truth["base_friction"]["f_v"])
    sel = np.arange(0, len(t), 17)
    model_tau = np.array([pin.rnea(model, data, ar["q"][i], ar["dq"][i], ar["ddq"][i]) for i in sel])
    model_tau += fc * np.sign(ar["dq"][sel]) + fv * ar["dq"][sel]
    noise = tau[sel] - model_tau
    assert np.abs(noise.mean(axis=0)).max() < 0.01
    assert np.allclose(noise.std(axis=0), 0.05, rtol=0.1)
    # jittered controller stamps: late cycles of 2–8 periods, short ones down to 0.7
    j = generate(Case(effect=None, jitter="controller", duration_s=20.0, seed=3), tmp_path / "j")[2]["timestamps"]
    assert j["max_step_s"] > 2e-3 and 0.69e-3 < j["min_step_s"] < 0.8e-3, j
    # delay: the torque channel at t is the undelayed torque at t − d
    _, _, tr = generate(Case(effect="delay", excitation="multisine", duration_s=10.0, seed=4), tmp_path / "d", arrays=True)
    dly = tr["params"]["joint1"]["delay_s"]
    assert 0.004 <= dly <= 0.02
    a = tr["arrays"]
    for k in range(nj):
        tw = a["tau_without_effect"][:, k]
        shifted = np.interp(a["t"] - dly, a["t"], tw)
        bracket = np.clip(np.searchsorted(a["t"], a["t"] - dly) - 1, 0, len(tw) - 2)
        # not across a Coulomb step (direction change) and after the first delay
        inner = (a["t"] > 0.05) & (np.abs(np.diff(tw))[bracket] < 0.05)
        assert inner.mean() > 0.95
        assert np.abs(a["tau"][inner, k] - shifted[inner]).max() < 2e-3, k
