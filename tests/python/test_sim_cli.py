"""`naic sim` and `naic bench sim` from the outside: output files and their
schema, and a clear message with exit code 2 for every input a user can get
wrong."""
import json
import subprocess

import pytest

PHASE_KEYS = {
    "t_start_s", "desired_force_n", "settling_time_2pct_s", "settling_time_5pct_s",
    "overshoot_pct", "steady_state_error_n", "rms_error_n", "max_force_n",
}


def run(naic_bin, *args, cwd=None):
    return subprocess.run([str(naic_bin), *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=600)


def test_sim_writes_metrics_csv_and_svg(naic_bin, root, tmp_path):
    out = tmp_path / "run"
    r = run(naic_bin, "sim", "--scenario", "flat", "--controller", "all", "--duration", "3.5", "--out", out, cwd=root)
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "metrics.json").read_text())
    assert m["scenario"] == "flat"
    assert set(m["controllers"]) == {"naic", "aic", "fixed", "scheduled"}
    for name, c in m["controllers"].items():
        assert set(c) == {"contact_time_s", "phases", "honest"}
        assert 0.5 < c["contact_time_s"] < 3.0
        # the honest metrics (docs/controller.md, "How runs are scored"), one entry per phase
        assert len(c["honest"]) == 2
        for h in c["honest"]:
            assert set(h) == {"band_n", "settling_band_s", "impact_n", "impact_bound_n", "overshoot_after_impact_pct"}
            assert h["band_n"] >= 0.02 * 10.0 - 1e-12
        # first contact and the 10 -> 20 N step at 3 s
        assert len(c["phases"]) == 2
        for ph in c["phases"]:
            assert set(ph) == PHASE_KEYS
        assert ph["t_start_s"] == pytest.approx(3.0)
        assert ph["desired_force_n"] == 20.0
        header = (out / f"{name}.truth.csv").read_text().splitlines()[0].split(",")
        assert (out / f"{name}.mcap").read_bytes()[:8] == b"\x89MCAP0\r\n"
        assert {"t", "f_ext", "f_d", "tip_z", "surface_z", "b_d", "ft_fz"} <= set(header)
    svg = (out / "flat.svg").read_text()
    assert svg.startswith("<svg") and "NAIC" in svg and "time [s]" in svg
    # the summary table is printed
    assert "| flat | naic |" in r.stdout


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--scenario", "moon"], "--scenario"),
        (["--controller", "pid"], "--controller"),
        (["--median-window", "0"], "--median-window"),
        (["--gamma", "-1"], "--gamma"),
        (["--duration", "0"], "--duration"),
        (["--urdf", "/nonexistent.urdf"], "--urdf"),
        (["--friction", "/nonexistent.yaml"], "--friction"),
        (["--replay", "/nonexistent.csv", "--q0", "0,0,0,0,0,0"], "--replay"),
        (["--table", "--scenario", "flat"], "--scenario"),
        (["--table", "--seeds", "0"], "--seeds"),
    ],
)
def test_bad_input_is_named_with_exit_code_2(naic_bin, root, tmp_path, args, needle):
    r = run(naic_bin, "sim", *args, "--out", tmp_path / "x", cwd=root)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert needle in r.stderr
    assert "panicked" not in r.stderr


def test_replay_input_errors(naic_bin, root, tmp_path):
    good = tmp_path / "tau.csv"
    good.write_text("tau1,tau2,tau3,tau4,tau5,tau6\n0,0,0,0,0,0\n")
    r = run(naic_bin, "sim", "--replay", good, "--out", tmp_path / "a", cwd=root)
    assert r.returncode == 2 and "--q0" in r.stderr
    r = run(naic_bin, "sim", "--replay", good, "--q0", "1,2,3", "--out", tmp_path / "a", cwd=root)
    assert r.returncode == 2 and "6" in r.stderr
    bad_cols = tmp_path / "cols.csv"
    bad_cols.write_text("a,b\n1,2\n")
    r = run(naic_bin, "sim", "--replay", bad_cols, "--q0", "0,0,0,0,0,0", "--out", tmp_path / "a", cwd=root)
    assert r.returncode == 2 and "tau1..tau6" in r.stderr
    nan = tmp_path / "nan.csv"
    nan.write_text("tau1,tau2,tau3,tau4,tau5,tau6\n0,0,0,0,0,0\n0,nan,0,0,0,0\n")
    r = run(naic_bin, "sim", "--replay", nan, "--q0", "0,0,0,0,0,0", "--out", tmp_path / "a", cwd=root)
    assert r.returncode == 2 and "line 3" in r.stderr and "tau2" in r.stderr
    r = run(naic_bin, "sim", "--replay", good, "--q0", "0,0,0,0,0,0", "--integrator", "leapfrog", "--out", tmp_path / "a", cwd=root)
    assert r.returncode == 2 and "--integrator" in r.stderr


def test_bench_sim_prints_steps_per_second(naic_bin, root):
    r = run(naic_bin, "bench", "sim", "--json", "--no-reference", "--steps", "200", "--repeats", "1", cwd=root)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["steps_per_s"] > 0 and d["plant_only_steps_per_s"] > 0
    assert d["in_contact_at_end"] is True


def test_seeds_write_a_summary_over_seeds(naic_bin, root, tmp_path):
    out = tmp_path / "multi"
    r = run(naic_bin, "sim", "--scenario", "flat", "--controller", "fixed", "--duration", "2.5", "--seeds", "2", "--seed", "4", "--out", out, cwd=root)
    assert r.returncode == 0, r.stderr
    md = (out / "summary.md").read_text()
    assert "seeds 4–5" in md and "| flat | fixed |" in md and "RMS of f_ext" in md
    a = json.loads((out / "seed-4" / "metrics.json").read_text())
    b = json.loads((out / "seed-5" / "metrics.json").read_text())
    assert a != b  # different noise realisations
    r = run(naic_bin, "sim", "--seeds", "0", "--out", tmp_path / "z", cwd=root)
    assert r.returncode == 2 and "--seeds" in r.stderr


def test_a_urdf_that_is_not_the_jk5_is_refused_cleanly(naic_bin, root, tmp_path):
    urdf = tmp_path / "one.urdf"
    urdf.write_text(
        '<robot name="one"><link name="base_link"/><link name="l1">'
        '<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="10" velocity="1"/></joint></robot>'
    )
    r = run(naic_bin, "sim", "--urdf", urdf, "--no-friction", "--out", tmp_path / "x", cwd=root)
    assert r.returncode == 2, r.stderr
    assert "--urdf" in r.stderr and "6-joint" in r.stderr
    assert "panicked" not in r.stderr


def test_sim_robot_panda_records_seven_named_joints_read_by_mcap_ros2(naic_bin, root, tmp_path):
    """`naic sim --robot params/robots/panda.yaml`: a 7-joint run whose bag an independent
    reader (mcap-ros2-support) decodes with the Panda's 7 joint names and 7 torques."""
    from mcap_ros2 import reader as mcap_ros2_reader

    out = tmp_path / "panda"
    r = run(naic_bin, "sim", "--robot", "params/robots/panda.yaml", "--scenario", "flat", "--controller", "scheduled",
            "--duration", "2.5", "--out", out, cwd=root)
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "metrics.json").read_text())["controllers"]["scheduled"]
    assert 0.5 < m["contact_time_s"] < 2.5
    assert m["phases"][0]["overshoot_pct"] <= 5.0
    names, efforts = set(), set()
    for msg in mcap_ros2_reader.read_ros2_messages(str(out / "scheduled.mcap"), topics=["/joint_states", "/joint_effort_cmd"]):
        if msg.channel.topic == "/joint_states":
            names.add(tuple(msg.ros_msg.name))
        else:
            efforts.add(len(msg.ros_msg.data))
    assert names == {tuple(f"joint{k}" for k in range(1, 8))}
    assert efforts == {7}
    header = (out / "scheduled.truth.csv").read_text().splitlines()[0].split(",")
    assert "q7" in header and "tau7" in header and "q8" not in header


@pytest.mark.parametrize(
    "body, needle",
    [
        ("urdf: {root}/urdf/panda.urdf\ntip_frame: flange\nsensor_frame: link7\n", "start_q"),
        ("urdf: {root}/urdf/panda.urdf\ntip_frame: nose\nsensor_frame: link7\n", "`tip_frame`"),
        ("urdf: {root}/urdf/jk5.urdf\ntip_frame: tip\nsensor_frame: ft_sensor\nstart_q: [0, 0, 0]\n", "`start_q`"),
    ],
)
def test_sim_bad_robot_file_is_named_with_exit_code_2(naic_bin, root, tmp_path, body, needle):
    f = tmp_path / "robot.yaml"
    f.write_text(body.replace("{root}", str(root)))
    r = run(naic_bin, "sim", "--robot", f, "--controller", "scheduled", "--duration", "0.5", "--out", tmp_path / "x", cwd=root)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert needle in r.stderr and str(f.name) in r.stderr
    assert "panicked" not in r.stderr


def test_held_out_on_the_panda_runs_every_group_without_two_material(naic_bin, root, tmp_path):
    """`naic sim --held-out --controller derived --robot params/robots/panda.yaml`: the held-out
    protocol on a 7-joint arm writes its goal counts for every group, scores every run, and
    leaves out two-material (placed for the JK5 only)."""
    out = tmp_path / "panda-held-out"
    r = run(naic_bin, "sim", "--held-out", "--controller", "derived", "--robot", "params/robots/panda.yaml", "--out", out, cwd=root)
    assert r.returncode == 0, r.stderr
    rows = json.loads((out / "held_out.json").read_text())
    groups = {x["group"] for x in rows}
    assert groups == {"seeds", "stiffness", "delay", "mass error", "60 s", "moving surface"}
    assert {x["controller"] for x in rows} == {"derived", "derived_oracle"}
    assert all(x["scenario"] != "two-material" for x in rows)
    # every run made contact and was scored: one honest entry per phase at least
    assert all(x["honest"] for x in rows), [x["scenario"] for x in rows if not x["honest"]]
    md = (out / "held_out.md").read_text()
    assert "panda.yaml" in md.split("\n")[0]
    for g in groups:
        assert f"| {g} | derived |" in md


def test_held_out_on_another_arm_refuses_the_mujoco_plant(naic_bin, root, tmp_path):
    r = run(naic_bin, "sim", "--held-out", "--robot", "params/robots/panda.yaml", "--plant", "mujoco", "--out", tmp_path / "x", cwd=root)
    assert r.returncode == 2, r.stderr
    # a build with MuJoCo names the robot file; one without refuses --plant mujoco at once
    assert "--plant" in r.stderr
    assert "panicked" not in r.stderr


def test_sim_robot_and_urdf_together_are_refused(naic_bin, root, tmp_path):
    r = run(naic_bin, "sim", "--robot", "params/robots/panda.yaml", "--urdf", "urdf/jk5.urdf", "--out", tmp_path / "x", cwd=root)
    assert r.returncode == 2 and "--urdf and --robot" in r.stderr
