#!/usr/bin/env python3
"""Write the real Franka Panda trajectory of Gaz et al. 2019 (../shared/data/panda-gaz2019)
as a `naic explain` CSV: t, q1..q7, dq1..dq7, tau1..tau7 (tau: the joint torque sensors).

    python3 tools/panda_gaz2019_csv.py [--data ../shared/data/panda-gaz2019] --out panda.csv

Python standard library only."""
import argparse
import pathlib
import sys



def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = pathlib.Path(__file__).resolve().parent.parent
    ap.add_argument("--data", type=pathlib.Path, default=here.parent / "shared/data/panda-gaz2019")
    ap.add_argument("--out", type=pathlib.Path, required=True)
    a = ap.parse_args()
    log = a.data / "rbt_log"
    names = ["time", "positions", "velocity", "torques"]
    missing = [n for n in names if not (log / f"exciting_traj_{n}.txt").is_file()]
    if missing:
        sys.exit(f"panda_gaz2019_csv: {log} lacks exciting_traj_{{{','.join(missing)}}}.txt: "
                 "give the data folder with --data (it holds rbt_log/)")
    def numbers(n):
        return (log / f"exciting_traj_{n}.txt").read_text().split()

    t = numbers("time")
    cols = [numbers(n) for n in names[1:]]
    if any(len(c) != 7 * len(t) for c in cols):
        sys.exit(f"panda_gaz2019_csv: {log}: {len(t)} time stamps but "
                 f"{[len(c) for c in cols]} values of q, dq, tau (want 7 per stamp)")
    hdr = "t," + ",".join([f"q{j}" for j in range(1, 8)] + [f"dq{j}" for j in range(1, 8)] + [f"tau{j}" for j in range(1, 8)])
    with open(a.out, "w") as f:
        f.write(hdr + "\n")
        for i, ti in enumerate(t):
            f.write(",".join([ti] + [v for c in cols for v in c[7 * i:7 * i + 7]]) + "\n")
    print(f"wrote {a.out}: {len(t)} samples, {float(t[-1]) - float(t[0]):.1f} s")


if __name__ == "__main__":
    main()
