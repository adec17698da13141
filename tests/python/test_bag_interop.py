"""Bags written by naic, read by readers no one here wrote: mcap (Foxglove), mcap-ros2-support
and rosbags. Every message's values must equal what naic wrote (the JSON dump of the same
structs, via serde), including naic_msgs/msg/NaicParams whose schema only lives in the bag.
Also checks the rosbag2 (Jazzy) conventions: profile, schema/channel encodings, channel
metadata, the `rosbag2` metadata record, indexes, zstd chunks.
"""
import json
import math
import pathlib
import subprocess

import pytest
import yaml

mcap_reader = pytest.importorskip("mcap.reader")
mcap_ros2_reader = pytest.importorskip("mcap_ros2.reader")
rosbags_highlevel = pytest.importorskip("rosbags.highlevel")

SECONDS = 0.4  # 400 cycles x 4 topics at 1 kHz


@pytest.fixture(scope="module")
def sample(naic_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("bag")
    bag = d / "sample.mcap"
    dump = d / "sample.jsonl"
    subprocess.run(
        [str(naic_bin), "bag", "write-sample", str(bag), "--seconds", str(SECONDS), "--dump-json", str(dump)],
        check=True, capture_output=True,
    )
    expected = [json.loads(line) for line in dump.read_text().splitlines()]
    assert len(expected) == round(SECONDS * 1000) * 4
    return bag, expected


def assert_same(value, want, path="msg"):
    """Recursively compare a decoded ROS message (any reader's objects) with the JSON dict."""
    if isinstance(want, dict):
        for k, v in want.items():
            assert_same(getattr(value, k), v, f"{path}.{k}")
    elif isinstance(want, list):
        got = list(value)
        assert len(got) == len(want), f"{path}: length {len(got)} != {len(want)}"
        for i, (g, w) in enumerate(zip(got, want)):
            assert_same(g, w, f"{path}[{i}]")
    elif isinstance(want, bool):
        assert bool(value) is want, f"{path}: {value!r} != {want!r}"
    elif isinstance(want, float):
        assert float(value) == want, f"{path}: {value!r} != {want!r}"
    else:
        assert value == want, f"{path}: {value!r} != {want!r}"


def test_mcap_ros2_support_decodes_every_message(sample):
    bag, expected = sample
    got = list(mcap_ros2_reader.read_ros2_messages(str(bag)))
    assert len(got) == len(expected)
    for m, want in zip(got, expected):
        assert m.channel.topic == want["topic"]
        assert m.log_time_ns == want["log_time"]
        assert m.publish_time_ns == want["publish_time"]
        assert_same(m.ros_msg, want["msg"], want["topic"])


def test_rosbags_decodes_every_message(sample):
    bag, expected = sample
    with rosbags_highlevel.AnyReader([bag]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types == {
            "/joint_states": "sensor_msgs/msg/JointState",
            "/wrench": "geometry_msgs/msg/WrenchStamped",
            "/joint_effort_cmd": "std_msgs/msg/Float64MultiArray",
            "/naic/params": "naic_msgs/msg/NaicParams",
        }
        got = [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    assert len(got) == len(expected)
    # rosbags yields in log-time order; so did naic write.
    for (topic, t, msg), want in zip(got, expected):
        assert topic == want["topic"]
        assert t == want["log_time"]
        assert_same(msg, want["msg"], topic)
    # The NaicParams constants come from the schema in the bag.
    assert msg.PHASE_CONTACT == 1 and msg.PHASE_HOLD == 2


def jazzy_hash(venv_share, type_name):
    pkg, _, name = type_name.split("/")
    d = json.loads((venv_share / pkg / "msg" / f"{name}.json").read_text())
    return d["type_hashes"][0]["hash_string"]


@pytest.fixture(scope="module")
def venv_share():
    import std_msgs  # noqa: F401  (the ros-jazzy wheels)
    import sys
    share = pathlib.Path(sys.prefix) / "share"
    if not (share / "std_msgs" / "msg" / "Header.json").exists():
        pytest.fail(f"ROS 2 Jazzy type descriptions not found under {share}")
    return share


def test_rosbag2_conventions(sample, venv_share):
    bag, expected = sample
    with open(bag, "rb") as f:
        reader = mcap_reader.make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        metadata = list(reader.iter_metadata())
    assert header.profile == "ros2"
    sep = "=" * 80
    for schema in summary.schemas.values():
        assert schema.encoding == "ros2msg"
        text = schema.data.decode()
        if schema.name == "sensor_msgs/msg/JointState":
            parts = text.split("\n" + sep + "\n")
            assert [p.splitlines()[0] for p in parts[1:]] == ["MSG: std_msgs/Header", "MSG: builtin_interfaces/Time"]
    for ch in summary.channels.values():
        assert ch.message_encoding == "cdr"
        qos = yaml.safe_load(ch.metadata["offered_qos_profiles"])
        assert isinstance(qos, list) and qos[0]["history"] == "keep_last" and "depth" in qos[0]
        type_name = summary.schemas[ch.schema_id].name
        if type_name.startswith("naic_msgs/"):
            assert ch.metadata["topic_type_hash"].startswith("RIHS01_")
        else:
            assert ch.metadata["topic_type_hash"] == jazzy_hash(venv_share, type_name)
    # indexes and zstd chunks
    assert summary.chunk_indexes and all(ci.compression == "zstd" for ci in summary.chunk_indexes)
    assert all(ci.message_index_offsets for ci in summary.chunk_indexes)
    assert summary.statistics.message_count == len(expected)
    # the rosbag2 metadata record
    rec = [m for m in metadata if m.name == "rosbag2"]
    assert len(rec) == 1
    md = yaml.safe_load(rec[0].metadata["serialized_metadata"])
    assert md["version"] == 9 and md["storage_identifier"] == "mcap"
    assert md["message_count"] == len(expected)
    assert md["compression_format"] == "" and md["relative_file_paths"] == ["sample.mcap"]
    t0 = min(e["log_time"] for e in expected)
    t1 = max(e["log_time"] for e in expected)
    assert md["starting_time"]["nanoseconds_since_epoch"] == t0
    assert md["duration"]["nanoseconds"] == t1 - t0
    topics = {t["topic_metadata"]["name"]: t for t in md["topics_with_message_count"]}
    assert set(topics) == {"/joint_states", "/wrench", "/joint_effort_cmd", "/naic/params"}
    for t in topics.values():
        assert t["message_count"] == len(expected) // 4
        tm = t["topic_metadata"]
        assert tm["serialization_format"] == "cdr"
        assert isinstance(tm["offered_qos_profiles"], list)
        assert tm["type_description_hash"].startswith("RIHS01_")


def test_serialized_metadata_opens_in_rosbags_rosbag2_reader(sample, tmp_path):
    """rosbags' rosbag2 reader parses metadata.yaml strictly (versions, QoS, files): give it
    naic's serialized_metadata as metadata.yaml beside the bag and read every message."""
    from rosbags.rosbag2 import Reader

    bag, expected = sample
    with open(bag, "rb") as f:
        md = [m for m in mcap_reader.make_reader(f).iter_metadata() if m.name == "rosbag2"][0]
    d = tmp_path / "rosbag2_dir"
    d.mkdir()
    (d / "sample.mcap").write_bytes(bag.read_bytes())
    body = yaml.safe_load(md.metadata["serialized_metadata"])
    (d / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": body}))
    with Reader(d) as r:
        assert r.message_count == len(expected)
        qos = {c.topic: c.ext.offered_qos_profiles for c in r.connections}
        assert qos["/wrench"][0].reliability.name == "BEST_EFFORT"
        assert qos["/joint_states"][0].reliability.name == "RELIABLE"
        assert sum(1 for _ in r.messages()) == len(expected)


def test_naic_bag_info_and_export(sample, naic_bin, tmp_path):
    bag, expected = sample
    out = subprocess.run([str(naic_bin), "bag", "info", "--json", str(bag)], check=True, capture_output=True, text=True)
    info = json.loads(out.stdout)
    assert info["message_count"] == len(expected) and info["indexed"] and not info["damage"]
    for t in info["topics"]:
        assert t["count"] == len(expected) // 4
        assert math.isclose(t["rate_hz"], 1000.0, rel_tol=1e-3)
    subprocess.run([str(naic_bin), "bag", "export-csv", str(bag), "--out", str(tmp_path)], check=True, capture_output=True)
    import csv
    rows = list(csv.DictReader(open(tmp_path / "naic_params.csv")))
    want = [e for e in expected if e["topic"] == "/naic/params"]
    assert len(rows) == len(want)
    for r, w in zip(rows, want):
        assert float(r["m_d"]) == w["msg"]["m_d"] and r["mode"] == w["msg"]["mode"]
        assert int(r["log_time_ns"]) == w["log_time"]


def test_truncated_bag_repair_reads_in_other_readers(sample, naic_bin, tmp_path):
    bag, expected = sample
    data = bag.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.7)])
    bad = subprocess.run([str(naic_bin), "bag", "info", str(cut)], capture_output=True, text=True)
    assert bad.returncode == 0 and "Damage" in bad.stdout
    fixed = tmp_path / "fixed.mcap"
    subprocess.run([str(naic_bin), "bag", "repair", str(cut), str(fixed)], check=True, capture_output=True)
    got = list(mcap_ros2_reader.read_ros2_messages(str(fixed)))
    for m, want in zip(got, expected):
        assert_same(m.ros_msg, want["msg"], want["topic"])
    # what could be recovered is a prefix of what was written
    assert 0 < len(got) <= len(expected)


def test_not_mcap_is_a_usage_error(naic_bin, tmp_path):
    p = tmp_path / "x.mcap"
    p.write_text("hello")
    r = subprocess.run([str(naic_bin), "bag", "info", str(p)], capture_output=True, text=True)
    assert r.returncode == 2 and "not an MCAP bag" in r.stderr


def test_naic_reads_bags_written_by_rosbags_and_mcap_ros2(naic_bin, tmp_path):
    """The other direction: bags from rosbags' rosbag2 writer and from mcap-ros2-support's
    writer, read by naic (info counts and CSV values)."""
    import csv

    import numpy as np
    from mcap_ros2.writer import Writer as McapRos2Writer
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    WS = ts.types["geometry_msgs/msg/WrenchStamped"]
    H, T = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    W, V = ts.types["geometry_msgs/msg/Wrench"], ts.types["geometry_msgs/msg/Vector3"]
    JS = ts.types["sensor_msgs/msg/JointState"]
    n = 50
    with Writer(tmp_path / "rb", version=9, storage_plugin=StoragePlugin.MCAP) as w:
        cw = w.add_connection("/wrench", WS.__msgtype__, typestore=ts)
        cj = w.add_connection("/joint_states", JS.__msgtype__, typestore=ts)
        for i in range(n):
            m = WS(header=H(stamp=T(sec=10, nanosec=i), frame_id="ft_sensor"),
                   wrench=W(force=V(x=i * 0.5, y=-1.0, z=2.0), torque=V(x=0.0, y=0.0, z=i * 1e-3)))
            w.write(cw, 10_000 + i, ts.serialize_cdr(m, WS.__msgtype__))
            j = JS(header=H(stamp=T(sec=10, nanosec=i), frame_id=""), name=["joint1", "joint2"],
                   position=np.array([i * 0.25, -1.0]), velocity=np.array([], dtype=float), effort=np.array([1.0, 2.0]))
            w.write(cj, 10_000 + i, ts.serialize_cdr(j, JS.__msgtype__))
    rb = tmp_path / "rb" / "rb.mcap"

    # mcap-ros2-support's writer, with the schema text from the Jazzy share folder
    import sys
    share = pathlib.Path(sys.prefix) / "share"
    mr = tmp_path / "mr.mcap"
    with open(mr, "wb") as f:
        writer = McapRos2Writer(f)
        text = (share / "rosgraph_msgs/msg/Clock.msg").read_text() + "\n" + "=" * 80 + "\nMSG: builtin_interfaces/Time\n" + (share / "builtin_interfaces/msg/Time.msg").read_text()
        schema = writer.register_msgdef("rosgraph_msgs/msg/Clock", text)
        for i in range(n):
            writer.write_message("/clock", schema, {"clock": {"sec": i, "nanosec": 7}}, log_time=i, publish_time=i, sequence=i)
        writer.finish()

    for path, counts in [(rb, {"/wrench": n, "/joint_states": n}), (mr, {"/clock": n})]:
        out = subprocess.run([str(naic_bin), "bag", "info", "--json", str(path)], check=True, capture_output=True, text=True)
        info = json.loads(out.stdout)
        assert {t["topic"]: t["count"] for t in info["topics"]} == counts
        assert not info["damage"]
        d = tmp_path / ("csv_" + path.stem)
        subprocess.run([str(naic_bin), "bag", "export-csv", str(path), "--out", str(d)], check=True, capture_output=True)
        if path == rb:
            rows = list(csv.DictReader(open(d / "wrench.csv")))
            assert [float(r["force_x"]) for r in rows] == [i * 0.5 for i in range(n)]
            assert rows[3]["stamp_s"] == "10.000000003" and rows[3]["frame_id"] == "ft_sensor"
            rows = list(csv.DictReader(open(d / "joint_states.csv")))
            assert [float(r["position_joint1"]) for r in rows] == [i * 0.25 for i in range(n)]
            assert "velocity_joint1" not in rows[0]
        else:
            rows = list(csv.DictReader(open(d / "clock.csv")))
            assert [r["clock_s"] for r in rows] == [f"{i}.000000007" for i in range(n)]


def test_naic_plot_draws_the_force_tracking_figure(sample, naic_bin, root, tmp_path):
    import xml.etree.ElementTree as ET

    bag, expected = sample
    r = subprocess.run([str(naic_bin), "plot", str(bag), "--out", str(tmp_path)], cwd=root,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    svg = tmp_path / "sample.svg"
    tree = ET.parse(svg)  # well-formed
    text = " ".join(t.text or "" for t in tree.iter())
    for title in ["Contact force", "Height of frame 'tip'", "Damping b_d", "NAIC weights", "eq-15 bound", "Joint torque commands"]:
        assert title in text, title
    lines = [e for e in tree.iter() if e.tag.endswith("polyline") or e.tag.endswith("path")]
    assert len(lines) >= 10
    # a bag without naic topics is a clear usage error
    other = tmp_path / "other.mcap"
    from mcap_ros2.writer import Writer as McapRos2Writer
    with open(other, "wb") as f:
        w = McapRos2Writer(f)
        s = w.register_msgdef("std_msgs/msg/String", "string data\n")
        w.write_message("/chatter", s, {"data": "hi"}, log_time=1, publish_time=1)
        w.finish()
    r = subprocess.run([str(naic_bin), "plot", str(other), "--out", str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 2 and "/chatter" in r.stderr, r.stderr
