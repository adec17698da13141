"""Reads what `NAIC_TAKEOVER_DUMP=DIR pytest tests/python/test_safety_process.py` wrote and
prints, per 0.5 s of the run: the gaps of more than 2 ms between the driver's states (it woke
up late), the states stamped within 0.3 ms of the one before (it ran missed cycles back to
back), each busy node thread's CPU ticks; then the loop's delay (how many states the
command applied at each state is behind the state it answers), outside the outages.
docs/notes/2026-12-dds-test-forensics.md, "The take-over failure, caught".

    python3 docs/figures/nodes/takeover_dump.py DIR
"""
import collections
import csv
import sys


def main(d):
    ev = eval(open(f"{d}/events.txt").read())  # noqa: S307 - the test's own repr of a dict
    js = sorted([list(map(float, r)) for r in csv.reader(open(f"{d}/js.csv"))])
    cm = [list(map(float, r)) for r in csv.reader(open(f"{d}/cmd.csv"))]
    t = [r[0] for r in js]
    t0 = t[0]
    print("events [s]:", {n: {k: round(v - t0, 3) for k, v in e.items() if isinstance(v, float)} for n, e in ev.items()})
    bins = range(int((t[-1] - t0) / 0.5) + 1)
    late, burst = collections.Counter(), collections.Counter()
    for a, c in zip(t, t[1:]):
        late[int((c - t0) / 0.5)] += c - a > 0.002
        burst[int((c - t0) / 0.5)] += c - a < 0.0003
    print("from [s]              " + " ".join(f"{b * 0.5:4.1f}" for b in bins))
    print("gaps > 2 ms           " + " ".join(f"{late[b]:4d}" for b in bins))
    print("back to back          " + " ".join(f"{burst[b]:4d}" for b in bins))
    last, use = {}, collections.defaultdict(collections.Counter)
    for row in csv.reader(open(f"{d}/threads.csv")):
        k = (row[1], row[3], row[4])
        if k in last:
            use[k][int((float(row[0]) - t0) / 0.5)] += int(row[5]) - last[k]
        last[k] = int(row[5])
    for k, c in sorted(use.items(), key=lambda kv: -sum(kv[1].values())):
        if sum(c.values()) >= 3:
            print(f"{k[0][:12]:12s} {k[2][:8]:8s} " + " ".join(f"{c[b]:4d}" for b in bins))
    out = [(e["kill"], e["restart"] + 0.5) for e in ev.values()]
    src = {tuple(round(x, 6) for x in c[2:8]): c[1] for c in cm}
    idx = {round(s, 6): i for i, s in enumerate(t)}
    delay = collections.Counter()
    for i, r in enumerate(js):
        if any(a <= r[0] <= b for a, b in out):
            continue
        s = src.get(tuple(round(x, 6) for x in r[13:19]))
        j = idx.get(round(s, 6)) if s is not None else None
        delay["unmatched" if j is None else min(i - j, 10)] += 1
    n = sum(delay.values())
    print("states the applied command answers, by how many states back (outside the outages):")
    print("  " + " ".join(f"{k}: {delay[k] / n * 100:.2f} %" for k in sorted(delay, key=str)))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: takeover_dump.py DIR (written by NAIC_TAKEOVER_DUMP=DIR pytest tests/python/test_safety_process.py)")
    main(sys.argv[1])
