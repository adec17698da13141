"""Helpers for the node-suite tests (tests/python/test_ros_*.py) and `naic bench chain`.

DDS stays on this machine: every process gets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
(rclpy/Fast DDS: no multicast, localhost peers only; RustDDS: loopback-only networks) and
its own ROS_DOMAIN_ID, so concurrent test runs on the machine do not see each other.
"""
import os
import pathlib
import random
import signal
import subprocess
import sys
import threading
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
NODES = ("jk5_sim_driver", "naic_controller", "friction_compensation")


def target_dir():
    return pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release"


def build_nodes():
    subprocess.run(
        ["cargo", "build", "--release", "-q", "-p", "naic", *sum((["-p", n] for n in NODES), [])],
        cwd=ROOT, check=True)
    return target_dir()


def fresh_domain(offset=0):
    """A domain id unlikely to be used by anyone else right now: 101..231 (ids up to 232
    fit the RTPS port mapping; low ids are what people use by hand)."""
    base = random.Random(os.getpid() * 7919 + time.time_ns()).randint(0, 130)
    return 101 + (base + offset) % 131


def ros_env(domain):
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("ROS_LOCALHOST_ONLY", None)  # deprecated in Jazzy; the range above wins anyway
    return env


def _die_with_parent():
    """In the child: get SIGINT when the test process dies, so no node outlives it."""
    import ctypes
    PR_SET_PDEATHSIG = 1
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGINT)


class Proc:
    """A node process whose output is collected (and echoed on failure)."""

    def __init__(self, args, env, cwd=ROOT):
        self.args = args
        self.p = subprocess.Popen(args, env=env, cwd=cwd, stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True, preexec_fn=_die_with_parent)
        self.lines = []
        self.t = threading.Thread(target=self._read, daemon=True)
        self.t.start()

    def _read(self):
        for line in self.p.stdout:
            self.lines.append(line.rstrip("\n"))

    def output(self):
        return "\n".join(self.lines)

    def alive(self):
        return self.p.poll() is None

    def stop(self, timeout=10.0):
        """SIGINT, wait; returns the exit code (kills and returns None if it hangs)."""
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGINT)
            try:
                self.p.wait(timeout)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
                return None
        self.t.join(2.0)
        return self.p.returncode


def naic_msgs_env():
    """Build msgs/naic_msgs with colcon (cached) and return the env overlay for rclpy."""
    venv = os.environ.get("NAIC_VENV") or str(pathlib.Path(sys.executable).parents[1])
    out = subprocess.run(["bash", str(ROOT / "tests/ros/build_naic_msgs.sh"), "--env"],
                         env={**os.environ, "NAIC_VENV": venv}, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"building naic_msgs failed:\n{out.stderr}")
    env = {}
    for line in out.stdout.splitlines():
        k, v = line.removeprefix("export ").split("=", 1)
        env[k] = v.split("${")[0]
    return env


def with_naic_msgs(env):
    """`env` plus the naic_msgs overlay (PYTHONPATH, LD_LIBRARY_PATH prepended) for an rclpy
    subprocess that imports naic_msgs."""
    overlay = naic_msgs_env()
    out = {**env, **overlay}
    for k in ("PYTHONPATH", "LD_LIBRARY_PATH"):
        out[k] = overlay[k] + os.pathsep + os.environ.get(k, "")
    return out


class RclpyDomain:
    """An rclpy context, node and executor on one domain (tests can use several domains)."""

    def __init__(self, domain, name="naic_test"):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        os.environ.pop("ROS_LOCALHOST_ONLY", None)
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node(name, context=self.ctx)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)

    def spin(self, seconds):
        t0 = time.time()
        while time.time() - t0 < seconds:
            self.ex.spin_once(timeout_sec=0.01)

    def spin_until(self, cond, timeout):
        t0 = time.time()
        while time.time() - t0 < timeout:
            self.ex.spin_once(timeout_sec=0.01)
            if cond():
                return True
        return cond()

    def wait(self, future, timeout=10.0):
        self.spin_until(future.done, timeout)
        assert future.done(), "no answer from the service within the timeout"
        return future.result()

    def close(self):
        self.ex.shutdown()
        self.node.destroy_node()
        self.ctx.try_shutdown()
