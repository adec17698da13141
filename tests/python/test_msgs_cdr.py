"""naic_msgs (msgs/rust) against ROS 2 Jazzy itself: RIHS01 type hashes equal the ones the
Jazzy wheels ship (and, for NaicParams, the one rosidl computes from the .msg); CDR bytes equal
rclpy's `serialize_message` (apart from padding bytes, which rclpy leaves uninitialised, and
the trailing slack of its size estimate) and mcap-ros2-support's encoder byte for byte; rclpy
deserializes naic's bytes back to the same message."""
import json
import pathlib
import subprocess
import sys
import tempfile

import pytest

rclpy_serialization = pytest.importorskip("rclpy.serialization")
from builtin_interfaces.msg import Time  # noqa: E402
from geometry_msgs.msg import Vector3, Wrench, WrenchStamped  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray, Header, MultiArrayDimension, MultiArrayLayout  # noqa: E402

SHARE = pathlib.Path(sys.prefix) / "share"


def cargo_example(root, name, stdin=None):
    out = subprocess.run(
        ["cargo", "run", "--release", "-q", "-p", "naic_msgs", "--example", name],
        cwd=root, input=stdin, capture_output=True, text=True, check=True,
    )
    return out.stdout


@pytest.fixture(scope="module")
def naic_hashes(root):
    return dict(line.split("\t") for line in cargo_example(root, "type_hashes").splitlines())


def test_type_hashes_equal_jazzy(naic_hashes):
    checked = 0
    for type_name, h in naic_hashes.items():
        pkg, _, name = type_name.split("/")
        f = SHARE / pkg / "msg" / f"{name}.json"
        if pkg in ("naic_msgs", "tf2_msgs"):
            continue  # no wheel ships them: rosidl's pipeline below
        assert f.exists(), f"{f} missing: are the ros-jazzy message wheels installed?"
        want = json.loads(f.read_text())["type_hashes"][0]["hash_string"]
        assert h == want, type_name
        checked += 1
    assert checked == 16


def rosidl_hash(pkg, name, msg_text, dep):
    """rosidl's own pipeline: .msg -> .idl (rosidl_adapter) -> parse (rosidl_parser) ->
    type description and hash (rosidl_generator_type_description); `dep` (pkg, Type) is the
    one nested type, whose description comes from the Jazzy wheel's .json."""
    from rosidl_adapter.msg import convert_msg_to_idl
    from rosidl_parser.definition import IdlLocator, Message
    from rosidl_parser.parser import parse_idl_file
    import rosidl_generator_type_description as g

    with tempfile.TemporaryDirectory() as d:
        d = pathlib.Path(d)
        (d / "msg").mkdir()
        (d / "msg" / f"{name}.msg").write_text(msg_text)
        convert_msg_to_idl(d, pkg, pathlib.Path("msg") / f"{name}.msg", d / "out")
        idl = parse_idl_file(IdlLocator(d / "out", pathlib.Path(f"{name}.idl")))
    m = [e for e in idl.content.elements if isinstance(e, Message)][0]
    td = g.serialize_individual_type_description(m.structure.namespaced_type, m.structure.members)
    nested = json.loads((SHARE / dep[0] / "msg" / f"{dep[1]}.json").read_text())["type_description_msg"]
    refs = [nested["type_description"]] + nested["referenced_type_descriptions"]
    full = {"type_description": td, "referenced_type_descriptions": sorted(refs, key=lambda t: t["type_name"])}
    return g.calculate_type_hash(full)


def test_naic_params_hash_equals_rosidl(naic_hashes, root):
    msg = root / "msgs" / "naic_msgs" / "msg" / "NaicParams.msg"
    want = rosidl_hash("naic_msgs", "NaicParams", msg.read_text(), ("std_msgs", "Header"))
    assert naic_hashes["naic_msgs/msg/NaicParams"] == want


def test_tf_message_hash_equals_rosidl(naic_hashes):
    """tf2_msgs/msg/TFMessage (/tf, /tf_static): no PyPI wheel ships tf2_msgs, so its
    upstream one-line definition goes through rosidl's pipeline."""
    want = rosidl_hash("tf2_msgs", "TFMessage", "geometry_msgs/TransformStamped[] transforms\n",
                       ("geometry_msgs", "TransformStamped"))
    assert naic_hashes["tf2_msgs/msg/TFMessage"] == want


def to_dict(msg):
    if hasattr(msg, "get_fields_and_field_types"):
        return {k: to_dict(getattr(msg, k)) for k in msg.get_fields_and_field_types()}
    if isinstance(msg, (list, tuple)) or type(msg).__name__ == "array":
        return [to_dict(x) for x in msg]
    return msg


def samples():
    h = Header(stamp=Time(sec=1700000000, nanosec=123456789), frame_id="ft_sensor")
    return [
        Time(sec=-5, nanosec=999999999),
        Header(),
        h,
        JointState(header=h, name=[f"joint{i}" for i in range(1, 7)], position=[0.1 * i for i in range(6)],
                   velocity=[], effort=[-1.5, 2.25, 1e-300, -0.0, 3e300, 7.0]),
        JointState(),
        JointState(name=["a"], position=[1.0]),
        WrenchStamped(header=h, wrench=Wrench(force=Vector3(x=1.0, y=-2.0, z=3.5), torque=Vector3(z=0.25))),
        Float64MultiArray(),
        Float64MultiArray(layout=MultiArrayLayout(dim=[MultiArrayDimension(label="joints", size=6, stride=6),
                                                        MultiArrayDimension(label="", size=1, stride=1)],
                                                   data_offset=3),
                          data=[float(i) for i in range(6)]),
        MultiArrayDimension(label="x", size=2, stride=3),
        Clock(clock=Time(sec=42, nanosec=7)),
    ]


def type_name(msg):
    mod = type(msg).__module__.split(".")[0]
    return f"{mod}/msg/{type(msg).__name__}"


def test_cdr_matches_rclpy(root):
    msgs = samples()
    lines = "".join(f"{type_name(m)}\t{json.dumps(to_dict(m))}\n" for m in msgs)
    ours = [bytes.fromhex(h) for h in cargo_example(root, "cdr_from_json", lines).splitlines()]
    assert len(ours) == len(msgs)
    for m, b in zip(msgs, ours):
        ref = rclpy_serialization.serialize_message(m)
        assert b[:4] == b"\x00\x01\x00\x00"
        # rclpy's buffer can be longer (its size estimate pads empty sequences); the content
        # is the prefix, and only alignment padding bytes (zero in ours) may differ.
        assert len(ref) >= len(b), type_name(m)
        diff = [i for i in range(len(b)) if b[i] != ref[i]]
        assert all(b[i] == 0 for i in diff), (type_name(m), diff)
        assert len(diff) <= 7 * len(b) // 8
        # rclpy decodes our bytes to the same message
        back = rclpy_serialization.deserialize_message(b, type(m))
        assert back == m, type_name(m)


def test_cdr_matches_mcap_ros2_encoder_exactly(root, naic_bin, tmp_path):
    """mcap-ros2-support's pure-Python CDR writer (zero padding) gives identical bytes,
    including for NaicParams, using the schema naic stores in its bags."""
    from mcap.reader import make_reader
    from mcap_ros2._dynamic import serialize_dynamic

    bag = tmp_path / "s.mcap"
    subprocess.run([str(naic_bin), "bag", "write-sample", str(bag), "--seconds", "0.01"], check=True, capture_output=True)
    with open(bag, "rb") as f:
        r = make_reader(f)
        schemas = {s.name: s.data.decode() for s in r.get_summary().schemas.values()}
        raw = [(r2.name, m.data) for r2, _, m in r.iter_messages()]
    from mcap_ros2.decoder import DecoderFactory
    dec = DecoderFactory()
    with open(bag, "rb") as f:
        decoded = [(s.name, msg) for s, _, _, msg in make_reader(f, decoder_factories=[dec]).iter_decoded_messages()]
    assert "naic_msgs/msg/NaicParams" in schemas
    for (name, data), (_, msg) in zip(raw, decoded):
        enc = serialize_dynamic(name, schemas[name])[name]
        assert enc(msg) == data, name
