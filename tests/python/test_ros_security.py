"""DDS Security (issue 41, items 2-4), with real processes on a private loopback domain.

The nodes are built with `--features naic_ros/security` into their own target directory
(`target/security`, so the default build's binaries are untouched); the keystore is made by
`naic security init` (openssl).

* Fail closed: a node started with an enclave it cannot load exits 1 and names the file
  (missing key, a certificate that is not one, a certificate from another CA); a build
  without the feature refuses every enclave; none of them ever comes up unsecured.
* Who reaches a secured driver, in a network namespace this module creates and removes
  (its own loopback: nothing of the test's DDS traffic can reach another process of the
  machine, and nothing outside can reach it): a participant without a certificate (rclpy,
  whose PyPI Fast DDS has no security plugins, docs/deploy.md; and `naic record` / `naic
  param` without the ROS security variables) discovers none of the chain's topics or
  nodes, records no /joint_states and sets no parameter; `naic record` and `naic param` in
  the keystore's observer enclave read /joint_states and set a parameter. The control: the
  same rclpy probe against an unsecured driver sees it and sets the parameter.
* The command owner holds under security: `naic launch --enclave` keeps the driver's and
  friction_compensation's named sources, the chain's commands are accepted, and a second
  writer of /joint_effort_cmd in the chain's own enclave (so the permissions let it
  publish) under another node name is counted, named and ignored.
"""
import json
import os
import pathlib
import shutil
import subprocess
import sys
import time

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

SEC_TARGET = ru.ROOT / "target" / "security"


@pytest.fixture(scope="module")
def sec_bins():
    """The binaries with DDS Security (needs libssl-dev and pkg-config)."""
    env = {**os.environ, "CARGO_TARGET_DIR": str(SEC_TARGET)}
    out = subprocess.run(["cargo", "build", "--release", "-q", "--workspace", "--bins", "--features", "naic_ros/security"],
                         cwd=ru.ROOT, env=env, capture_output=True, text=True)
    if out.returncode != 0:
        pytest.fail(f"the security build failed (apt-get install -y libssl-dev pkg-config?):\n{out.stderr[-3000:]}")
    return SEC_TARGET / "release"


@pytest.fixture(scope="module")
def keystore(sec_bins, tmp_path_factory):
    ks = tmp_path_factory.mktemp("keystore") / "ks"
    out = subprocess.run([str(sec_bins / "naic"), "security", "init", str(ks)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return ks


def _secure_env(domain, keystore, enclave):
    env = ru.ros_env(domain)
    env.update(ROS_SECURITY_ENABLE="true", ROS_SECURITY_KEYSTORE=str(keystore), ROS_SECURITY_ENCLAVE_OVERRIDE=enclave)
    return env


def _driver_fails(bins, env, timeout=60):
    out = subprocess.run([str(bins / "jk5_sim_driver"), "--ros-args", "--params-file", "params/jk5_sim_driver.yaml"],
                         cwd=ru.ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    return out.returncode, out.stdout + out.stderr


def _copy_enclave(keystore, tmp_path):
    ks = tmp_path / "ks"
    shutil.copytree(keystore, ks)
    return ks, ks / "enclaves" / "naic" / "chain"


def test_ros_security_missing_file_stops_the_node_naming_it(sec_bins, keystore, tmp_path):
    ks, enc = _copy_enclave(keystore, tmp_path)
    (enc / "key.pem").unlink()
    code, text = _driver_fails(sec_bins, _secure_env(ru.fresh_domain(5), ks, "/naic/chain"))
    assert code == 1 and "key.pem" in text and "refusing to start" in text, text[-2000:]
    assert "started /jk5_sim_driver" not in text, "the node came up"


def test_ros_security_bad_certificate_stops_the_node_naming_it(sec_bins, keystore, tmp_path):
    ks, enc = _copy_enclave(keystore, tmp_path)
    (enc / "cert.pem").write_text("-----BEGIN CERTIFICATE-----\nbm90IGEgY2VydGlmaWNhdGU=\n-----END CERTIFICATE-----\n")
    code, text = _driver_fails(sec_bins, _secure_env(ru.fresh_domain(5), ks, "/naic/chain"))
    assert code == 1 and "cert.pem" in text and "not a PEM certificate" in text, text[-2000:]
    assert "started /jk5_sim_driver" not in text


def test_ros_security_certificate_of_another_ca_stops_the_node(sec_bins, keystore, tmp_path):
    """A well-formed certificate the identity CA did not issue: RustDDS refuses it when the
    participant is built; the node exits naming the enclave's directory."""
    other = tmp_path / "other"
    subprocess.run([str(sec_bins / "naic"), "security", "init", str(other)], check=True, capture_output=True)
    ks, enc = _copy_enclave(keystore, tmp_path)
    shutil.copy(other / "enclaves/naic/chain/cert.pem", enc / "cert.pem")
    shutil.copy(other / "enclaves/naic/chain/key.pem", enc / "key.pem")
    code, text = _driver_fails(sec_bins, _secure_env(ru.fresh_domain(5), ks, "/naic/chain"))
    assert code == 1 and str(enc) in text and "refus" in text, text[-2000:]
    assert "started /jk5_sim_driver" not in text


def test_ros_security_a_build_without_it_refuses_every_enclave(keystore):
    bins = ru.build_nodes()
    code, text = _driver_fails(bins, _secure_env(ru.fresh_domain(5), keystore, "/naic/chain"))
    assert code == 1 and "no DDS Security" in text and "naic_ros/security" in text, text[-2000:]
    assert "started /jk5_sim_driver" not in text


def _netns_prefix():
    """Create a network namespace with its loopback up: (argv prefix, name), or (None, why)."""
    if os.geteuid() != 0:
        return None, "a network namespace needs root (ip netns add); this test runs as uid %d" % os.geteuid()
    if shutil.which("ip") is None:
        return None, "the ip command (iproute2) is not installed"
    name = f"naic-sec-{os.getpid()}"
    add = subprocess.run(["ip", "netns", "add", name], capture_output=True, text=True)
    if add.returncode != 0:
        return None, f"ip netns add {name} failed: {add.stderr.strip()}"
    up = subprocess.run(["ip", "netns", "exec", name, "ip", "link", "set", "lo", "up"], capture_output=True, text=True)
    if up.returncode != 0:
        subprocess.run(["ip", "netns", "del", name], capture_output=True)
        return None, f"ip netns exec {name} ip link set lo up failed: {up.stderr.strip()}"
    return ["ip", "netns", "exec", name], name


@pytest.fixture(scope="module")
def netns():
    """The argv prefix that runs a process in this module's own network namespace."""
    prefix, name = _netns_prefix()
    if prefix is None:
        pytest.skip(f"the security tests run in a network namespace, and none can be made here: {name}")
    try:
        yield prefix
    finally:
        subprocess.run(["ip", "netns", "del", name], capture_output=True)
        assert not (pathlib.Path("/run/netns") / name).exists(), f"network namespace {name} was not removed"


def _observer(keystore):
    return dict(ROS_SECURITY_ENABLE="true", ROS_SECURITY_KEYSTORE=str(keystore), ROS_SECURITY_ENCLAVE_OVERRIDE="/naic/observer")


def _run(netns, argv, domain, env_extra, timeout=120):
    env = {**ru.ros_env(domain), **env_extra}
    return subprocess.run(netns + argv, cwd=ru.ROOT, env=env, capture_output=True, text=True, timeout=timeout)


def _record(netns, bins, domain, out, env_extra):
    return _run(netns, [str(bins / "naic"), "record", "--topics", "/joint_states", "--duration", "6", "--out", str(out)],
                domain, env_extra)


def _count(bins, bag):
    r = subprocess.run([str(bins / "naic"), "bag", "info", str(bag), "--json"], capture_output=True, text=True)
    if r.returncode != 0:
        return None, r.stdout + r.stderr
    info = json.loads(r.stdout)
    topics = {t["topic"]: t for t in info.get("topics", [])}
    return topics.get("/joint_states", {}).get("count", 0), r.stdout


def _probe(netns, domain, seconds=8.0, value=7.5):
    """tests/ros/graph_probe.py (rclpy, no certificate) against the driver's hold_damping."""
    r = _run(netns, [sys.executable, str(ru.ROOT / "tests/ros/graph_probe.py"), str(seconds), "jk5_sim_driver",
                     "hold_damping", str(value)], domain, {}, timeout=90)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def _param(netns, bins, domain, env_extra, *args, timeout=15):
    return _run(netns, [str(bins / "naic"), "param", *args, "--timeout", str(timeout)], domain, env_extra,
                timeout=timeout + 60)


def _driver(netns, bins, domain, env):
    return ru.Proc(netns + [str(bins / "jk5_sim_driver"), "--ros-args", "--params-file", "params/jk5_sim_driver.yaml"],
                   env)


def test_ros_security_the_rclpy_probe_sees_and_sets_an_unsecured_driver(sec_bins, netns):
    """The control of the next test: the same probe, the same namespace, no security."""
    domain = ru.fresh_domain(5)
    drv = _driver(netns, sec_bins, domain, ru.ros_env(domain))
    try:
        seen = _probe(netns, domain)
        got = _param(netns, sec_bins, domain, {}, "get", "jk5_sim_driver", "hold_damping")
        assert drv.p.poll() is None, drv.output()[-3000:]
    finally:
        drv.stop(timeout=20)
    print(f"unsecured driver, rclpy probe: {seen}")
    assert "/joint_states" in seen["topics"] and "/jk5_sim_driver" in seen["nodes"], seen
    assert seen["service_ready"] and seen["set"] is True, seen
    assert got.returncode == 0 and "hold_damping (double) = 7.5\n" in got.stdout, got.stdout + got.stderr


def test_ros_security_only_a_participant_with_a_certificate_reads_the_chain(sec_bins, keystore, netns, tmp_path):
    domain = ru.fresh_domain(5)
    drv = _driver(netns, sec_bins, domain, _secure_env(domain, keystore, "/naic/chain"))
    try:
        # Without a certificate: rclpy (no security plugins at all) and naic (RustDDS, unsecured).
        seen = _probe(netns, domain)
        set_plain = _param(netns, sec_bins, domain, {}, "set", "jk5_sim_driver", "hold_damping:=9.0")
        without = _record(netns, sec_bins, domain, tmp_path / "plain.mcap", {})
        # With the observer enclave's certificate and permissions.
        with_cert = _record(netns, sec_bins, domain, tmp_path / "observer.mcap", _observer(keystore))
        assert drv.p.poll() is None, drv.output()[-3000:]
    finally:
        drv.stop(timeout=20)
    n_obs, info_obs = _count(sec_bins, tmp_path / "observer.mcap")
    n_plain, info_plain = _count(sec_bins, tmp_path / "plain.mcap")
    print(f"secured driver: rclpy probe without a certificate {seen}; naic param set without one: exit "
          f"{set_plain.returncode}; /joint_states recorded: observer enclave {n_obs}, no certificate {n_plain}")
    assert "DDS Security on: enclave /naic/chain" in drv.output(), drv.output()[-2000:]
    # No certificate: nothing of the chain is discovered, read or set.
    assert not any(t.startswith("/joint") or t.startswith("/naic") or t == "/wrench" for t in seen["topics"]), seen
    assert "/jk5_sim_driver" not in seen["nodes"] and not seen["service_ready"] and seen["set"] is None, seen
    assert set_plain.returncode == 3 and "no answer" in set_plain.stderr, set_plain.stdout + set_plain.stderr
    assert "parameter hold_damping set" not in drv.output(), drv.output()[-3000:]
    assert not n_plain, f"a participant without a certificate recorded {n_plain}:\n{without.stderr[-2000:]}"
    # The observer enclave reads the chain.
    assert "DDS Security on: enclave /naic/observer" in with_cert.stdout + with_cert.stderr
    assert n_obs and n_obs > 1000, f"the observer enclave recorded {n_obs}:\n{with_cert.stderr[-2000:]}\n{info_obs[-1000:]}"


def test_ros_security_a_participant_with_the_keystores_permissions_sets_a_parameter(sec_bins, keystore, netns):
    """`naic param set` and `get` in the observer enclave (RustDDS: the PyPI rclpy has no
    security plugins) change a secured driver's parameter and read it back. The service
    payloads (the GetParameters request, the SetParameters reply) are not a multiple of 4
    octets long: before crates/vendor/rustdds/PATCHED.md, "Padded protected payloads", their
    receivers dropped them and neither command got an answer. The driver logs no payload it
    could not decode (no MAC failure). Without a certificate the same set is not answered:
    test_ros_security_only_a_participant_with_a_certificate_reads_the_chain."""
    domain = ru.fresh_domain(5)
    drv = _driver(netns, sec_bins, domain, _secure_env(domain, keystore, "/naic/chain"))
    try:
        set_obs = _param(netns, sec_bins, domain, _observer(keystore), "set", "jk5_sim_driver", "hold_damping:=8.0")
        after = _param(netns, sec_bins, domain, _observer(keystore), "get", "jk5_sim_driver", "hold_damping")
        assert drv.p.poll() is None, drv.output()[-3000:]
    finally:
        drv.stop(timeout=20)
    print(f"observer enclave: set exit {set_obs.returncode}, get exit {after.returncode}: {after.stdout.strip()}")
    assert set_obs.returncode == 0 and "set hold_damping = 8" in set_obs.stdout, set_obs.stdout + set_obs.stderr[-1500:]
    assert after.returncode == 0 and "hold_damping (double) = 8.0\n" in after.stdout, after.stdout + after.stderr[-1500:]
    assert "parameter hold_damping set to" in drv.output()
    # A payload that fails its MAC (the symptom of the padding) is logged by ring's error.
    for text in (set_obs.stderr, after.stderr, drv.output()):
        assert "The ring crypto library gives 'Unspecified' error" not in text, text[-3000:]


def _launch_secured(netns, bins, keystore, domain, report, duration, extra=()):
    return ru.Proc(netns + [str(bins / "naic"), "launch", "--enclave", str(keystore / "enclaves/naic/chain"),
                            "--duration", str(duration), "-p", f"jk5_sim_driver:latency_report:={report}",
                            "-p", "jk5_sim_driver:latency_warmup:=2.0", *extra], ru.ros_env(domain))


def test_ros_security_the_chain_runs_in_its_enclave_with_named_command_sources(sec_bins, keystore, netns, tmp_path):
    """`naic launch --enclave`: the three nodes authenticate each other, the driver and
    friction_compensation name their command's writer through ros_discovery_info (delivered
    between secured participants), and the driver gets the chain's commands, none refused."""
    domain = ru.fresh_domain(5)
    report = tmp_path / "driver.json"
    launch = _launch_secured(netns, sec_bins, keystore, domain, report, 12)
    launch.wait_end(120)
    code = launch.stop(timeout=20)
    text = launch.output()
    assert code == 0, text[-3000:]
    assert text.count("DDS Security on: enclave /naic/chain") == 3, text[-3000:]
    assert "accepting only node 'friction_compensation' (command_source)" in text, text[-3000:]
    assert "/joint_effort_cmd: accepting the writer of /friction_compensation" in text, text[-3000:]
    assert "/naic/effort: accepting the writer of /naic_controller" in text, text[-3000:]
    r = json.loads(report.read_text())
    print(f"secured chain: {r['samples']} commands matched, median {r['median_us']} us, missed {r['missed_cycles']}, "
          f"{r['ignored_commands']} ignored before the writer was named, {r['foreign_commands']} foreign")
    assert r["samples"] > 5000 and r["rejected_commands"] == 0, r
    # The gate fails closed: the owner's first commands, before its participant's
    # ros_discovery_info named the writer, are ignored and counted (the driver holds the arm
    # meanwhile); no other node was ever seen writing.
    assert "ignoring the samples of node" not in text, text[-3000:]
    assert r["foreign_commands"] == 0, r


def test_ros_security_a_foreign_writer_in_the_chains_enclave_is_counted_and_ignored(sec_bins, keystore, netns,
                                                                                    tmp_path):
    """A second friction_compensation, renamed naic_intruder, in the chain's own enclave (its
    permissions allow publishing /joint_effort_cmd): it takes the controller's /naic/effort
    and publishes commands at 1 kHz as the real one does. The driver names it from its
    ros_discovery_info, counts and ignores every one of its samples, and keeps taking the
    chain's."""
    domain = ru.fresh_domain(5)
    report = tmp_path / "driver.json"
    launch = _launch_secured(netns, sec_bins, keystore, domain, report, 16)
    intruder = None
    try:
        t0 = time.time()
        while time.time() - t0 < 60 and "started /friction_compensation" not in launch.output():
            time.sleep(0.2)
        intruder = ru.Proc(netns + [str(sec_bins / "friction_compensation"), "--ros-args", "--params-file",
                                    "params/friction_compensation.yaml", "-r", "__node:=naic_intruder",
                                    "-p", "realtime_priority:=0", "-p", "cpu_affinity:=-1"],
                           _secure_env(domain, keystore, "/naic/chain"))
        launch.wait_end(120)
    finally:
        code = launch.stop(timeout=20)
        if intruder is not None:
            intruder.stop(timeout=20)
    text = launch.output()
    assert code == 0, text[-3000:]
    assert intruder is not None and "DDS Security on: enclave /naic/chain" in intruder.output(), intruder.output()[-2000:]
    r = json.loads(report.read_text())
    print(f"secured chain with an intruder in its enclave: {r['samples']} commands matched, "
          f"{r['foreign_commands']} foreign ignored")
    assert r["samples"] > 5000 and r["rejected_commands"] == 0, r
    assert r["foreign_commands"] > 1000, (r, intruder.output()[-2000:])
    named = [l for l in text.splitlines() if "/joint_effort_cmd" in l and "/naic_intruder" in l]
    assert named, text[-3000:]
