"""examples/tool_poses.py and the live `naic tool identify` against the node chain (lockstep,
loopback only, issue 39 item 2): rclpy moves the tool through 8 orientations on
/naic/target_pose and waits for rest in each; the example identifies the tool from its bag
(`naic tool identify --bag`), and a live `naic tool identify` (no bag: /joint_states and
/wrench over DDS) started with the chain identifies it from the same motion. The simulated
sensor's tool is not the URDF's (the driver's `tool_mass_error`, `tool_com_offset`, as
`naic sim --tool-mass-error/--tool-com-offset`): 0.51 kg at (4, -3, 28) mm where the URDF,
which the controller keeps, says 0.424 kg at (0, 0, 15) mm. Both must find the true tool's
mass within 2 % and its centre of mass within 2 mm.
"""
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")
pytest.importorskip("pinocchio")


MASS_ERROR = 1.2028
COM_OFFSET = [0.004, -0.003, 0.013]


def _true_tool():
    link = ET.parse(ru.ROOT / "urdf/jk5.urdf").getroot().find("link[@name='ft_sensor']/inertial")
    mass = float(link.find("mass").get("value"))
    com = [float(x) for x in link.find("origin").get("xyz").split()]
    return mass * MASS_ERROR, [c + o for c, o in zip(com, COM_OFFSET)]


def _fit(text):
    val = lambda k: float(re.search(rf"^{k}\s+(-?[0-9.]+)", text, re.M).group(1))  # noqa: E731
    return val("mass"), [val(f"com {a}") * 1e-3 for a in "xyz"]


def test_example_tool_poses_and_the_live_identification_find_the_tool(tmp_path):
    bins = ru.build_nodes()
    domain = ru.fresh_domain(75)
    env = ru.ros_env(domain)
    launch = ru.Proc([str(bins / "naic"), "launch", "--lockstep", "-p", "naic_controller:scenario:=none",
                      "-p", f"jk5_sim_driver:tool_mass_error:={MASS_ERROR}",
                      "-p", f"jk5_sim_driver:tool_com_offset:=[{','.join(str(x) for x in COM_OFFSET)}]"], env)
    live = ru.Proc([str(bins / "naic"), "tool", "identify", "--poses", "8", "--timeout", "400"], env)
    try:
        ex = subprocess.run([sys.executable, str(ru.ROOT / "examples/tool_poses.py"), "--out", str(tmp_path),
                             "--use-sim-time", "--timeout", "400", "--naic", str(bins / "naic")],
                            cwd=ru.ROOT, env=env, capture_output=True, text=True, timeout=450)
        live.wait_end(60)
    finally:
        live.stop(timeout=10)
        launch.stop(timeout=20)
    assert ex.returncode == 0, ex.stderr[-3000:] + launch.output()[-2000:]
    assert live.p.returncode == 0, live.output()[-3000:]
    assert "pose 8/8 held" in ex.stderr and "pose 8/8 held" in live.output()
    mass, com = _true_tool()
    for name, text in (("example (--bag)", ex.stderr), ("live", live.output())):
        m, c = _fit(text)
        dc = max(abs(a - b) for a, b in zip(c, com))
        print(f"{name}: mass {m:.4f} kg (tool {mass}), centre of mass off by {dc * 1e3:.3f} mm")
        assert abs(m - mass) <= 0.02 * mass, (name, m, mass)
        assert dc <= 0.002, (name, c, com)
