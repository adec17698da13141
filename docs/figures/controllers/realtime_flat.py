"""Metrics of a real-time `naic launch` run on flat from its /naic/params CSV
(`naic bag export-csv`), as quoted in controller.md "Which controller to use", "On the real-time
DDS chain". The force is the controller's measured_force (the tared F/T estimate: no
topic carries the simulator's true force), so sensor noise and quantisation are in it.

    python3 realtime_flat.py DIR/naic_params.csv [more.csv ...]
"""
import csv
import math
import sys


class NoContact(Exception):
    pass


def metrics(path):
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        missing = {"stamp_s", "measured_force", "desired_force", "phase"} - set(reader.fieldnames or [])
        if missing:
            raise NoContact(f"no column(s) {sorted(missing)}: expected `naic bag export-csv` output of /naic/params")
        rows = list(reader)
    t = [float(r["stamp_s"]) for r in rows]
    f = [float(r["measured_force"]) for r in rows]
    fd = [float(r["desired_force"]) for r in rows]
    ph = [int(r["phase"]) for r in rows]
    # Contact: the first sample in the controller's contact phase at or above 1 N (the
    # paper's threshold), so that laws entering contact at another force (the scheduled
    # law's 0.5 N) are measured from the same point of the rise.
    ic = next((i for i, p in enumerate(ph) if p == 1 and f[i] >= 1.0), None)
    if ic is None:
        raise NoContact(
            f"no contact in {len(rows)} sample(s) (none in the contact phase at or above 1 N): "
            "was /naic/params recorded while `naic launch` ran from the repository root?"
        )
    f_d = fd[ic]

    def settle(tol, force=f):
        last = max((i for i in range(ic, len(force)) if abs(force[i] - fd[i]) > tol * abs(f_d)), default=None)
        return None if last is None or last + 1 >= len(force) else round(t[last + 1] - t[ic], 3)

    # The sensor's noise (1 sigma = one 1/16 N count) puts single samples outside +-2 % of
    # 10 N for the whole run, so settling is also given for the trailing 10-sample (10 ms)
    # mean, whose noise is a third of that.
    w = 10
    f_mean = [sum(f[max(0, i - w + 1):i + 1]) / (i + 1 - max(0, i - w + 1)) for i in range(len(f))]
    late = [i for i in range(ic, len(t)) if t[i] >= t[-1] - 2.0]
    late_err = [f[i] - fd[i] for i in late]
    late_mean = sum(late_err) / len(late_err)

    gaps = sum(1 for i in range(ic + 1, len(t)) if t[i] - t[i - 1] > 1.5e-3)
    return dict(
        file=path,
        samples=len(rows),
        contact_s=round(t[ic] - t[0], 3),
        overshoot_pct=round(100 * max(0.0, max(f[ic:]) - f_d) / f_d, 1),
        settle_2pct_s=settle(0.02),
        settle_5pct_s=settle(0.05),
        settle_2pct_10ms_mean_s=settle(0.02, f_mean),
        error_last_2s_mean_n=round(late_mean, 4),
        error_last_2s_sd_n=round(math.sqrt(sum((e - late_mean) ** 2 for e in late_err) / len(late_err)), 4),
        rms_n=round(math.sqrt(sum((f[i] - fd[i]) ** 2 for i in range(ic, len(f))) / (len(f) - ic)), 3),
        peak_n=round(max(f), 2),
        cycles_late_over_1p5ms=gaps,
    )


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    failed = 0
    for p in sys.argv[1:]:
        try:
            print(metrics(p))
        except (OSError, NoContact, ValueError) as e:
            print(f"realtime_flat.py: {p}: {e}", file=sys.stderr)
            failed += 1
    sys.exit(2 if failed else 0)
