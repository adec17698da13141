"""rclpy watches a running chain (composed or three processes) while the simulated driver
plays a failing sensor (its `sensor_fault` parameter, set here through the parameter
service); prints what /naic/params and /joint_effort_cmd carried in each phase as JSON
(used by tests/python/test_ros_composed.py).

Needs naic_msgs on PYTHONPATH/LD_LIBRARY_PATH (tests/ros/build_naic_msgs.sh --env).
"""
import json
import math
import os
import sys

import rclpy
from naic_msgs.msg import NaicParams
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from std_msgs.msg import Float64MultiArray

import rostest_util as ru  # this directory: observer_priority

# PROBE_FAULTS=a,b,... runs another sequence (e.g. one fault four times, to tell a fault's
# own effect from that of repeated holds).
FAULTS = os.environ.get("PROBE_FAULTS", "nan_wrench,absurd_wrench,stale_wrench,nan_joint").split(",")


def main():
    rclpy.init()
    n = rclpy.create_node("sensor_fault_probe")
    params, cmds = [], []
    n.create_subscription(NaicParams, "/naic/params", params.append, 1000)
    n.create_subscription(Float64MultiArray, "/joint_effort_cmd", lambda m: cmds.append(list(m.data)), 1000)
    ru.observer_priority()

    def spin(seconds, until=lambda: False):
        return ru.spin_node_until(n, until, seconds, step=0.01)

    out = {"errors": []}
    driver = AsyncParameterClient(n, "jk5_sim_driver")
    if not driver.wait_for_services(30.0):
        print(json.dumps({"errors": ["jk5_sim_driver's parameter services not found in 30 s"]}))
        return
    # In contact and holding the force before any fault.
    if not spin(30.0, lambda: any(m.phase == NaicParams.PHASE_CONTACT for m in params[-50:])):
        out["errors"].append(f"no contact within 30 s; last phases {[m.phase for m in params[-5:]]}")

    def set_fault(v):
        f = driver.set_parameters([Parameter("sensor_fault", value=v)])
        spin(10.0, f.done)
        return f.done() and f.result().results[0].successful

    def phase(name, seconds):
        params.clear()
        cmds.clear()
        spin(seconds)
        tail = params[len(params) // 2:]
        return {
            "n_params": len(params),
            "n_cmds": len(cmds),
            "cmds_all_finite": all(math.isfinite(x) for c in cmds for x in c),
            "phases_tail": sorted({m.phase for m in tail}),
            "faults_tail": sorted({m.fault for m in tail}),
            "hold_tail": sum(m.phase == NaicParams.PHASE_HOLD for m in tail),
            "n_tail": len(tail),
            "faults_all": sorted({m.fault for m in params if m.fault}),
            "fault_count_end": params[-1].fault_count if params else None,
        }

    out["valid"] = phase("valid", 1.0)
    for fault in FAULTS:
        if not set_fault(fault):
            out["errors"].append(f"sensor_fault:={fault} was not accepted")
        out[fault] = phase(fault, 1.0)
        if not set_fault("none"):
            out["errors"].append("sensor_fault:=none was not accepted")
        out[fault + "_recovered"] = phase("recovered", 2.0)
    f = driver.set_parameters([Parameter("sensor_fault", value="smoke")])
    spin(10.0, f.done)
    out["bad_value"] = f.result().results[0].reason if f.done() and not f.result().results[0].successful else None
    print(json.dumps(out))
    n.destroy_node()
    rclpy.shutdown()
    sys.stdout.flush()


if __name__ == "__main__":
    main()
