"""`naic explain` against an independent MCAP writer (mcap-ros2-support): a bag written by
the reference Python library gives the same findings as the same data in CSV; bad input
exits with code 2 and names the problem."""
import json
import subprocess

import numpy as np
import pytest

JOINT_STATE_DEF = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def run(naic_bin, *args, check=True):
    return subprocess.run([str(naic_bin), "explain", "--quiet", *map(str, args)], capture_output=True, text=True, check=check)


def test_explain_reads_reference_mcap_like_csv(naic_bin, root, tmp_path):
    from mcap_ros2.writer import Writer

    csv = tmp_path / "data.csv"
    out = subprocess.run([str(naic_bin), "explain", "--generate", csv, "--seed", "11", "--hide", "torque_offset", "--urdf", root / "urdf/jk5.urdf"],
                         capture_output=True, text=True, check=True).stdout
    assert "hidden: torque_offset" in out
    d = np.genfromtxt(csv, delimiter=",", names=True)
    bag = tmp_path / "data.mcap"
    t0 = 1_700_000_000_000_000_000
    with open(bag, "wb") as f:
        w = Writer(f)
        schema = w.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE_DEF)
        for row in d:
            ns = t0 + int(round(row["t"] * 1e9))
            msg = {
                "header": {"stamp": {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}, "frame_id": ""},
                "name": [f"joint{j}" for j in range(1, 7)],
                "position": [float(row[f"q{j}"]) for j in range(1, 7)],
                "velocity": [float(row[f"dq{j}"]) for j in range(1, 7)],
                "effort": [float(row[f"tau{j}"]) for j in range(1, 7)],
            }
            w.write_message(topic="/joint_states", schema=schema, message=msg, log_time=ns + 150_000, publish_time=ns)
        w.finish()
    for src, name in [(csv, "csv"), (bag, "bag")]:
        run(naic_bin, "--measured", src, "--out", tmp_path / name, "--urdf", root / "urdf/jk5.urdf")
    rc = json.loads((tmp_path / "csv" / "report.json").read_text())
    rb = json.loads((tmp_path / "bag" / "report.json").read_text())
    assert rb["data"]["kind"] == "bag" and rc["data"]["kind"] == "timeseries"
    assert rb["data"]["samples"] == rc["data"]["samples"] == len(d)
    fc, fb = rc["findings"][0], rb["findings"][0]
    assert fc["effect"] == fb["effect"] == "torque_offset" and fc["significant"] and fb["significant"]
    assert fc["targets"] == fb["targets"]
    j = fc["targets"][0]
    # bag stamps are whole nanoseconds, so a sample on a 2 s block boundary can land in the
    # neighbouring held-out block: equal to 1e-3, not bit for bit
    assert fb["params"][j]["offset_nm"] == pytest.approx(fc["params"][j]["offset_nm"], rel=1e-3)
    for k, v in rc["extended"]["heldout_rmse"].items():
        assert rb["extended"]["heldout_rmse"][k] == pytest.approx(v, rel=1e-3)


def test_explain_bad_input_exit_code_and_message(naic_bin, root, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,q1,q2\n0,1,2\n")
    r = run(naic_bin, "--measured", bad, "--out", tmp_path / "o", "--urdf", root / "urdf/jk5.urdf", check=False)
    assert r.returncode == 2
    assert "missing column `dq1`" in r.stderr and "t,q1..q6,dq1..dq6,tau1..tau6" in r.stderr
    r = run(naic_bin, "--measured", bad, check=False)
    assert r.returncode == 2 and "--out" in r.stderr
