"""Reads what observer_qos_pairs.sh wrote and prints, per variant (A: reliable observers,
B: best-effort observers, C / D: only `naic record` / only rclpy best effort), the driver's own wake-up report over the runs: wake-ups late by
more than 1 ms, runs of missed cycles, the latest wake-up. docs/notes/2026-12-dds-test-forensics.md, "Reliable
observers".

    python3 docs/figures/nodes/observer_qos.py OUT
"""
import glob
import json
import os
import re
import statistics
import sys


def report(run_dir):
    """The driver's last 'chain latency {...}' line of the run, or None."""
    try:
        log = open(os.path.join(run_dir, "log_jk5_sim_driver.txt")).read()
    except OSError:
        return None
    found = re.findall(r"chain latency (\{.*\})", log)
    return json.loads(found[-1]) if found else None


def main(out):
    variants = (("A", "reliable observers"), ("B", "best-effort observers"),
                ("C", "naic record best effort, rclpy reliable"), ("D", "rclpy best effort, naic record reliable"))
    found = 0
    for v, what in variants:
        runs = [r for d in sorted(glob.glob(os.path.join(out, f"{v}[0-9]*/"))) if (r := report(d))]
        if not runs:
            continue
        found += 1
        late = sorted(r["wakes_late_over_1ms"] for r in runs)
        eps = sorted(r["miss_episodes"] for r in runs)
        mx = sorted(round(r["wake_late_max_us"] / 1e3, 1) for r in runs)
        print(f"{v} ({what}), {len(runs)} runs")
        print(f"  wake-ups late > 1 ms: median {statistics.median(late)}, sorted {late}")
        print(f"  runs of missed cycles: median {statistics.median(eps)}, sorted {eps}")
        print(f"  latest wake-up [ms]: median {statistics.median(mx)}, sorted {mx}")
    if not found:
        sys.exit(f"no run with a driver report under {out}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: observer_qos.py OUT (written by observer_qos_pairs.sh OUT)")
    main(sys.argv[1])
