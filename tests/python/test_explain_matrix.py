"""Issue 38's matrix, CI subset: clean data from each of the three generators at 100 Hz, 1 kHz and
2 kHz, and every single hidden effect each generator can hide, one seed per cell (seed 6, the
first held-out seed; seeds 0–5 were the development set). The full matrix (20 seeds per cell,
the numbers in docs/explain.md) is

    python -m explain_gen.matrix --naic target/release/naic --seeds 6-25 --rates 1000,100,2000

(run from tests/python; ≈ 40 min on a 2-core machine). `NAIC_EXPLAIN_MATRIX_SEEDS=6-25` runs it
here as a test (the goal: ≤ 1 failing seed in 20 per cell).
"""
import os

import pytest

from explain_gen import matrix

SEEDS = matrix._parse_seeds(os.environ.get("NAIC_EXPLAIN_MATRIX_SEEDS", "6"))

# Cells whose full 20-seed run (seeds 6–25) misses the goal: (generator, effect) -> the measured
# numbers. Marked xfail(strict=True): an unexpected pass fails the run (remove the entry).
KNOWN_FAILS = {}

CELLS = [(g, e, r) for g, e, r in matrix.cells(matrix.GENERATORS, [None, *matrix.EFFECTS], [1000.0, 100.0, 2000.0])]


class GoalNotMet(AssertionError):
    pass


def _param(g, e, r):
    marks = []
    if (g, e or "clean") in KNOWN_FAILS:
        marks.append(pytest.mark.xfail(strict=True, raises=GoalNotMet, reason=KNOWN_FAILS[(g, e or "clean")]))
    return pytest.param(g, e, r, id=f"{g}-{e or 'clean'}-{r:g}Hz", marks=marks)


@pytest.mark.parametrize("generator,effect,rate", [_param(*c) for c in CELLS])
def test_matrix_cell(naic_bin, generator, effect, rate):
    """Clean data: no significant finding. A hidden effect: named first, on its joint, with
    its parameters within `check.TOLERANCE`. ≤ 1 failing seed in 20 (none in fewer)."""
    results = [matrix.run_one(naic_bin, generator, effect, rate, s) for s in SEEDS]
    bad = [(r["seed"], r.get("detail"), r.get("param_err"), r.get("errors")) for r in results if not r["ok"]]
    if len(bad) > len(SEEDS) // 20:
        raise GoalNotMet(f"{generator} {effect or 'clean'} {rate:g} Hz: {len(SEEDS) - len(bad)} of {len(SEEDS)} seeds passed: {bad}")


def test_significance_is_the_bootstrap_test(naic_bin):
    """The significance decision is the reported interval: every significant target's interval
    has its low end above zero, at level 1 − 2α/m (its low end the one-sided 1 − α/m bound),
    α = 5 % family-wise, m = the candidates × targets (≥ 6 joints × 11 candidates on the JK5)."""
    import json
    import pathlib
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        csv = pathlib.Path(tmp) / "d.csv"
        g = subprocess.run([str(naic_bin), "explain", "--generate", str(csv), "--seed", "6", "--hide", "torque_offset"],
                           capture_output=True, text=True, cwd=matrix.ROOT)
        assert g.returncode == 0, g.stderr
        out = pathlib.Path(tmp) / "out"
        r = subprocess.run([str(naic_bin), "explain", "--quiet", "--measured", str(csv), "--out", str(out)], capture_output=True,
                           text=True, cwd=matrix.ROOT)
        assert r.returncode == 0, r.stderr
        rep = json.loads((out / "report.json").read_text())
    sig = [f for f in rep["findings"] if f["significant"]]
    assert sig and sig[0]["effect"] == "torque_offset", [(f["effect"], f["targets"]) for f in sig]
    for f in sig:
        m = f["comparisons"]
        assert m >= 66 and f["family_wise_alpha"] == 0.05
        # per target: at or below Bonferroni's level, at or above the joint's share of the family
        assert abs(f["bonferroni_interval_level"] - (1 - 2 * 0.05 / m)) < 1e-12
        assert set(f["gain_interval"]) == set(f["targets"]) == set(f["interval_level"])
        for lv in f["interval_level"].values():
            assert 1 - 2 * 0.05 * 13 / m <= lv <= 1 - 2 * 0.05 / m + 1e-12, f
        for lo, hi in f["gain_interval"].values():
            assert 0 < lo <= hi, f
