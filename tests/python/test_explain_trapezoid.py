"""`naic explain` on the third generator (tests/python/explain_gen/trapezoid.py, issue 38):
trapezoidal joint moves whose acceleration steps at every corner, 2²⁰-count encoders, eq. 5
friction with the exact sign, `--nominal` with the exact friction shape.

Goals (issue 38): clean data gives no significant finding in ≥ 19 of 20 seeds at 100 Hz, 1 kHz
and 2 kHz; each single hidden effect is named first, on its joint, with its parameters within
`check.TOLERANCE`, in ≥ 19 of 20 seeds.

Default run: 20 clean seeds at 1 kHz (half of them with the torque's q̈ taken as a backward
difference of q̇, the issue's clean-data `delay` case), 4 at 100 Hz and 2 kHz, and 2 seeds per
hidden effect (≈ 3 min on a 2-core VM). `NAIC_EXPLAIN_FULL=1`: 20 seeds everywhere.
`NAIC_EXPLAIN_SWEEP_LOG=FILE` appends the per-seed results as JSON lines.
"""
import json
import os
import subprocess

import pytest

from explain_gen import check
from explain_gen import trapezoid as trap

FULL = os.environ.get("NAIC_EXPLAIN_FULL") == "1"
LOG = os.environ.get("NAIC_EXPLAIN_SWEEP_LOG")


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
        case = trap.TrapCase(effect=None, rate_hz=rate, seed=seed, accel="backward" if seed % 2 else "exact",
                             velocity="difference" if seed % 4 >= 2 else "noisy")
        report, _ = _run(naic_bin, case, tmp_path / f"s{seed}")
        found = [(f["effect"], f["targets"], round(f["gain"], 4)) for f in check.significant(report)]
        results.append({"seed": seed, "accel": case.accel, "ok": not found, "findings": found})
    _log(f"trapezoid-clean-{rate:g}Hz", results)
    bad = [r for r in results if not r["ok"]]
    assert len(bad) <= n // 20, f"clean trapezoid data at {rate:g} Hz gave a finding in {len(bad)} of {n} seeds: {bad}"


@pytest.mark.parametrize("effect", trap.EFFECTS)
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
    assert len(bad) <= n // 20, f"{effect}: {n - len(bad)} of {n} seeds passed: {bad}"
