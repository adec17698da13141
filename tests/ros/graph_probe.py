"""An rclpy participant that looks at a domain for a while and tries to set a parameter.

    python graph_probe.py SECONDS NODE NAME VALUE

Prints one JSON line: the topics and nodes its graph saw (other than its own), whether
NODE's set_parameters service became ready, and the set's outcome (`null` when the service
never became ready). Used by tests/python/test_ros_security.py: a participant without a
certificate must see nothing of a secured chain and set nothing; against an unsecured node
the same probe sees it and sets the parameter (the control).
"""
import json
import sys
import time

import rclpy
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter


def main():
    seconds, node_name, name, value = float(sys.argv[1]), sys.argv[2], sys.argv[3], float(sys.argv[4])
    rclpy.init()
    node = rclpy.create_node("naic_graph_probe")
    client = node.create_client(SetParameters, f"/{node_name}/set_parameters")
    t_end = time.time() + seconds
    topics, nodes = set(), set()
    ready = False
    while time.time() < t_end:
        rclpy.spin_once(node, timeout_sec=0.1)
        topics |= {t for t, _ in node.get_topic_names_and_types()}
        nodes |= {f"{ns.rstrip('/')}/{n}" for n, ns in node.get_node_names_and_namespaces()}
        ready = ready or client.service_is_ready()
    result = None
    if ready:
        req = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        fut = client.call_async(req)
        t_end = time.time() + 20.0
        while not fut.done() and time.time() < t_end:
            rclpy.spin_once(node, timeout_sec=0.1)
        result = fut.done() and bool(fut.result().results[0].successful)
    nodes.discard("/naic_graph_probe")
    own = {"/parameter_events", "/rosout"}
    print(json.dumps({"topics": sorted(topics - own), "nodes": sorted(nodes), "service_ready": ready, "set": result}))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
