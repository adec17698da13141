"""What the paper's 5-sample velocity median costs at one and two cycles of loop delay, as
quoted in docs/notes/2026-12-dds-test-forensics.md, "The second cycle of delay", and docs/controller.md, "The
baselines' velocity filter".

In process (default): `naic sim --scenario flat --delay-cycles D --median-window W` for
each law, seed 1; per run joint 2's command range in free space (0.5-0.6 s), the cycles at
its +-100 N m limit and the largest |dq4| of the plant.

    python3 docs/figures/controllers/median_window.py [--naic target/release/naic]

Real time (`--realtime`): `naic launch` on flat for AIC and NAIC with the window set in
both nodes, recorded with `naic record`; per run the force metrics of realtime_flat.py and
the command changes above 5 N m per joint over 4-9 s. Needs a quiet machine to compare
runs; keeps DDS on this machine.

    python3 docs/figures/controllers/median_window.py --realtime [--runs 2]
"""
import argparse
import csv
import os
import pathlib
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(HERE))
import realtime_flat  # noqa: E402


def in_process(naic, out):
    print("| law | window | d | free-space tau2 [N m] | cycles at +-100 N m | max |dq4| [rad/s] |")
    print("|---|---|---|---|---|---|")
    for law in ["fixed", "aic", "naic", "scheduled"]:
        for w in [5, 3, 1]:
            for d in [1, 2]:
                run = out / f"{law}-w{w}-d{d}"
                subprocess.run([naic, "sim", "--controller", law, "--scenario", "flat", "--delay-cycles", str(d),
                                "--median-window", str(w), "--out", str(run)], cwd=ROOT, check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                rows = list(csv.DictReader(open(run / f"{law}.truth.csv")))
                free = [float(r["tau2"]) for r in rows if 0.5 <= float(r["t"]) < 0.6]
                sat = sum(1 for r in rows if abs(float(r["tau2"])) >= 99.9)
                dq4 = max(abs(float(r["dq4"])) for r in rows)
                print(f"| {law} | {w} | {d} | {min(free):.1f} .. {max(free):.1f} | {sat} of {len(rows)} | {dq4:.2f} |")


def command_steps(path, lo=4.0, hi=9.0, step=5.0):
    rows = list(csv.DictReader(open(path)))
    t0 = int(rows[0]["log_time_ns"])
    seg = [r for r in rows if lo * 1e9 <= int(r["log_time_ns"]) - t0 <= hi * 1e9]
    out = []
    for j in range(6):
        x = [float(r[f"data_{j}"]) for r in seg]
        out.append(sum(1 for a, b in zip(x, x[1:]) if abs(b - a) > step))
    return out


def realtime(naic, out, runs):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env.setdefault("ROS_DOMAIN_ID", "91")
    for k in range(1, runs + 1):
        for law in ["aic", "naic"]:
            for w in [5, 1]:
                run = out / f"{law}-w{w}-{k}"
                run.mkdir(parents=True)
                rec = subprocess.Popen([naic, "record", "--topics", "/naic/params", "/joint_effort_cmd", "--out",
                                        str(run / "run.mcap"), "--duration", "13"], cwd=ROOT, env=env,
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                time.sleep(1.5)
                subprocess.run([naic, "launch", "--duration", "10", "-p", f"naic_controller:mode:={law}",
                                "-p", f"naic_controller:median_window:={w}",
                                "-p", f"friction_compensation:median_window:={w}"],
                               cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
                if rec.wait() != 0:
                    sys.exit(f"naic record failed for {run}")
                subprocess.run([naic, "bag", "export-csv", str(run / "run.mcap"), "--out", str(run / "csv")],
                               cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL)
                m = realtime_flat.metrics(str(run / "csv" / "naic_params.csv"))
                steps = command_steps(run / "csv" / "joint_effort_cmd.csv")
                keep = ["overshoot_pct", "settle_5pct_s", "error_last_2s_sd_n", "rms_n", "peak_n"]
                print(f"{law} window {w} run {k}:", {key: m.get(key) for key in keep},
                      "command changes > 5 N m in 4-9 s per joint:", steps,
                      "load", open("/proc/loadavg").read().split()[0])


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--naic", default=str(ROOT / "target/release/naic"), help="the naic binary")
    ap.add_argument("--realtime", action="store_true", help="real-time naic launch runs instead of in process")
    ap.add_argument("--runs", type=int, default=2, help="real time: runs per law and window")
    ap.add_argument("--out", help="folder for the runs (default: a temporary one)")
    a = ap.parse_args()
    if not pathlib.Path(a.naic).is_file():
        sys.exit(f"no naic binary at {a.naic}: build it (cargo build --release) or pass --naic")
    out = pathlib.Path(a.out) if a.out else pathlib.Path(tempfile.mkdtemp(prefix="median_window_"))
    if a.realtime:
        realtime(a.naic, out, a.runs)
    else:
        in_process(a.naic, out)
