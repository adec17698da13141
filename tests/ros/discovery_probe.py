"""How long rclpy takes to find naic_controller and its parameter services (issue 13).

    python tests/ros/discovery_probe.py [--trials N] [--chain [--lockstep]] [--node NAME] [--rclpy-first]
        [--extra K] [--client-after S [--subscribe]]

Each trial starts a lone `naic_controller` (or, with --chain, `naic launch`) on a fresh
private domain (loopback only) and an rclpy observer (after the node, or before it with
--rclpy-first), then polls every 10 ms, without spinning (discovery runs in Fast DDS's own
threads), for: the first `/naic/params` publisher seen (SPDP + SEDP of the node's
participant), the node name (`ros_discovery_info`), and each of the six parameter
services ready (`Client.service_is_ready`: the request writer and the response reader
matched). Prints one JSON line per trial (seconds since the node was started) and a
summary; run it with the machine loaded to see where the time goes.
"""
import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
import rostest_util as ru  # noqa: E402


def _port_bound(port):
    import socket
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.bind(("127.0.0.1", port))
        return False
    except OSError:
        return True
    finally:
        s.close()


def trial(bins, chain, rclpy_first, limit, extra=0, client_after=0.0, lockstep=False, node="naic_controller", subscribe=False):
    from rclpy.client import Client
    from rclpy.parameter_client import AsyncParameterClient
    domain = ru.fresh_domain()
    env = ru.ros_env(domain)
    # Other participants first (lone friction_compensation nodes under other names), so the
    # controller's participant gets id `extra` (RTPS ports 7410 + 250 d + 2 id).
    pads = [ru.Proc([str(bins / "friction_compensation"), "--ros-args", "-p", "realtime_priority:=0",
                     "-r", f"__node:=pad{i}"], env) for i in range(extra)]
    t_pad = time.time()
    while extra and time.time() - t_pad < 20 and not all(_port_bound(7410 + 250 * domain + 2 * i) for i in range(extra)):
        time.sleep(0.05)
    r = ru.RclpyDomain(domain, "discovery_probe") if rclpy_first else None
    t0 = time.time()
    if chain:
        p = ru.Proc([str(bins / "naic"), "launch", *(["--lockstep"] if lockstep else [])], env)
    else:
        p = ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml"], env)
    if r is None:
        r = ru.RclpyDomain(domain, "discovery_probe")
    out = {"domain": domain, "extra_participants": extra, "rclpy_ready": round(time.time() - t0, 3)}
    # A long-lived observer (the suite's): its clients are created later; with `subscribe`
    # it receives /joint_states and /clock meanwhile (as the lockstep test does).
    if subscribe:
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState
        got = []
        r.node.create_subscription(JointState, "/joint_states", got.append, 100)
        r.node.create_subscription(Clock, "/clock", got.append, 100)
        r.spin(client_after)
        out["received"] = len(got)
    else:
        time.sleep(client_after)
    t0 = time.time()
    c = AsyncParameterClient(r.node, node)
    clients = {k.strip("_"): v for k, v in vars(c).items() if isinstance(v, Client)}
    ready = {}
    try:
        while time.time() - t0 < limit and len(ready) < len(clients):
            now = round(time.time() - t0, 3)
            if "params_pub" not in out and r.node.count_publishers("/naic/params") > 0:
                out["params_pub"] = now
            if "node" not in out and node in {n for n, _ in r.node.get_node_names_and_namespaces()}:
                out["node"] = now
            for k, cl in clients.items():
                if k not in ready and cl.service_is_ready():
                    ready[k] = now
            time.sleep(0.01)
    finally:
        out["services"] = ready
        if len(ready) < len(clients):
            # Which of the server's endpoints the observer knows (its DDS topics
            # rq/<node>/<service>Request, read by the server, and .../<service>Reply).
            srvs = ("get_parameters", "get_parameter_types", "set_parameters", "set_parameters_atomically",
                    "list_parameters", "describe_parameters")
            out["server_endpoints_seen"] = {
                sv: (len(r.node.get_subscriptions_info_by_topic(f"rq/{node}/{sv}Request", no_mangle=True)),
                     len(r.node.get_publishers_info_by_topic(f"rr/{node}/{sv}Reply", no_mangle=True)))
                for sv in srvs}
            # The node's other endpoints, created before the services (/parameter_events)
            # and after them (its topics).
            out["other_endpoints_seen"] = {
                "/parameter_events writer": sum(1 for i in r.node.get_publishers_info_by_topic("/parameter_events") if i.node_name == node),
                "/joint_effort_cmd reader": sum(1 for i in r.node.get_subscriptions_info_by_topic("/joint_effort_cmd") if i.node_name == node),
                "/joint_states writer": sum(1 for i in r.node.get_publishers_info_by_topic("/joint_states") if i.node_name == node),
            }
        out["all_services"] = max(ready.values()) if len(ready) == len(clients) else None
        r.close()
        out["exit"] = p.stop(timeout=15)
        for q in pads:
            q.stop(timeout=15)
        ru.release_domains()
    if out["all_services"] is None:
        out["node_output_tail"] = p.output()[-1500:]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--chain", action="store_true", help="naic launch (three nodes, real time) instead of a lone controller")
    ap.add_argument("--rclpy-first", action="store_true", help="start the rclpy observer before the node")
    ap.add_argument("--extra", type=int, default=0, help="start this many other RustDDS participants first")
    ap.add_argument("--client-after", type=float, default=0.0, help="create the parameter client this long after the observer (times are then from its creation)")
    ap.add_argument("--lockstep", action="store_true", help="with --chain: naic launch --lockstep")
    ap.add_argument("--node", default="naic_controller", help="whose parameter services to wait for")
    ap.add_argument("--subscribe", action="store_true", help="the observer receives /joint_states and /clock (spinning) before making its client")
    ap.add_argument("--limit", type=float, default=30.0, help="give up a trial after this many seconds")
    a = ap.parse_args()
    bins = ru.build_nodes()
    times = []
    for _ in range(a.trials):
        t = trial(bins, a.chain, a.rclpy_first, a.limit, a.extra, a.client_after, a.lockstep, a.node, a.subscribe)
        print(json.dumps(t), flush=True)
        times.append(t["all_services"])
    ok = sorted(x for x in times if x is not None)
    print(json.dumps({
        "trials": len(times), "found": len(ok), "load": os.getloadavg()[0],
        "median_s": ok[len(ok) // 2] if ok else None, "max_s": ok[-1] if ok else None,
        "over_10s": sum(1 for x in times if x is None or x > 10.0),
    }))


if __name__ == "__main__":
    main()
