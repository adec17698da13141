"""DDS Security (issue 41, items 2-4), with real processes on a private loopback domain.

The nodes are built with `--features naic_ros/security` into their own target directory
(`target/security`, so the default build's binaries are untouched); the keystore is made by
`naic security init` (openssl).

* Fail closed: a node started with an enclave it cannot load exits 1 and names the file
  (missing key, a certificate that is not one, a certificate from another CA); a build
  without the feature refuses every enclave; none of them ever comes up unsecured.
* RustDDS <-> RustDDS (the PyPI rclpy's Fast DDS has no security plugins: docs/deploy.md):
  a `naic record` in the keystore's observer enclave records the secured driver's
  /joint_states; one without a certificate discovers nothing and records nothing.
"""
import json
import os
import shutil
import subprocess
import sys

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


def _record(bins, domain, out, env_extra):
    env = {**ru.ros_env(domain), **env_extra}
    r = subprocess.run([str(bins / "naic"), "record", "--topics", "/joint_states", "--duration", "6", "--out", str(out)],
                       cwd=ru.ROOT, env=env, capture_output=True, text=True, timeout=120)
    return r


def _count(bins, bag):
    r = subprocess.run([str(bins / "naic"), "bag", "info", str(bag), "--json"], capture_output=True, text=True)
    if r.returncode != 0:
        return None, r.stdout + r.stderr
    info = json.loads(r.stdout)
    topics = {t["topic"]: t for t in info.get("topics", [])}
    return topics.get("/joint_states", {}).get("count", 0), r.stdout


def test_ros_security_only_a_participant_with_a_certificate_reads_the_chain(sec_bins, keystore, tmp_path):
    domain = ru.fresh_domain(5)
    drv = ru.Proc([str(sec_bins / "jk5_sim_driver"), "--ros-args", "--params-file", "params/jk5_sim_driver.yaml"],
                  _secure_env(domain, keystore, "/naic/chain"))
    try:
        with_cert = _record(sec_bins, domain, tmp_path / "observer.mcap",
                            dict(ROS_SECURITY_ENABLE="true", ROS_SECURITY_KEYSTORE=str(keystore),
                                 ROS_SECURITY_ENCLAVE_OVERRIDE="/naic/observer"))
        without = _record(sec_bins, domain, tmp_path / "plain.mcap", {})
        assert drv.p.poll() is None, drv.output()[-3000:]
    finally:
        drv.stop(timeout=20)
    n_obs, info_obs = _count(sec_bins, tmp_path / "observer.mcap")
    n_plain, info_plain = _count(sec_bins, tmp_path / "plain.mcap")
    print(f"/joint_states recorded: observer enclave {n_obs}, no certificate {n_plain}")
    assert "DDS Security on: enclave /naic/chain" in drv.output(), drv.output()[-2000:]
    assert "DDS Security on: enclave /naic/observer" in with_cert.stdout + with_cert.stderr
    assert n_obs and n_obs > 1000, f"the observer enclave recorded {n_obs}:\n{with_cert.stderr[-2000:]}\n{info_obs[-1000:]}"
    assert not n_plain, f"a participant without a certificate recorded {n_plain}:\n{without.stderr[-2000:]}"


def test_ros_security_the_chain_runs_in_its_enclave(sec_bins, keystore, tmp_path):
    """`naic launch --enclave`: the three nodes authenticate each other and the driver gets
    the chain's commands (its latency report counts matched commands), none refused."""
    domain = ru.fresh_domain(5)
    report = tmp_path / "driver.json"
    out = subprocess.run([str(sec_bins / "naic"), "launch", "--enclave", str(keystore / "enclaves/naic/chain"),
                          "--duration", "12", "-p", f"jk5_sim_driver:latency_report:={report}",
                          "-p", "jk5_sim_driver:latency_warmup:=2.0"],
                         cwd=ru.ROOT, env=ru.ros_env(domain), capture_output=True, text=True, timeout=120)
    text = out.stdout + out.stderr
    assert out.returncode == 0, text[-3000:]
    assert text.count("DDS Security on: enclave /naic/chain") == 3, text[-3000:]
    r = json.loads(report.read_text())
    print(f"secured chain: {r['samples']} commands matched, median {r['median_us']} us, missed {r['missed_cycles']}")
    assert r["samples"] > 5000 and r["foreign_commands"] == 0 and r["rejected_commands"] == 0, r
