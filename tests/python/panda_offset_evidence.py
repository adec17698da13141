"""How much evidence the real Panda data (21 s) carry for a constant torque offset on joints 1
and 6 (docs/explain.md, "Why joints 1 and 6 stay above the published model").

On `naic explain`'s analysis instants (panda_gaz2019._instants: 0.201 s Savitzky–Golay window,
every 10th sample, direction changes left out) and its held-out scheme (2 s time blocks, block b
in fold b mod 10), the nominal friction sgn(q̇), q̇ and the nominal plus a constant are fitted
per fold by least squares. Of the out-of-fold residuals e_nom, e_off it prints: the gain; the
autocorrelation of the loss differential d = e_nom² − e_off² (which sets how long a bootstrap
block must be and how many independent observations the data hold); the block-bootstrap lower
bound of the gain at 1 − 0.05/84 (the test of `analysis::bootstrap`) for block lengths from one
filter window to one fold block; and a Diebold–Mariano t of mean(d) with a Newey–West variance.

    python tests/python/panda_offset_evidence.py      # needs NAIC_SHARED (the shared data)
"""
import os
import pathlib

import numpy as np

import panda_gaz2019 as P

ROOT = pathlib.Path(__file__).resolve().parents[2]
STEP = 0.01  # analysis step [s]
WINDOW = 0.201  # filter window [s]
M = 84  # candidates × targets of the Panda analysis
REPS = 20_000


def oof(x, y, fold):
    e = np.empty_like(y)
    for k in range(10):
        tr = fold != k
        th, *_ = np.linalg.lstsq(x[tr], y[tr], rcond=None)
        e[~tr] = y[~tr] - x[~tr] @ th
    return e


def blocks(eb, ea, fold, length):
    out, last, c = [], None, 0
    for i in range(len(eb)):
        if last != fold[i] or c >= length:
            out.append([0.0, 0.0])
            last, c = fold[i], 0
        c += 1
        out[-1][0] += eb[i] ** 2
        out[-1][1] += ea[i] ** 2
    return np.array(out)


def boot_lower(b, alpha, rng):
    idx = rng.integers(0, len(b), (REPS, len(b)))
    g = np.sort(1 - b[idx, 1].sum(1) / b[idx, 0].sum(1))
    return g[int(np.floor(alpha * REPS))]


def acf(x, lags):
    x = x - x.mean()
    v = x @ x
    return np.array([x[:len(x) - k] @ x[k:] / v for k in range(lags)])


def dm_t(d, bandwidth):
    dd = d - d.mean()
    lrv = dd @ dd / len(d)
    for lag in range(1, bandwidth + 1):
        lrv += 2 * (1 - lag / (bandwidth + 1)) * (dd[:-lag] @ dd[lag:]) / len(d)
    return d.mean() / np.sqrt(lrv / len(d))


def main():
    shared = pathlib.Path(os.environ.get("NAIC_SHARED", ROOT.parent / "shared"))
    vi, keep, r = P._instants(shared, ROOT / "urdf" / "panda.urdf", WINDOW)
    fold_all = (np.arange(len(vi)) * STEP // 2.0).astype(int) % 10
    rng = np.random.default_rng(1)
    win = WINDOW / STEP
    for j in (0, 5):
        k = keep[:, j]
        v, y, fold = vi[k, j], r[k, j], fold_all[k]
        e_nom = oof(np.column_stack([np.sign(v), v]), y, fold)
        e_off = oof(np.column_stack([np.sign(v), v, np.ones_like(v)]), y, fold)
        d = e_nom ** 2 - e_off ** 2
        ac = acf(d, 400)
        zero = int(np.argmax(ac < 0))
        tau = 1 + 2 * ac[1:zero].sum()
        print(f"joint {j + 1}: {len(y)} instants, held-out RMSE {np.sqrt(np.mean(e_nom ** 2)):.3f} -> "
              f"{np.sqrt(np.mean(e_off ** 2)):.3f} N·m, gain {1 - (e_off ** 2).sum() / (e_nom ** 2).sum():.3f}")
        print(f"  autocorrelation of d: {ac[int(win)]:.2f} at one window, first below 0 at {zero * STEP:.2f} s "
              f"({zero / win:.1f} windows); integrated time {tau * STEP:.2f} s -> {len(y) / tau:.0f} independent observations")
        for w in (1, 2, 4, 8, 10):
            length = int(np.ceil(w * win))
            b = blocks(e_nom, e_off, fold, length)
            print(f"  blocks of {w:2d} windows ({length * STEP:.2f} s, {len(b)} blocks): bootstrap bound at 1 - 0.05/{M} "
                  f"{boot_lower(b, 0.05 / M, rng):+.3f}")
        for w in (1, 4, 10):
            print(f"  Diebold-Mariano t, Newey-West bandwidth {w} windows: {dm_t(d, int(round(w * win))):.2f}")


if __name__ == "__main__":
    main()
