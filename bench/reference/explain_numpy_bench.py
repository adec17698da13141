"""Reference for `naic explain --bench`: the core least-squares work an analysis of every
sample has to do, in numpy.

Per joint, an ordinary least-squares fit of viscous + Coulomb + offset friction,
tau = f_v*dq + f_c*sign(dq) + c, on as many samples as the benchmark data has
(`numpy.linalg.lstsq` on the N x 3 regressor). The data are synthetic (seeded, made before
timing): per joint a sum of two sines as the velocity, with known friction and white noise
on the torque. The timing covers building each joint's regressor from the velocity and
solving it, for all joints in turn. The fit must recover the friction it was made with,
so the timed work is real; the script fails otherwise.

Prints one JSON line: {"lstsq_s": median over --repeats, ...}. Without numpy it prints
{"skipped": "..."} and exits 0, so the caller can say why there is no ratio.

    python bench/reference/explain_numpy_bench.py --samples 3657600 --joints 7
"""
import argparse
import json
import sys
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, required=True, help="samples per joint (1 kHz: 3 600 000 per hour)")
    ap.add_argument("--joints", type=int, required=True, help="number of joints")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=3, help="timed repeats; the median is reported")
    a = ap.parse_args()
    if a.samples < 20000 or a.joints < 1 or a.repeats < 1:
        # shorter, the slow velocity sines hardly change sign and the fit is ill-posed
        ap.error("--samples must be >= 20000 (20 s at 1 kHz), --joints and --repeats >= 1")
    try:
        import numpy as np
    except ImportError as e:
        print(json.dumps({"skipped": f"numpy is not installed for {sys.executable} ({e}); set NAIC_PYTHON to a Python with numpy"}))
        return 0

    rng = np.random.default_rng(a.seed)
    t = np.arange(a.samples) * 1e-3
    dq, tau, truth = [], [], []
    for _ in range(a.joints):
        f1, f2 = rng.uniform(0.05, 0.15), rng.uniform(0.3, 0.5)
        v = 0.3 * np.sin(2 * np.pi * f1 * t + rng.uniform(0, 6.28)) + 0.1 * np.sin(2 * np.pi * f2 * t + rng.uniform(0, 6.28))
        p = np.array([rng.uniform(1.0, 5.0), rng.uniform(1.0, 6.0), rng.uniform(-0.8, 0.8)])  # f_v, f_c, offset
        dq.append(v)
        tau.append(p[0] * v + p[1] * np.sign(v) + p[2] + 0.05 * rng.standard_normal(a.samples))
        truth.append(p)
    del t

    times, fits = [], None
    for _ in range(a.repeats):
        t0 = time.perf_counter()
        out = []
        for j in range(a.joints):
            A = np.column_stack((dq[j], np.sign(dq[j]), np.ones(a.samples)))
            x, *_ = np.linalg.lstsq(A, tau[j], rcond=None)
            out.append(x)
        times.append(time.perf_counter() - t0)
        fits = out
    err = max(float(np.max(np.abs(x - p))) for x, p in zip(fits, truth))
    tol = 0.01 + 2.0 / np.sqrt(a.samples)  # the noise's effect on the estimate is ~0.05/sqrt(N)
    if not err < tol:
        print(f"explain_numpy_bench: the fit did not recover the friction it was made with (max error {err:.3g} > {tol:.3g})", file=sys.stderr)
        return 1
    print(json.dumps({
        "lstsq_s": sorted(times)[len(times) // 2],
        "repeats_s": times,
        "samples": a.samples,
        "joints": a.joints,
        "max_param_error": err,
        "numpy": np.__version__,
        "what": "per joint: numpy.linalg.lstsq of tau on [dq, sign(dq), 1] (N x 3), regressor built in the timing",
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
