"""A fresh client's first service request is answered (issue 13, item 5).

rclpy's `wait_for_services` says that the client's participant has matched the node's
service endpoints; the node's own participant may learn the client's reply reader later.
A reply written before that is lost (RustDDS gaps samples written before a volatile
reader matched), and the first `ros2 param get` of a new process waits forever. The nodes
hold such a reply until the client's reply reader is known (naic_ros `reply.rs`). This
test makes several new rclpy participants against the three running nodes; each one sends
its first request the moment `wait_for_services` returns, and every request must be
answered. Loopback only, private domain.
"""
import os
import sys
import time

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402

# A parameter every node declares.
PARAM = "realtime_priority"


def test_first_request_of_a_new_participant_is_answered():
    bins = ru.build_nodes()
    domain = ru.fresh_domain()
    env = ru.ros_env(domain)
    procs = {n: ru.Proc([str(bins / n), "--ros-args", "--params-file", f"params/{n}.yaml",
                         "-p", "realtime_priority:=0"], env) for n in ru.NODES}
    latencies = []
    try:
        # The new participants join after the nodes have announced their endpoints: a
        # participant created during those announcements can lose some of them inside Fast
        # DDS (docs/notes/2026-12-dds-test-forensics.md, "The 10 s failure, traced"), which is not what this test is about.
        t_start = time.time()
        while not all("started /" in p.output() for p in procs.values()):
            assert time.time() - t_start < 30, {n: p.output()[-1500:] for n, p in procs.items()}
            time.sleep(0.1)
        time.sleep(1.0)
        for trial in range(4):
            r = ru.RclpyDomain(domain, f"fresh_client_{trial}")
            try:
                for n in ru.NODES:
                    c = ru.param_client(r.node, n, 20.0)
                    t0 = time.time()
                    f = c.get_parameters([PARAM])
                    r.spin_until(f.done, 15.0)
                    assert f.done(), (
                        f"trial {trial}: {n} did not answer a new client's first get_parameters within 15 s; "
                        f"its output: {procs[n].output()[-1500:]}")
                    assert [v.integer_value for v in f.result().values] == [0], f.result()
                    latencies.append(time.time() - t0)
                    print(f"domain {domain} trial {trial} {n}: first reply after {latencies[-1]:.3f} s at {t0:.3f}")
            finally:
                r.close()
    finally:
        outs = [(p.stop(), p.output()) for p in procs.values()]
    for code, out in outs:
        assert code == 0, out[-3000:]
        assert "panicked" not in out
        assert "dropped the reply" not in out, out[-3000:]
    print(f"first-reply latency over {len(latencies)} new clients: max {max(latencies):.3f} s")
    assert len(latencies) == 4 * len(ru.NODES)
