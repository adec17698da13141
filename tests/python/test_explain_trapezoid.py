"""`naic explain` on the third generator (tests/python/explain_gen/trapezoid.py, issue 38):
trapezoidal joint moves whose acceleration steps at every corner, 2²⁰-count encoders, eq. 5
friction with the exact sign, `--nominal` with the exact friction shape.

Goals (issue 38): clean data gives no significant finding in ≥ 19 of 20 seeds at 100 Hz, 1 kHz
and 2 kHz; each single hidden effect is named first, on its joint, with its parameters within
`check.TOLERANCE`, in ≥ 19 of 20 seeds.

Default run: 20 clean seeds at 1 kHz, 4 at 100 Hz and 2 kHz, 2 seeds of the issue's clean-data
`delay` case (the torque's q̈ a backward difference of q̇: a real half-sample lag, reported and
flagged as shorter than a sample), and 2 seeds per hidden effect (≈ 3 min on a 2-core VM).
`NAIC_EXPLAIN_FULL=1`: 20 seeds everywhere.
`NAIC_EXPLAIN_SWEEP_LOG=FILE` appends the per-seed results as JSON lines.
"""
import json
import os
import subprocess

import numpy as np

import pytest

from explain_gen import check
from explain_gen import trapezoid as trap

FULL = os.environ.get("NAIC_EXPLAIN_FULL") == "1"
LOG = os.environ.get("NAIC_EXPLAIN_SWEEP_LOG")


class GoalNotMet(AssertionError):
    """`naic explain` missed the issue's goal on a valid case (precondition met)."""


# Effects that miss the goal on this generator: effect -> the measured numbers. Marked
# xfail(strict=True, raises=GoalNotMet): an unexpected pass fails the run (remove the entry).
KNOWN_FAILS = {}
# (`torque_offset` was a miss over 20 seeds until issue 38's second session: every offset on
# joint 2 was named `inertial_parameters`; now the simpler candidate is kept unless the richer beats
# it by the test, and the pair is named confounded: seeds 0-5 and 6-25 all pass, docs/explain.md.)


def _run(naic_bin, case, work, arrays=False):
    csv, nominal, urdf, truth = trap.generate(case, work, arrays=arrays)
    args = [str(naic_bin), "explain", "--quiet", "--measured", str(csv), "--nominal", str(nominal), "--urdf", str(urdf),
            "--out", str(work / "out")]
    if check.OPT_IN:  # the catalogue's opt-in entries, as every case of test_explain_independent
        args += ["--effects", check.OPT_IN]
    r = subprocess.run(args, capture_output=True, text=True)
    assert r.returncode == 0, f"naic explain failed on {case.label()}:\n{r.stderr[-2000:]}"
    csv.unlink()
    return json.loads((work / "out" / "report.json").read_text()), truth


def _log(cid, results):
    if LOG:
        with open(LOG, "a") as f:
            f.write(json.dumps({"case": cid, "n": len(results), "n_ok": sum(r["ok"] for r in results), "results": results},
                               default=float) + "\n")


@pytest.mark.parametrize("rate", [1000.0, 100.0, 2000.0])
def test_trapezoid_clean_data_gives_no_finding(naic_bin, tmp_path, rate):
    """No significant finding on clean data in ≥ 19 of 20 seeds (≤ 5 % of the seeds run)."""
    n = 20 if (FULL or rate == 1000.0) else 4
    results = []
    for seed in range(n):
        case = trap.TrapCase(effect=None, rate_hz=rate, seed=seed, velocity="difference" if seed % 2 else "noisy")
        report, _ = _run(naic_bin, case, tmp_path / f"s{seed}")
        found = [(f["effect"], f["targets"], round(f["gain"], 4)) for f in check.significant(report)]
        results.append({"seed": seed, "accel": case.accel, "ok": not found, "findings": found})
    _log(f"trapezoid-clean-{rate:g}Hz", results)
    bad = [r for r in results if not r["ok"]]
    if len(bad) > n // 20:
        raise GoalNotMet(f"clean trapezoid data at {rate:g} Hz gave a finding in {len(bad)} of {n} seeds: {bad}")


@pytest.mark.parametrize("rate", [1000.0, 100.0])
def test_backward_difference_lag_is_a_sub_sample_delay(naic_bin, tmp_path, rate):
    """The issue's clean-data `delay`: a producer that takes q̈ as (q̇_k − q̇_{k−1})/dt puts a real
    half-sample lag into the torque's inertia part. `naic explain` names it `delay` at about 0.6
    of a sample period (0.57–0.83 at 1 kHz, 0.59–0.66 at 100 Hz measured) and flags it as shorter
    than one sample period, the data's own sampling convention (`sub_sample_delay`); with the
    exact q̈ the same data give nothing (test above)."""
    n = 20 if FULL else 2
    for seed in range(n):
        case = trap.TrapCase(effect=None, rate_hz=rate, seed=seed, accel="backward")
        report, _ = _run(naic_bin, case, tmp_path / f"s{seed}")
        sig = check.significant(report)
        assert [f["effect"] for f in sig][:1] == ["delay"], [(f["effect"], f["targets"]) for f in sig]
        d = np.median([p["delay_s"] for p in sig[0]["params"].values()]) * rate
        assert 0.4 < d < 1.0, f"seed {seed}: delay {d:.3f} samples"
        assert sig[0]["sub_sample_delay"] and "shorter than one sample period" in sig[0]["evidence"], sig[0]


@pytest.mark.parametrize("effect", [
    pytest.param(e, marks=[pytest.mark.xfail(strict=True, raises=GoalNotMet, reason=KNOWN_FAILS[e])] if e in KNOWN_FAILS else [])
    for e in trap.EFFECTS])
def test_trapezoid_hidden_effect_is_named_first(naic_bin, tmp_path, effect):
    """The hidden effect first, on its joint, parameters within tolerance, in ≥ 19 of 20 seeds
    (every seed of the default run's 2)."""
    n = 20 if FULL else 2
    results = []
    for seed in range(n):
        case = trap.TrapCase(effect=effect, seed=seed)
        report, truth = _run(naic_bin, case, tmp_path / f"s{seed}", arrays=effect == "inertial_parameters")
        need = max(0.02, truth["noise_after_smoother_nm"])
        seen = [truth["effect_rms_nm"][f"joint{j}"] for j in truth["joints"]]
        assert max(seen) >= need, f"generator precondition: {case.label()} effect RMS {seen} below {need}"
        r = check.score(report, truth)
        r.update(seed=seed, truth_params=truth["params"])
        results.append(r)
    _log(f"trapezoid-{effect}", results)
    bad = [(r["seed"], r["first"], r["param_err"], r["errors"]) for r in results if not r["ok"]]
    if len(bad) > n // 20:
        raise GoalNotMet(f"{effect}: {n - len(bad)} of {n} seeds passed: {bad}")


# Seeds of the matrix (`explain_gen.matrix`, seeds 6-25) whose 100 Hz delay (4.1-6.1 ms, under
# two thirds of the 10 ms sample) went unnamed while the rates of the model torque came from a fit
# three filter windows long (270 ms at 100 Hz, across the trapezoid's 50 ms acceleration phases).
SHORT_DELAY_SEEDS_100HZ = (18, 19, 20)


@pytest.mark.parametrize("seed", SHORT_DELAY_SEEDS_100HZ)
def test_trapezoid_sub_sample_delay_at_100hz_is_named(naic_bin, tmp_path, seed):
    """A hidden delay of half a 100 Hz sample on trapezoidal moves: `delay` first, its value
    within `check.TOLERANCE` (issue 38's goal at 100 Hz). The matrix' case, as it generates it."""
    case = trap.TrapCase(effect="delay", rate_hz=100.0, seed=seed, velocity="difference" if seed % 2 else "noisy")
    report, truth = _run(naic_bin, case, tmp_path / f"s{seed}")
    d = truth["params"]["joint1"]["delay_s"]
    assert 0.004 <= d < 0.0067, f"generator precondition: seed {seed} hides {d * 1e3:.2f} ms, not under 2/3 of a sample"
    r = check.score(report, truth)
    assert r["ok"], (seed, r["first"], r["param_err"], r["errors"])


def test_clean_report_says_no_effect_beyond_noise_with_the_noise_floor(naic_bin, tmp_path):
    """Issue 38's wording on clean data: the verdict "no effect beyond noise" (report.json, CLI)
    with each joint's noise floor, which must be the generator's torque noise after the
    analysis' filter: σ·√(Σc₀²) with c₀ scipy's Savitzky–Golay smoothing coefficients of the
    window the report names (quintic)."""
    import re

    from scipy.signal import savgol_coeffs

    case = trap.TrapCase(effect=None, rate_hz=1000.0, seed=0)
    csv, nominal, urdf, truth = trap.generate(case, tmp_path)
    out = tmp_path / "out"
    r = subprocess.run([str(naic_bin), "explain", "--measured", str(csv), "--nominal", str(nominal), "--urdf", str(urdf),
                        "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    rep = json.loads((out / "report.json").read_text())
    assert not check.significant(rep), [(f["effect"], f["targets"]) for f in check.significant(rep)]
    assert rep["verdict"] == "no effect beyond noise"
    assert "nothing significant: no effect beyond noise" in r.stdout, r.stdout
    m = re.search(r"window (\d+) samples", rep["method"]["velocity/acceleration"])
    assert m, rep["method"]
    c0 = savgol_coeffs(int(m.group(1)), 5)
    expect = truth["noise_sigma_nm"] * np.sqrt(np.sum(c0**2))
    floor = np.array(list(rep["noise_floor"].values()))
    assert len(floor) == 6 and np.all(np.abs(floor / expect - 1) < 0.1), (floor, expect)
    md = (out / "report.md").read_text()
    assert "no effect beyond noise" in md and "noise floor" in md
