"""Cross-check of `naic friction fit` against SciPy (an implementation no one here wrote).

* SciPy's bounded trust-region least squares (`least_squares(method="trf")`), started
  from 15 q_s values, must not find a lower sum of squares than naic's fit on the real
  JK5 data, for any joint and direction; where both reach the same optimum the parameters
  must agree to a small fraction of naic's 95 % interval.
* The 95 % intervals naic writes are recomputed here independently: finite-difference
  Jacobian at naic's parameters, σ²(JᵀJ)⁻¹ over the parameters not on a bound, and
  scipy.stats.t quantile.
* The CLI rejects bad input with exit code 2 and a message naming the problem.
"""
import os
import pathlib
import subprocess

import numpy as np
import pytest
import yaml
from scipy import stats
from scipy.optimize import least_squares

FILES = ["segment_means_gravity_included.csv", "segment_means_gravity_removed.csv"]
NAMES = ["f_a", "f_b", "q_s", "f_v"]
LOWER = np.array([0.0, 0.0, 1e-4, 0.0])
UPPER = np.array([np.inf, np.inf, 2.0, np.inf])


@pytest.fixture(scope="module")
def data_dir(root):
    for cand in [root.parent / "shared", pathlib.Path(os.environ.get("NAIC_SHARED", "/nonexistent"))]:
        d = cand / "data" / "jk5-friction"
        if d.is_dir():
            return d
    pytest.fail("jk5-friction data not found: expected ../shared/data/jk5-friction beside the repo (or set NAIC_SHARED)")


def model(th, v):
    f_a, f_b, q_s, f_v = th
    return np.sign(v) * (f_a + (f_b - f_a) * np.exp(-((v / q_s) ** 2))) + f_v * v


def scipy_best(v, t):
    best = None
    m = float(np.median(np.abs(t)))
    for q_s0 in np.geomspace(1e-4, 2.0, 15):
        r = least_squares(lambda th: model(th, v) - t, [m, m, q_s0, 0.0], bounds=(LOWER, UPPER), method="trf",
                          xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
        ssr = float(np.sum(r.fun ** 2))
        if best is None or ssr < best[0]:
            best = (ssr, r.x)
    return best


def run_fit(naic_bin, data, out, model_name="per-direction"):
    p = subprocess.run([str(naic_bin), "friction", "fit", "--data", str(data), "--model", model_name,
                        "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert f"wrote {out}" in p.stdout
    return yaml.safe_load(out.read_text())


@pytest.mark.parametrize("fname", FILES)
def test_per_direction_fit_matches_scipy_and_intervals(naic_bin, data_dir, tmp_path, fname):
    raw = np.loadtxt(data_dir / fname, delimiter=",", skiprows=1)
    fitted = run_fit(naic_bin, data_dir / fname, tmp_path / "fit.yaml")
    assert len(fitted["joints"]) == 6
    for jp in fitted["joints"]:
        j = jp["joint"]
        assert jp["model"] == "stribeck_per_direction"
        rows = raw[raw[:, 0] == j]
        for key, sel in (("positive", rows[:, 1] > 0), ("negative", rows[:, 1] < 0)):
            v, t = rows[sel, 1], rows[sel, 2]
            br = jp[key]
            th = np.array([br[n] for n in NAMES])
            ssr = float(np.sum((model(th, v) - t) ** 2))
            n = len(v)
            assert br["n_points"] == n
            assert br["rmse"] == pytest.approx(np.sqrt(ssr / n), rel=1e-9)
            s_ssr, s_th = scipy_best(v, t)
            # naic's optimum is at least as good as SciPy's best.
            assert ssr <= s_ssr * (1 + 1e-6) + 1e-12, (j, key, ssr, s_ssr, th, s_th)
            # Independent 95 % intervals at naic's parameters.
            free = [i for i, name in enumerate(NAMES) if br["ci95"][name] != "at bound"]
            assert len(free) == sum(1 for i in range(4) if not (th[i] <= LOWER[i] or th[i] >= UPPER[i]))
            jac = np.zeros((n, 4))
            for i in range(4):
                h = 1e-6 * max(abs(th[i]), 1e-3)
                tp, tm = th.copy(), th.copy()
                tp[i] += h
                tm[i] -= h
                jac[:, i] = (model(tp, v) - model(tm, v)) / (2 * h)
            jf = jac[:, free]
            dof = n - len(free)
            # pinv, not inv: with an unidentifiable parameter (f_b = f_a, q_s free) the
            # Fisher matrix is singular, and inv returns garbage (numpy 2.4 returned zeros
            # and 1e38 here); pinv equals inv where it is regular.
            cov = ssr / dof * np.linalg.pinv(jf.T @ jf)
            tq = stats.t.ppf(0.975, dof)
            for c, i in enumerate(free):
                ci = br["ci95"][NAMES[i]]
                if ci == "unidentifiable":
                    continue
                half = 0.5 * (ci[1] - ci[0])
                assert half == pytest.approx(tq * np.sqrt(cov[c, c]), rel=1e-3), (j, key, NAMES[i])
                if s_ssr <= ssr * (1 + 1e-6):
                    # Same optimum: parameters agree to a small fraction of the interval.
                    assert abs(s_th[i] - th[i]) <= 0.05 * half + 1e-9, (j, key, NAMES[i], th[i], s_th[i], half)


def test_symmetric_fit_not_worse_than_scipy(naic_bin, data_dir, tmp_path):
    raw = np.loadtxt(data_dir / FILES[1], delimiter=",", skiprows=1)
    fitted = run_fit(naic_bin, data_dir / FILES[1], tmp_path / "sym.yaml", "symmetric")
    for jp in fitted["joints"]:
        rows = raw[(raw[:, 0] == jp["joint"]) & (raw[:, 1] != 0)]
        v, t = rows[:, 1], rows[:, 2]
        th = np.array([jp[n] for n in NAMES])
        ssr = float(np.sum((model(th, v) - t) ** 2))
        s_ssr, _ = scipy_best(v, t)
        assert ssr <= s_ssr * (1 + 1e-6) + 1e-12, (jp["joint"], ssr, s_ssr)


def test_cli_rejects_bad_input(naic_bin, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("joint,velocity_rad_s,torque_nm\n1,0.1,2.0\n1,nan,2.0\n")
    p = subprocess.run([str(naic_bin), "friction", "fit", "--data", str(bad), "--out", str(tmp_path / "x.yaml")],
                       capture_output=True, text=True)
    assert p.returncode == 2
    assert "line 3, column `velocity_rad_s`" in p.stderr and "not finite" in p.stderr
    assert not (tmp_path / "x.yaml").exists()

    good = tmp_path / "good.csv"
    good.write_text("joint,velocity_rad_s,torque_nm\n" + "".join(f"1,{k/100},{1 + k/100}\n" for k in range(1, 20)))
    for args, want in [
        (["--model", "lugre"], "--model `lugre` is not a friction model"),
        (["--joints", "1,x"], "--joints: `x` is not a joint number"),
        (["--joints", "2"], "joint 2 is not in"),
        ([], "no samples with velocity < 0 (negative direction)"),
    ]:
        p = subprocess.run([str(naic_bin), "friction", "fit", "--data", str(good), "--out", str(tmp_path / "y.yaml"),
                            *args], capture_output=True, text=True)
        assert p.returncode == 2, (args, p.stderr)
        assert want in p.stderr, (args, p.stderr)
    p = subprocess.run([str(naic_bin), "friction", "fit", "--data", str(tmp_path / "missing.csv")],
                       capture_output=True, text=True)
    assert p.returncode == 2 and "missing.csv" in p.stderr
