"""`naic explain --bench` on a seven-joint arm (issue 14, its speed goal): the benchmark
generates data with the joint count of `--urdf` (urdf/panda.urdf: 7), finds the effects it
hid, and reports the numpy least-squares reference beside the RNEA one. Short data (one
excitation period); nothing here asserts a time."""
import json
import os
import subprocess
import sys

import numpy  # noqa: F401  (the reference needs it in this Python; fail loudly here if it is missing)
import pytest


def _bench(naic_bin, root, *extra, env=None):
    args = [str(naic_bin), "explain", "--bench", "--json", "--quiet", "--minutes", "1", *extra]
    r = subprocess.run(args, capture_output=True, text=True, cwd=root, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def _param(entries, joint, name):
    vals = [e["value"] for e in entries if e["joint"] == joint and e["param"] == name]
    assert len(vals) == 1, (entries, joint, name)
    return vals[0]


def test_bench_on_the_panda_has_seven_joints_and_finds_what_it_hid(naic_bin, root):
    env = dict(os.environ, NAIC_PYTHON=sys.executable)
    v = _bench(naic_bin, root, "--urdf", str(root / "urdf/panda.urdf"), "--tip", "flange", env=env)
    print(json.dumps({k: v[k] for k in ("joints", "samples", "analyse_s", "found", "hidden", "stages_s")}, indent=1))
    assert v["joints"] == 7
    # one excitation period of 7 joints: 7 × 4 speeds × 2 directions × 1.7 s + 20 s = 115.2 s at 1 kHz
    assert v["samples"] == 115200
    hidden = {h["effect"]: h for h in v["hidden"]}
    assert set(hidden) == {"friction_asymmetry", "torque_offset"}, v["hidden"]
    for name, key in (("friction_asymmetry", "f_c_difference"), ("torque_offset", "offset_nm")):
        h = hidden[name]
        assert h["found_on"] == h["joints"], h
        (j,) = h["joints"]
        truth, est = _param(h["truth"], j, key), _param(h["estimate"], j, key)
        assert abs(est - truth) <= 0.05 * abs(truth), (name, truth, est)
    # nothing else reads as significant on this clean data
    assert sorted(v["found"]) == sorted(hidden), v["found"]
    # the two references were measured in the same run
    assert v["reference_rnea_every_sample_s"] > 0 and v["ratio_analyse_to_reference"] > 0
    ref = v["numpy_reference"]
    assert ref["samples"] == v["samples"] and ref["joints"] == 7, ref
    assert ref["max_param_error"] < 0.05 and v["ratio_analyse_to_numpy_lstsq"] > 0, ref
    stages = [s["stage"] for s in v["stages_s"]]
    assert any(s.startswith("catalogue") for s in stages) and any(s.startswith("prepare") for s in stages), stages


def test_bench_says_why_the_numpy_reference_is_missing(naic_bin, root, tmp_path):
    """A Python that cannot run: the bench still reports, with the reason instead of the ratio."""
    env = dict(os.environ, NAIC_PYTHON=str(tmp_path / "no-such-python"))
    v = _bench(naic_bin, root, env=env)
    assert v["joints"] == 6 and "ratio_analyse_to_numpy_lstsq" not in v, v
    assert "cannot run" in v["numpy_reference_skipped"] and "NAIC_PYTHON" in v["numpy_reference_skipped"], v


def test_numpy_reference_without_numpy_prints_skipped(root, tmp_path):
    """The script itself, in a Python whose `import numpy` fails: one JSON line saying so, exit 0."""
    (tmp_path / "numpy.py").write_text("raise ImportError('numpy hidden by the test')\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    r = subprocess.run(
        [sys.executable, str(root / "bench/reference/explain_numpy_bench.py"), "--samples", "100000", "--joints", "7"],
        capture_output=True, text=True, env=env, timeout=120,
    )
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout.strip().splitlines()[-1])
    assert "numpy is not installed" in v["skipped"] and "NAIC_PYTHON" in v["skipped"], v


@pytest.mark.parametrize("urdf,tip", [("urdf/panda.urdf", "no_such_frame")])
def test_bench_refuses_a_wrong_tip_with_the_links_to_choose_from(naic_bin, root, urdf, tip):
    r = subprocess.run([str(naic_bin), "explain", "--bench", "--quiet", "--urdf", str(root / urdf), "--tip", tip],
                       capture_output=True, text=True, cwd=root, timeout=120)
    assert r.returncode != 0
    assert "no_such_frame" in r.stderr and "flange" in r.stderr, r.stderr
