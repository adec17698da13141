"""rclpy observer for tests/python/test_ros_launch.py: watches a running `naic launch`
(/joint_states, /joint_effort_cmd, /naic/params), SIGKILLs its nodes one at a time and
records what the wire shows around each kill. Prints one JSON object on stdout.

    launch_probe.py LAUNCH_PID PLAN_JSON

PLAN_JSON: [[node, "respawn" | "dead"], ...]. "respawn": wait (up to 60 s) until the
launcher started a new process and it published (a controller: /naic/params; any node:
commands, unless a node of the plan was left dead before), then watch 2 s more; "dead": watch 3 s and
check that no new process appeared. Kills are made once the chain runs (commands and
/naic/params flowing).

Subscriptions are best effort (depth 10): under load this reader drops messages instead of
slowing the nodes' writers; the test judges by stamps, not by counts at a rate.

Needs naic_msgs on PYTHONPATH/LD_LIBRARY_PATH (tests/ros/build_naic_msgs.sh --env).
"""
import json
import os
import signal
import sys
import time

import rclpy
from naic_msgs.msg import NaicParams
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

import rostest_util as ru


def children(pid):
    """{node binary name: pid} of the live child processes of `pid`."""
    out = {}
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                st = f.read()
            ppid = int(st[st.rindex(")") + 2:].split()[1])
            state = st[st.rindex(")") + 2]
            if ppid != pid or state == "Z":
                continue
            with open(f"/proc/{d}/cmdline", "rb") as f:
                exe = f.read().split(b"\0")[0].decode()
            out[os.path.basename(exe)] = int(d)
        except (OSError, ValueError, IndexError):
            continue
    return out


def stamp_ns(h):
    return h.stamp.sec * 1_000_000_000 + h.stamp.nanosec


def src_ns(m):
    for kv in (m.layout.dim[0].label if m.layout.dim else "").split(";"):
        if kv.startswith("stamp_ns="):
            return int(kv[len("stamp_ns="):])
    return None


def main():
    launch_pid = int(sys.argv[1])
    plan = json.loads(sys.argv[2])
    rclpy.init()
    n = rclpy.create_node("naic_launch_probe")
    js, cmds, params = [], [], []
    n.create_subscription(JointState, "/joint_states", lambda m: js.append(
        (time.time(), stamp_ns(m.header), list(m.position), list(m.velocity), list(m.effort))), qos_profile_sensor_data)
    n.create_subscription(Float64MultiArray, "/joint_effort_cmd", lambda m: cmds.append(
        (time.time(), src_ns(m), list(m.data))), qos_profile_sensor_data)
    n.create_subscription(NaicParams, "/naic/params", lambda m: params.append(
        (time.time(), stamp_ns(m.header), m.phase, m.measured_force, m.fault)), qos_profile_sensor_data)

    def spin(seconds, until=lambda: False):
        ru.observer_priority()
        t0 = time.time()
        while time.time() - t0 < seconds:
            rclpy.spin_once(n, timeout_sec=0.01)
            if until():
                return True
        return until()

    def after(lst, t_ns, k=1):
        return [x for x in lst if x[k] is not None and x[k] > t_ns]

    res = {"events": [], "error": None}
    left_dead = False  # a node of the plan was killed and not respawned: no command can come
    t_start = time.time()
    if not spin(60, lambda: len(cmds) > 200 and len(params) > 200):
        res["error"] = f"chain did not run: {len(cmds)} commands, {len(params)} params, {len(js)} states"
    else:
        spin(2.0)
        for node, mode in plan:
            pids = children(launch_pid)
            if node not in pids:
                res["error"] = f"{node} is not running under naic launch (children: {pids})"
                break
            ev = {"node": node, "mode": mode, "pid": pids[node]}
            os.kill(pids[node], signal.SIGKILL)
            ev["t_kill_ns"] = time.time_ns()
            if mode == "respawn":
                ok = spin(60, lambda: children(launch_pid).get(node, pids[node]) != pids[node])
                ev["t_respawn_ns"] = time.time_ns() if ok else None
                ev["new_pid"] = children(launch_pid).get(node)
                if ok:
                    t = ev["t_respawn_ns"]
                    # The chain is whole again: commands computed from states after the
                    # restart, and the controller's report (the report alone after a node
                    # was left dead).
                    ev["resumed"] = spin(60, lambda: (left_dead or len(after(cmds, t)) > 100) and len(after(params, t)) > 100)
                    spin(2.0)
            else:
                spin(3.0)
                ev["new_pid"] = children(launch_pid).get(node)
                left_dead = True
            ev["t_end_ns"] = time.time_ns()
            ev["children_end"] = children(launch_pid)
            res["events"].append(ev)
    res["duration_s"] = time.time() - t_start
    res["js"], res["cmds"], res["params"] = js, cmds, params
    n.destroy_node()
    rclpy.shutdown()
    print(json.dumps(res))


if __name__ == "__main__":
    main()
