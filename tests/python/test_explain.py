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


def _urdf_tool(urdf):
    """Mass and centre of mass (sensor frame) of the URDF's `ft_sensor` link, read from the XML."""
    import xml.etree.ElementTree as ET

    link = [l for l in ET.parse(urdf).getroot().findall("link") if l.get("name") == "ft_sensor"][0]
    inertial = link.find("inertial")
    xyz = [float(x) for x in inertial.find("origin").get("xyz").split()]
    return float(inertial.find("mass").get("value")), np.array(xyz)


def test_explain_contact_data_from_pinocchio(naic_bin, root, tmp_path):
    """Contact data synthesised independently with Pinocchio (forward kinematics of
    `ft_sensor` and `tip`, RNEA) and numpy: a free-space wrist motion, then pressing into a
    linear-spring surface of known height and stiffness, seen by a sensor with a known bias.
    `naic explain` must recover the surface height and stiffness (its nominal contact model)
    and name `ft_bias` with the bias of every axis, and find no contact effect that is not there."""
    import pinocchio as pin

    urdf = root / "urdf/jk5.urdf"
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    tip, ft = model.getFrameId("tip"), model.getFrameId("ft_sensor")
    m_tool, c_tool = _urdf_tool(urdf)
    g = np.array([0.0, 0.0, -9.81])
    rng = np.random.default_rng(3)

    q_c = np.radians([0.0, -30.0, 120.0, 0.0, -90.0, 0.0])
    pin.framesForwardKinematics(model, data, q_c)
    h = float(data.oMf[tip].translation[2])  # surface at the tip height of the pressing posture
    J = pin.computeFrameJacobian(model, data, q_c, tip, pin.LOCAL_WORLD_ALIGNED)[:3]
    n_q = np.linalg.pinv(J)[:, 2]  # joint motion per metre of tip height
    k_e, bias = 4000.0, np.array([0.5, -0.7, 0.8, 0.02, -0.015, 0.01])

    dt = 1e-3
    t = np.arange(0.0, 53.0, dt)
    dz = np.empty_like(t)
    w = np.zeros((len(t), 6))
    a = t < 20.0  # free space 0.15 m up, wrist sweeping (sin² envelope: starts and ends at rest)
    env = np.sin(np.pi * t[a] / 20.0) ** 2
    for j, (amp, f, ph) in {0: (0.15, 0.07, 0.0), 3: (0.35, 0.11, 1.0), 4: (0.35, 0.17, 2.0), 5: (0.35, 0.23, 0.5)}.items():
        w[a, j] = env * amp * np.sin(2 * np.pi * f * t[a] + ph)
    dz[a] = 0.15
    b = (t >= 20.0) & (t < 23.0)  # down to 10 mm above the surface
    dz[b] = 0.01 + 0.14 * (1 + np.cos(np.pi * (t[b] - 20.0) / 3.0)) / 2
    for (t0, t1, f) in [(23.0, 33.0, 0.2), (33.0, 43.0, 0.5), (43.0, 53.0, 1.0)]:  # presses to 5 mm deep
        c = (t >= t0) & (t < t1)
        dz[c] = 0.0025 + 0.0075 * np.cos(2 * np.pi * f * (t[c] - t0))
    q = q_c + w + dz[:, None] * n_q[None, :]
    v = np.gradient(q, dt, axis=0)
    acc = np.gradient(v, dt, axis=0)

    rows = []
    for i in range(len(t)):
        pin.framesForwardKinematics(model, data, q[i])
        R = data.oMf[ft].rotation
        p_ft, p_tip = data.oMf[ft].translation, data.oMf[tip].translation
        f_c = np.array([0.0, 0.0, max(0.0, k_e * (h - p_tip[2]))])  # environment on the tip, base frame
        f_s = R.T @ (m_tool * g + f_c)
        t_s = R.T @ (np.cross(R @ c_tool, m_tool * g) + np.cross(p_tip - p_ft, f_c))
        wrench = np.concatenate([f_s, t_s]) + bias + rng.normal(0.0, [0.03] * 3 + [0.001] * 3)
        Jt = pin.computeFrameJacobian(model, data, q[i], tip, pin.LOCAL_WORLD_ALIGNED)[:3]
        tau = pin.rnea(model, data, q[i], v[i], acc[i]) - Jt.T @ f_c + rng.normal(0.0, 0.02, 6)
        rows.append(np.concatenate([[t[i]], q[i], v[i], tau, wrench]))
    header = "t," + ",".join(f"{p}{j}" for p in ["q", "dq", "tau"] for j in range(1, 7)) + ",fx,fy,fz,mx,my,mz"
    csv = tmp_path / "contact.csv"
    np.savetxt(csv, np.array(rows), delimiter=",", header=header, comments="", fmt="%.10g")

    run(naic_bin, "--measured", csv, "--out", tmp_path / "out", "--urdf", urdf)
    r = json.loads((tmp_path / "out" / "report.json").read_text())
    # the extended model (nominal spring + the bias found) has the surface and stiffness;
    # the nominal alone shifts h by bias/k to absorb the unmodelled bias
    fz = r["contact_model"]["fz"]["extended"]
    assert fz["model"] == ["ft_bias"]
    assert fz["surface_height_m"] == pytest.approx(h, abs=2e-5)
    assert fz["k"] == pytest.approx(k_e, rel=0.02)
    assert r["contact_model"]["fz"]["nominal"]["surface_height_m"] == pytest.approx(h - bias[2] / k_e, abs=5e-5)
    found = {f["effect"]: f for f in r["findings"] if f["significant"]}
    assert "ft_bias" in found, found.keys()
    for k, axis in enumerate(["fx", "fy", "fz", "mx", "my", "mz"]):
        assert found["ft_bias"]["params"][axis]["bias"] == pytest.approx(bias[k], abs=0.03 if k < 3 else 0.002), axis
    for e in ["contact_nonlinearity", "contact_damping", "tool_gravity"]:
        assert e not in found, found[e]
    assert r["extended"]["heldout_rmse"]["fz"] < 0.2 * r["nominal"]["heldout_rmse"]["fz"]


def test_explain_generated_contact_data_cli(naic_bin, root, tmp_path):
    """`--generate --hide tool_gravity` writes contact data (wrench columns) and the analysis names it."""
    csv = tmp_path / "c.csv"
    out = subprocess.run([str(naic_bin), "explain", "--generate", csv, "--seed", "4", "--hide", "tool_gravity", "--urdf", root / "urdf/jk5.urdf"],
                         capture_output=True, text=True, check=True).stdout
    assert "hidden: tool_gravity on fx, fy, fz" in out
    assert open(csv).readline().strip().endswith("fx,fy,fz,mx,my,mz")
    run(naic_bin, "--measured", csv, "--out", tmp_path / "o", "--urdf", root / "urdf/jk5.urdf")
    r = json.loads((tmp_path / "o" / "report.json").read_text())
    first = [f for f in r["findings"] if f["significant"]][0]
    assert first["effect"] == "tool_gravity" and "fz" in first["targets"]
