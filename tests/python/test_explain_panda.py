"""`naic explain` on real measured data: the Franka Panda identification trajectory of
Gaz et al. 2019 (../shared/data/panda-gaz2019), urdf/panda.urdf (the published
identified inertials) as the nominal, no friction given. Asserts what the README's
"Result on the real Panda data" says."""
import json
import re
import subprocess

import numpy as np
import pytest

import panda_gaz2019 as P

WINDOW = 0.201


def _explain(naic_bin, root, csv, out, window=None):
    args = [str(naic_bin), "explain", "--quiet", "--measured", str(csv), "--urdf", str(root / "urdf/panda.urdf"), "--out", str(out)]
    if window is not None:
        args += ["--window", str(window)]
    r = subprocess.run(args, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return json.loads((out / "report.json").read_text())


def _extended(rep):
    return np.array([rep["extended"]["heldout_rmse"][f"joint{j}"] for j in range(1, 8)])


def test_panda_default_window_is_chosen_from_the_data(naic_bin, root, shared, tmp_path):
    """Without --window the filter window comes from the data (prepare::choose_window): on the
    Panda's jittery clock it must be long (the 51 ms of the generator data leaves q̈ dominated by
    noise), and the extended model must beat the published one on every joint it beats it on
    with --window 0.201."""
    csv = tmp_path / "panda.csv"
    P.write_csv(shared, csv)
    auto = _explain(naic_bin, root, csv, tmp_path / "auto")
    how = auto["method"]["filter window"]
    m = re.match(r"([0-9.]+) s chosen from the data", how)
    assert m, how
    chosen = float(m.group(1))
    print("window:", how)
    assert 0.15 <= chosen <= 0.3, how
    fixed = _extended(_explain(naic_bin, root, csv, tmp_path / "fixed", WINDOW))
    pub_fixed = P.published_rmse(shared, root / "urdf/panda.urdf", WINDOW)[0]
    ext = _extended(auto)
    pub = P.published_rmse(shared, root / "urdf/panda.urdf", chosen)[0]
    print("chosen", chosen, "extended", ext.round(3), "published", pub.round(3))
    beaten_fixed = set(np.flatnonzero(fixed <= pub_fixed))
    beaten = set(np.flatnonzero(ext <= pub))
    # all 7 (5 while issue 38's bootstrap test decided inertial_parameters per joint, not pooled)
    assert len(beaten_fixed) == 7 and beaten_fixed <= beaten, (ext, pub, fixed, pub_fixed)


def test_panda_baseline_beats_the_published_model_on_the_same_samples(naic_bin, root, shared, tmp_path):
    csv = tmp_path / "panda.csv"
    P.write_csv(shared, csv)
    rep = _explain(naic_bin, root, csv, tmp_path / "out", WINDOW)
    keys = [f"joint{j}" for j in range(1, 8)]
    method = rep["method"]
    assert "resampled" in method["sampling of " + str(csv)] and "flange" in method["robot model"]
    base = np.array([rep["baseline"]["joints"][k]["heldout_rmse"] for k in keys])
    urdf_only = np.array([rep["baseline"]["joints"][k]["urdf_rigid_body_rmse"] for k in keys])
    ext = np.array([rep["extended"]["heldout_rmse"][k] for k in keys])
    pub, rb, n = P.published_rmse(shared, root / "urdf/panda.urdf", WINDOW)
    print("published", pub.round(3), "baseline", base.round(3), "extended", ext.round(3))
    # our estimation of q, q̇, q̈ and the torque is reproduced independently (scipy +
    # Pinocchio): the URDF's rigid body alone gives the same residual on both sides
    assert np.all(np.abs(urdf_only - rb) < 0.03 * rb + 0.005), (urdf_only, rb)
    # the goal: held-out RMSE per joint at or below the published identified model
    # (rigid body + Supp. Table I friction) on the same samples — met by the baseline
    assert np.all(base <= pub), (base, pub)
    # the catalogue on top of the published inertials: the link inertials are the main
    # discrepancy (inertial_parameters first, on every joint); better than the published model
    # on every joint (README; before issue 14's second round joint 6 missed: 0.111 vs 0.091)
    sig = [f for f in rep["findings"] if f["significant"]]
    assert sig[0]["effect"] == "inertial_parameters" and "joint2" in sig[0]["targets"], [(f["effect"], f["targets"]) for f in sig]
    assert rep["inertial_parameters"]["significant"] and rep["inertial_parameters"]["folds_won"] == 10
    # below the published model on every joint: joints 1 and 6 only since `inertial_parameters`
    # is tested pooled over the joints (one correction of the whole arm; on its own 21 s a
    # joint's ≈ 26 blocks did not pass at 1 − 0.05/85, and joints 1 and 6 kept the nominal,
    # 0.281 / 0.111 N·m against the published 0.272 / 0.091)
    assert np.all(ext < pub), (ext, pub)
    # joint 2, the worst: close to the classical baseline (0.63 → 0.200 N·m, baseline 0.191:
    # 4.6 % above it; 5.3 % while inertial_parameters was fitted beside the first pass's rotor
    # inertias, 4.7 % before that). A regression guard, not the goal (ext < pub above).
    assert ext[1] < 1.1 * base[1], (ext, base)
    # 0.80 with the fold rule; 0.66 with the per-joint bootstrap test; 0.79 with the pooled one
    assert rep["explained"]["all_joints"] > 0.75
    # issue 38's wording: a finding below 5 % of every one of its joints' residual is "small",
    # with the share left; the others are not
    for f in sig:
        share = f["share_of_joint_residual"]
        assert set(share) == set(f["targets"]) and set(f["share_left"]) == set(f["targets"]), f
        small = all(x < 0.05 for x in share.values())
        assert f["small"] == small, (f["effect"], share, f["small"])
        assert ("(small:" in f["evidence"]) == small, f["evidence"]
    assert rep["verdict"] == "findings"
    # issue 38's significance test: every significant target has a block-bootstrap interval of
    # its held-out gain whose low end (a one-sided bound) is above zero: that is what made it
    # significant. Its level lies between Bonferroni's 1 − 2·0.05/m and the joint's share of the
    # family, 1 − 2·0.05·m_j/m (m_j ≤ 13 candidates on a joint): balanced over the joint's
    # candidates. The rigid-body correction's (the pooled test over all seven joints, the same
    # interval on each) is at Bonferroni's level and far from zero.
    for f in sig:
        m = f["comparisons"]
        bonferroni = 1 - 2 * 0.05 / m
        assert m >= 7 * 11 and abs(f["bonferroni_interval_level"] - bonferroni) < 1e-12, f
        assert set(f["gain_interval"]) == set(f["targets"]) == set(f["interval_level"]), f
        for lv in f["interval_level"].values():
            assert 1 - 2 * 0.05 * 13 / m <= lv <= bonferroni + 1e-12, f
        if f["pooled_test"]:
            assert all(abs(lv - bonferroni) < 1e-12 for lv in f["interval_level"].values()), f
        for lo, hi in f["gain_interval"].values():
            assert 0 < lo <= hi, f
    assert sig[0]["pooled_test"] and len(sig[0]["targets"]) == 7, sig[0]
    assert not any(f["pooled_test"] for f in sig[1:]), sig
    lo2 = sig[0]["gain_interval"]["joint2"][0]
    assert lo2 > 0.3, sig[0]["gain_interval"]


def test_panda_identified_friction_within_the_published_curve_and_its_scatter(naic_bin, root, shared, tmp_path):
    """Issue 14's second Panda goal: the identified friction within the published model's curve
    ± its scatter. Measured on the analysis instants: per joint the RMS of τ_f,identified(q̇) −
    τ_f,published(q̇) (Supp. Table I's sigmoid) against the published model's scatter there (the
    RMS of τ − RNEA − τ_f,published). Met in RMS on every joint, for the baseline (f_v, f_c, f_o)
    and for the extended model (its eq. 5 law + torque_offset); pointwise it is not: at low
    speeds the sigmoid (width 1/φ2 ≈ 0.06–0.2 rad/s) passes through 0 where a Coulomb law jumps
    to ±f_c, and the largest differences (0.15–0.6 N·m) exceed the scatter on joints 1, 4, 5, 7
    (README)."""
    csv = tmp_path / "panda.csv"
    P.write_csv(shared, csv)
    out = tmp_path / "out"
    rep = _explain(naic_bin, root, csv, out, WINDOW)
    urdf = root / "urdf/panda.urdf"
    for name, law in (("baseline", P.baseline_friction(rep)), ("extended", P.extended_friction(rep, out / "extended_params.yaml"))):
        rms_diff, max_diff, scatter = P.friction_vs_published(shared, urdf, WINDOW, law)
        print(name, "RMS difference", rms_diff.round(3), "largest", max_diff.round(3), "scatter", scatter.round(3))
        assert np.all(rms_diff <= scatter), (name, rms_diff, scatter)
        assert np.any(max_diff > scatter), (name, max_diff, scatter)



def test_panda_extended_below_published_on_every_joint(naic_bin, root, shared, tmp_path):
    """Issue 38's Panda goal: the extended model's held-out RMSE below the published model's on
    every joint (and no joint worse than 0.182 / 0.200 / 0.183 / 0.159 / 0.062 / 0.032 / 0.032)."""
    csv = tmp_path / "panda.csv"
    P.write_csv(shared, csv)
    ext = _extended(_explain(naic_bin, root, csv, tmp_path / "out", WINDOW))
    pub = P.published_rmse(shared, root / "urdf/panda.urdf", WINDOW)[0]
    before = np.array([0.182, 0.200, 0.183, 0.159, 0.062, 0.032, 0.032])
    print("extended", ext.round(4), "published", pub.round(4))
    assert np.all(ext < pub), f"extended {ext.round(3)} not below published {pub.round(3)} on every joint"
    assert np.all(ext <= before + 0.0005), f"extended {ext.round(4)} worse than issue 38's numbers {before} on a joint"
