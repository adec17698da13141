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
    """The node binaries and `naic`. `--workspace`: features unified as in tests/run_all.sh's
    build, so nothing is compiled again (with `-p` a different feature set rebuilt the
    dependencies: 2 min in a fresh clone)."""
    subprocess.run(["cargo", "build", "--release", "-q", "--workspace", "--bins"], cwd=ROOT, check=True)
    return target_dir()


# Domains this process has claimed: {domain: open lock file}. Kept for the life of the
# process (a module fixture's domain is still in use while later tests run); 131 ids are
# enough for the few dozen a test session takes, and for several sessions at once.
_CLAIMED = {}


def _domain_port_free(domain):
    """True when no DDS participant of this machine uses `domain`'s first unicast
    discovery port (RTPS default mapping: 7400 + 250 d + 10; participant 0 takes it, the
    next participants take the ports above)."""
    import socket
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.bind(("127.0.0.1", 7410 + 250 * domain))
        return True
    except OSError:
        return False
    finally:
        s.close()


def takeover_blend_override(node_prefix=""):
    """`-p [node:]takeover_blend:=X` when NAIC_TAKEOVER_BLEND=X is set (to compare take-overs
    with a blend; docs/notes/2026-12-dds-test-forensics.md, "The blend is off by default"), else nothing. `node_prefix`
    is "friction_compensation:" for `naic launch`, "" for the node itself."""
    v = os.environ.get("NAIC_TAKEOVER_BLEND")
    return ["-p", f"{node_prefix}takeover_blend:={float(v)}"] if v else []


def fresh_domain(offset=0):
    """A domain id no one else on this machine uses right now: 101..231 (ids up to 232 fit
    the RTPS port mapping; low ids are what people use by hand). Concurrent test runs (other
    checkouts, CI jobs) each claim their domains with a lock file, and a domain whose
    discovery port is taken (any DDS participant, ours or not) is skipped: two runs on one
    domain see each other's nodes (a second /naic_controller answering parameter requests,
    another chain's commands reaching a lone driver) and fail in ways that look like load."""
    import fcntl
    import tempfile
    base = random.Random(os.getpid() * 7919 + time.time_ns()).randint(0, 130)
    lock_dir = pathlib.Path(tempfile.gettempdir()) / "naic-ros-domains"
    lock_dir.mkdir(exist_ok=True)
    for k in range(131):
        d = 101 + (base + offset + k) % 131
        if d in _CLAIMED:
            continue
        f = open(lock_dir / f"{d}.lock", "w")
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.close()
            continue
        if not _domain_port_free(d):
            f.close()
            continue
        _CLAIMED[d] = f
        return d
    raise RuntimeError("no free ROS domain id in 101..231 on this machine")


def release_domains():
    """Give back this process's domain claims (the lock files; called after every test by
    tests/python/conftest.py). Without it a long pytest run holds one claim per test and
    runs out of the 131 ids. A domain still in use by a longer-lived fixture stays safe:
    its participants hold its discovery port, which `fresh_domain` checks."""
    for f in _CLAIMED.values():
        f.close()
    _CLAIMED.clear()


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

    def wait_end(self, timeout):
        """Wait up to `timeout` s for the process to end by itself (`naic launch --duration`)."""
        try:
            self.p.wait(timeout)
        except subprocess.TimeoutExpired:
            pass

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


class NodeStalls:
    """Stops a node of a `naic launch` (found by its "started NODE (pid N)" line) for
    `stop_s` every `period_s` (SIGSTOP, SIGCONT) from a thread until `close()`: a stall the
    test makes itself, so a precondition that needs one does not depend on the machine's
    load. `count` is the number of stops made."""

    def __init__(self, launch, node, stop_s=0.005, period_s=0.03, find_timeout=20.0):
        self.launch, self.node, self.stop_s, self.period_s = launch, node, stop_s, period_s
        self.find_timeout = find_timeout
        self.count, self.error = 0, None
        self.done = threading.Event()
        self.t = threading.Thread(target=self._run, daemon=True)
        self.t.start()

    def _run(self):
        import re
        pat = re.compile(rf"started {re.escape(self.node)} \(pid (\d+)\)")
        t0 = time.monotonic()
        m = None
        while m is None and not self.done.is_set() and time.monotonic() - t0 < self.find_timeout:
            m = pat.search(self.launch.output())
            time.sleep(0.01)
        if m is None:
            self.error = f"no 'started {self.node} (pid N)' line from naic launch within {self.find_timeout} s"
            return
        pid = int(m.group(1))
        while not self.done.wait(self.period_s - self.stop_s):
            try:
                os.kill(pid, signal.SIGSTOP)
                time.sleep(self.stop_s)
            except ProcessLookupError:
                return
            finally:
                try:
                    os.kill(pid, signal.SIGCONT)
                except ProcessLookupError:
                    pass
            self.count += 1

    def close(self):
        """Stop stalling (the node is left running) and return the number of stops."""
        self.done.set()
        self.t.join(5.0)
        return self.count


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


OBSERVER_PRIORITY = 10  # SCHED_RR, below the nodes' SCHED_RR 50 (params/ realtime_priority)
_warned_priority = []


def observer_priority():
    """Run every thread of this process (the rclpy observer: its executor and Fast DDS's
    threads) at SCHED_RR OBSERVER_PRIORITY, with SCHED_RESET_ON_FORK so processes it starts
    (cargo, the nodes, naic) and threads created later start with normal scheduling (call
    again after creating a context).

    Why: on a busy machine a normal-priority Python observer gets a small share of a CPU
    (Linux autogroups split the CPUs between sessions, so nice does not help): it then
    receives a few hundred of the 1 kHz messages, publishes its commands late and judges
    the nodes by what it failed to read. The nodes run real-time; their observers must not
    starve. Without CAP_SYS_NICE this warns once and runs normally."""
    policy = os.SCHED_RR | getattr(os, "SCHED_RESET_ON_FORK", 0x40000000)
    param = os.sched_param(OBSERVER_PRIORITY)
    try:
        tids = [int(t) for t in os.listdir("/proc/self/task")]
    except OSError:
        tids = [0]
    for tid in tids:
        try:
            if os.sched_getscheduler(tid) & ~0x40000000 != os.SCHED_RR:
                os.sched_setscheduler(tid, policy, param)
        except PermissionError as e:
            if not _warned_priority:
                _warned_priority.append(e)
                print(f"rostest_util: cannot raise the rclpy observer to SCHED_RR {OBSERVER_PRIORITY} ({e}); "
                      "on a busy machine it may miss messages", file=sys.stderr)
            return
        except OSError:
            continue  # the thread ended meanwhile


def with_naic_msgs(env):
    """`env` plus the naic_msgs overlay (PYTHONPATH, LD_LIBRARY_PATH prepended) for an rclpy
    subprocess that imports naic_msgs."""
    return overlay_env(env, naic_msgs_env())


def overlay_env(env, overlay, *pythonpath):
    """`env` plus the colcon `overlay` (from `naic_msgs_env()`): its PYTHONPATH, then the
    folders `pythonpath`, then this process's; its LD_LIBRARY_PATH before this process's."""
    out = {**env, **overlay}
    out["PYTHONPATH"] = os.pathsep.join([overlay["PYTHONPATH"], *map(str, pythonpath), os.environ.get("PYTHONPATH", "")])
    out["LD_LIBRARY_PATH"] = overlay["LD_LIBRARY_PATH"] + os.pathsep + os.environ.get("LD_LIBRARY_PATH", "")
    return out


def run_in_overlay(argv, domain, overlay, timeout, stop=None, pythonpath=()):
    """Run `python ARGV` (an rclpy script: `["-c", SCRIPT]` or a file and its arguments) in
    the naic_msgs `overlay` on `domain`, then stop the process `stop` (a Proc, even when
    the script failed). Asserts that both exited cleanly, naming what each printed, and
    returns the script's last line of output parsed as JSON."""
    import json
    env = overlay_env(ros_env(domain), overlay, *pythonpath)
    try:
        out = subprocess.run([sys.executable, *map(str, argv)], env=env, capture_output=True, text=True,
                             timeout=timeout)
    finally:
        rc = stop.stop(timeout=15) if stop is not None else 0
    assert out.returncode == 0, out.stderr[-3000:]
    assert rc == 0, stop.output()[-3000:]
    lines = out.stdout.strip().splitlines()
    assert lines, f"the script printed nothing; stderr: {out.stderr[-3000:]}"
    return json.loads(lines[-1])


def param_client(node, target, timeout=20.0):
    """An rclpy AsyncParameterClient of `node` for the naic node `target`, once its parameter
    services are matched. When they are not within `timeout` but `target` itself is in the
    graph (its ros_discovery_info arrived) and its get_parameters service is not, the failure
    names the loss of a RustDDS node's first SEDP announcements inside Fast DDS that the
    vendored re-announcement patch exists for (issue 13; docs/notes/2026-12-dds-test-forensics.md, "The 10 s failure,
    traced"). Until 2026-12-04 that case was an xfail; it is a failure now, so that a case
    the patch does not cover is seen."""
    from rclpy.parameter_client import AsyncParameterClient
    c = AsyncParameterClient(node, target)
    if c.wait_for_services(timeout):
        return c
    name = target.rsplit("/", 1)[-1]
    ns = target.rsplit("/", 1)[0] or "/" if "/" in target else "/"
    nodes = set(node.get_node_names_and_namespaces())
    services = {s for s, _ in node.get_service_names_and_types_by_node(name, ns)} if (name, ns) in nodes else set()
    want = f"{ns.rstrip('/')}/{name}/get_parameters"
    if (name, ns) in nodes and want not in services:
        raise AssertionError(f"{target}'s parameter services never reached this rclpy participant though the node is in "
                             f"its graph (the RustDDS/Fast DDS discovery loss of issue 13, which the re-announcement "
                             f"patch should repair: crates/vendor/rustdds/PATCHED.md; services seen: "
                             f"{sorted(services)[:4]})")
    raise AssertionError(f"{target}'s parameter services not found in {timeout} s; nodes in the graph: {sorted(nodes)}")


class RclpyDomain:
    """An rclpy context, node and executor on one domain (tests can use several domains).
    Its threads run at [`observer_priority`]."""

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
        observer_priority()

    def spin(self, seconds):
        observer_priority()
        t0 = time.time()
        while time.time() - t0 < seconds:
            self.ex.spin_once(timeout_sec=0.01)

    def spin_until(self, cond, timeout):
        observer_priority()  # threads Fast DDS started since
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


SLIDE_EXAMPLE = ROOT / "examples" / "slide_with_force_profile.py"


def run_slide_example(bins, launch, domain, out_dir, timeout, *args):
    """Run examples/slide_with_force_profile.py (`--use-sim-time`, extra `args`) against the
    chain `launch` (a Proc on `domain`), then stop the chain. Asserts that the example and the
    chain exited cleanly (an example that never learned naic_controller's reference
    subscriptions is named as the RustDDS <-> Fast DDS discovery loss of issue 13; an xfail
    until 2026-12-04) and returns the example's JSON summary."""
    import json
    env = with_naic_msgs(ros_env(domain))
    try:
        out = subprocess.run([sys.executable, str(SLIDE_EXAMPLE), "--out", str(out_dir), "--use-sim-time",
                              "--naic", str(bins / "naic"), "--timeout", str(timeout), *map(str, args)],
                             env=env, cwd=ROOT, capture_output=True, text=True, timeout=timeout + 120)
    finally:
        rc = launch.stop(timeout=15)
    assert not (out.returncode != 0 and "naic_controller does not subscribe" in out.stderr), (
        "discovery: the example's rclpy participant never learned naic_controller's reference subscriptions "
        "(the RustDDS/Fast DDS loss of issue 13, which the re-announcement patch should repair: "
        "crates/vendor/rustdds/PATCHED.md): " + out.stderr.strip()[-300:])
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-3000:]
    assert rc == 0, launch.output()[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def assert_bag_complete(summary, topic, short, what):
    """The bag has every `topic` message: naic record reported no loss of it (gaps in a
    publisher's sequence numbers), and the caller's check on what the bag holds (`short`)
    did not find it short without such a report (data lost silently). Until 2026-12-03 a
    reported loss was an expected failure (the recorder fell behind a lockstep chain under
    load); since the recorder writes on its own thread and both sides keep 10 s of history,
    none was seen in three loaded runs of the DDS suite (docs/bags.md), so a loss is a
    failure again. `what` says what the bag holds, for the messages."""
    lost = summary["recorder_lost"].get(topic, 0)
    assert lost == 0, f"naic record lost {lost} {topic} messages ({what}; docs/bags.md)"
    assert not short, f"{what}, and naic record reported no loss of {topic}: data lost silently: {summary}"


def spin_node_until(node, cond, timeout, step=0.02):
    """Spin an rclpy `node` in the global context until `cond()` holds or `timeout` s pass;
    returns `cond()` (for rclpy scripts that have one node and no executor)."""
    import rclpy
    t0 = time.time()
    while time.time() - t0 < timeout:
        rclpy.spin_once(node, timeout_sec=step)
        if cond():
            return True
    return cond()
