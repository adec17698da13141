"""Bad files and arguments (issue 7, item 5): the `naic` binary and the node binaries are
run with malformed URDF, ROS 2 params YAML, friction YAML, CSV and flags. Each must exit
with code 2 and one message naming the thing that is wrong, never panic and never start
the DDS loop on bad input. (Cases already covered in test_ros_nodes.py, test_friction.py
and test_dynamics_vs_pinocchio.py are not repeated.)
"""
import os
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

URDF_BROKEN = {
    "not_xml.urdf": ("this is { not xml", ["not_xml.urdf"]),
    "truncated.urdf": ('<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="revolute">', ["truncated.urdf"]),
    "bad_number.urdf": ('<robot name="r"><link name="a"/><link name="b"><inertial><mass value="heavy"/>'
                        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
                        '<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
                        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>', ["bad_number.urdf"]),
    "one_joint.urdf": ('<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>'
                    '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
                    '<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
                    '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>', ["6"]),
}

FRICTION_BROKEN = {
    "not_yaml.yaml": ("joints: [unclosed", ["not_yaml.yaml"]),
    "negative.yaml": ("source: test\njoints:\n" + "".join(
        f"  - joint: {j}\n    model: stribeck_per_direction\n"
        f"    positive: {{f_a: {-1.0 if j == 3 else 1.0}, f_b: 2.0, q_s: 0.1, f_v: 1.0}}\n"
        f"    negative: {{f_a: 1.0, f_b: 2.0, q_s: 0.1, f_v: 1.0}}\n" for j in range(1, 7)), ["negative.yaml", "f_a"]),
    "missing_field.yaml": ("source: test\njoints:\n  - joint: 1\n    model: stribeck_per_direction\n"
                           "    positive: {f_a: 1.0, f_b: 2.0, q_s: 0.1}\n", ["missing_field.yaml", "f_v"]),
    "three_joints.yaml": ("source: test\njoints:\n" + "".join(
        f"  - joint: {j}\n    model: coulomb_viscous\n    f_c: 1.0\n    f_v: 1.0\n" for j in range(1, 4)),
        ["three_joints.yaml"]),
}


@pytest.fixture(scope="module")
def bins():
    return ru.build_nodes()


def _run(args, **kw):
    env = ru.ros_env(ru.fresh_domain(90))
    return subprocess.run([str(a) for a in args], cwd=ru.ROOT, capture_output=True, text=True, timeout=60, env=env, **kw)


def _assert_usage_error(p, needles, what):
    assert p.returncode == 2, f"{what}: exit {p.returncode}\nstdout: {p.stdout[-1000:]}\nstderr: {p.stderr[-2000:]}"
    assert "panicked" not in p.stderr, f"{what}: {p.stderr}"
    # One clear message line `<program>: error: ...` (the last one; a usage line may follow) names the problem.
    errs = [l for l in p.stderr.splitlines() if ": error: " in l]
    assert errs, f"{what}: no error line: {p.stderr}"
    last = errs[-1]
    for n in needles:
        assert n in last, f"{what}: {n!r} not in the error line: {last}\n{p.stderr}"


@pytest.mark.parametrize("node", ["naic_controller", "friction_compensation", "jk5_sim_driver"])
@pytest.mark.parametrize("fname", sorted(URDF_BROKEN))
def test_bad_urdf_given_to_a_node_exits_2_naming_the_file(bins, tmp_path, node, fname):
    text, needles = URDF_BROKEN[fname]
    f = tmp_path / fname
    f.write_text(text)
    p = _run([bins / node, "--ros-args", "-p", f"urdf:={f}"])
    _assert_usage_error(p, needles, f"{node} {fname}")


@pytest.mark.parametrize("node", ["naic_controller", "friction_compensation", "jk5_sim_driver"])
def test_missing_urdf_exits_2(bins, tmp_path, node):
    p = _run([bins / node, "--ros-args", "-p", f"urdf:={tmp_path / 'nope.urdf'}"])
    _assert_usage_error(p, ["nope.urdf"], node)


@pytest.mark.parametrize("node", ["friction_compensation", "jk5_sim_driver"])
@pytest.mark.parametrize("fname", sorted(FRICTION_BROKEN))
def test_bad_friction_yaml_given_to_the_node_exits_2_naming_it(bins, tmp_path, fname, node):
    text, needles = FRICTION_BROKEN[fname]
    f = tmp_path / fname
    f.write_text(text)
    p = _run([bins / node, "--ros-args", "-p", f"friction_file:={f}"])
    _assert_usage_error(p, needles, f"{node} {fname}")


@pytest.mark.parametrize("fname", sorted(FRICTION_BROKEN))
def test_bad_friction_yaml_given_to_naic_friction_eval_exits_2(bins, tmp_path, fname, shared):
    text, needles = FRICTION_BROKEN[fname]
    if fname == "three_joints.yaml":
        pytest.skip("a 3-joint model is valid for `naic friction eval`")
    f = tmp_path / fname
    f.write_text(text)
    data = sorted((shared / "data/jk5-friction").glob("*.csv"))[0]
    p = _run([bins / "naic", "friction", "eval", "--params", f, "--data", data])
    _assert_usage_error(p, needles, fname)


@pytest.mark.parametrize("content,needle", [
    ("", "empty"),
    ("joint,velocity,torque\n1,0.1,2\n", "velocity_rad_s"),
    ("joint,velocity_rad_s,torque_nm\n1,0.1\n", "line 2"),
    ("joint,velocity_rad_s,torque_nm\nx,0.1,2.0\n", "line 2"),
    ("joint,velocity_rad_s,torque_nm\n0,0.1,2.0\n", "line 2"),
    ("joint,velocity_rad_s,torque_nm\n1,0.1,inf\n", "line 2"),
    ("\x00\x01\x02binary\xff", "bad.csv"),
])
def test_bad_csv_exits_2_naming_the_line(bins, tmp_path, content, needle):
    f = tmp_path / "bad.csv"
    f.write_bytes(content.encode("utf-8", "surrogateescape") if isinstance(content, str) else content)
    p = _run([bins / "naic", "friction", "fit", "--data", f, "--out", tmp_path / "o.yaml"])
    _assert_usage_error(p, ["bad.csv", needle], repr(content))
    assert not (tmp_path / "o.yaml").exists()


@pytest.mark.parametrize("node", ru.NODES)
@pytest.mark.parametrize("yaml_text,needle", [
    ("{node}:\n  ros__parameters:\n\tbad: tab\n", "p.yaml"),
    ("{node}:\n  ros__parameters: [1, 2]\n", "ros__parameters"),
    ("{node}:\n  ros__parameters:\n    no_such_parameter: 1.0\n", "no_such_parameter"),
    ("/**:\n  ros__parameters:\n    use_sim_time: maybe\n", "use_sim_time"),
    ("- just\n- a list\n", "p.yaml"),
])
def test_bad_ros2_params_file_exits_2_naming_the_problem(bins, tmp_path, node, yaml_text, needle):
    f = tmp_path / "p.yaml"
    f.write_text(yaml_text.format(node=node))
    p = _run([bins / node, "--ros-args", "--params-file", f])
    _assert_usage_error(p, [needle], f"{node}: {yaml_text!r}")


@pytest.mark.parametrize("node", ru.NODES)
@pytest.mark.parametrize("args,needle", [
    (["--ros-args", "-p", "use_sim_time:=2"], "use_sim_time"),
    (["--ros-args", "-p", "novalue"], "novalue"),
    (["--ros-args", "-r"], "-r"),
    (["--ros-args", "-p", "rate:=nan"], "rate"),
])
def test_bad_node_flags_exit_2(bins, node, args, needle):
    if needle == "rate" and node != "jk5_sim_driver":
        args = ["--ros-args", "-p", "use_sim_time:=nan"]
        needle = "use_sim_time"
    p = _run([bins / node, *args])
    _assert_usage_error(p, [needle], f"{node} {args}")


@pytest.mark.parametrize("args,needle", [
    (["launch", "--params-dir", "/nonexistent_dir"], "/nonexistent_dir"),
    (["launch", "-p", "no_colon_here"], "no_colon_here"),
    (["launch", "-p", "no_such_node:rate:=1.0"], "no_such_node"),
    (["launch", "--duration", "-5"], "-5"),
    (["launch", "--duration=-5"], "duration"),
    (["launch", "--duration", "abc"], "abc"),
    (["bench", "dynamics", "--batches", "0"], "batches"),
    (["frobnicate"], "frobnicate"),
    (["friction", "fit"], "--data"),
])
def test_bad_naic_cli_flags_exit_2(bins, args, needle):
    p = _run([bins / "naic", *args])
    assert p.returncode == 2, (args, p.returncode, p.stderr[-2000:])
    assert needle in p.stderr and "panicked" not in p.stderr, (args, p.stderr)


def _jk5_without(tmp_path, frame):
    """urdf/jk5.urdf with the link `frame` renamed: a valid 6-joint URDF the nodes must refuse."""
    text = (ru.ROOT / "urdf/jk5.urdf").read_text()
    assert f'"{frame}"' in text
    f = tmp_path / f"jk5_without_{frame}.urdf"
    f.write_text(text.replace(f'"{frame}"', f'"{frame}_renamed"'))
    return f


# (node, parameter, how to make the bad file, words the error line must hold besides the file name)
BEFORE_DDS = [
    ("naic_controller", "urdf", lambda d: _write(d, "not_xml.urdf", "this is { not xml"), ["urdf:="]),
    ("naic_controller", "urdf", lambda d: _jk5_without(d, "tip"), ["'tip'", "urdf:="]),
    ("naic_controller", "urdf", lambda d: _jk5_without(d, "ft_sensor"), ["'ft_sensor'", "urdf:="]),
    ("naic_controller", "urdf", lambda d: _write(d, "one_joint.urdf", URDF_BROKEN["one_joint.urdf"][0]), ["6"]),
    ("naic_controller", "urdf", lambda d: d / "missing.urdf", ["urdf:="]),
    ("jk5_sim_driver", "urdf", lambda d: _write(d, "not_xml.urdf", "this is { not xml"), ["urdf:="]),
    ("jk5_sim_driver", "urdf", lambda d: _jk5_without(d, "tip"), ["'tip'"]),
    ("jk5_sim_driver", "urdf", lambda d: _jk5_without(d, "ft_sensor"), ["'ft_sensor'", "urdf:="]),
    ("jk5_sim_driver", "urdf", lambda d: d / "missing.urdf", ["urdf:="]),
    ("jk5_sim_driver", "friction_file", lambda d: _write(d, "bad.yaml", "joints: [unclosed"), ["friction_file:="]),
    ("friction_compensation", "urdf", lambda d: _write(d, "not_xml.urdf", "this is { not xml"), ["urdf:="]),
    ("friction_compensation", "friction_file", lambda d: _write(d, "bad.yaml", "joints: [unclosed"), ["friction_file:="]),
    ("friction_compensation", "friction_file", lambda d: d / "missing.yaml", ["friction_file:="]),
]


def _write(d, name, text):
    f = d / name
    f.write_text(text)
    return f


@pytest.mark.parametrize("node,param,make,needles", BEFORE_DDS,
                         ids=[f"{n}-{p}-{i}" for i, (n, p, _, _) in enumerate(BEFORE_DDS)])
def test_bad_file_is_refused_before_any_dds_participant_exists(bins, tmp_path, node, param, make, needles):
    """Issue 7: a node checks its files before it creates the DDS participant, so a bad file
    never shows up on the network (no half-started node, no parameter services, no
    /naic/params publisher). Exit 2 within a second, one error line naming the file and the
    fix; no 'started' line (the node logs it once its participant exists); and, where strace
    is installed, not one IP socket was opened (the participant opens several)."""
    import shutil
    import time
    f = make(tmp_path)
    args = [bins / node, "--ros-args", "-p", f"{param}:={f}"]
    t0 = time.monotonic()
    p = _run(args)
    elapsed = time.monotonic() - t0
    _assert_usage_error(p, [f.name, *needles], f"{node} {param}={f.name}")
    assert elapsed < 1.0, f"{node}: took {elapsed:.2f} s to refuse {f.name}"
    assert "started" not in p.stderr, p.stderr
    if shutil.which("strace"):
        trace = tmp_path / "strace.txt"
        q = _run(["strace", "-f", "-e", "trace=socket", "-o", trace, *args])
        assert q.returncode == 2, q.stderr[-2000:]
        inet = [l for l in trace.read_text().splitlines() if "AF_INET" in l]
        assert not inet, f"{node} opened IP sockets before refusing {f.name}: {inet[:3]}"


def test_strace_sees_the_participant_of_a_node_that_starts(bins, tmp_path):
    """The socket check above is not vacuous: the same trace of a node that does start shows
    its DDS participant's IP sockets."""
    import shutil
    if not shutil.which("strace"):
        pytest.skip("strace not installed")
    trace = tmp_path / "strace.txt"
    # `timeout` (traced too) runs the node for 3 s and stops it with SIGINT.
    p = _run(["strace", "-f", "-e", "trace=socket", "-o", trace, "timeout", "-s", "INT", "3",
              bins / "friction_compensation", "--ros-args", "--params-file", "params/friction_compensation.yaml"])
    assert p.returncode in (0, 124), p.stderr[-2000:]
    assert "AF_INET" in trace.read_text()
