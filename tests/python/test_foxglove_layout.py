"""docs/foxglove/naic.json, the Foxglove layout of docs/nodes.md: valid JSON whose panels
read only what naic publishes: the 3D view's URDF from /robot_description in the frame of
/tf's root, and plot paths that are fields of naic_msgs/msg/NaicParams."""
import json
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]


def msg_fields():
    text = (ROOT / "msgs/naic_msgs/msg/NaicParams.msg").read_text()
    lines = [line.split("#")[0].strip() for line in text.splitlines()]
    return {line.split()[1] for line in lines if line and "=" not in line}


def test_the_foxglove_layout_reads_what_naic_publishes():
    layout = json.loads((ROOT / "docs/foxglove/naic.json").read_text())
    panels = layout["configById"]
    # Every panel the layout tree names is configured, and every configured one is shown.
    shown = set()

    def walk(node):
        if isinstance(node, str):
            shown.add(node)
        else:
            walk(node["first"])
            walk(node["second"])

    walk(layout["layout"])
    assert shown == set(panels), (shown, set(panels))
    three_d = [c for k, c in panels.items() if k.startswith("3D!")]
    assert len(three_d) == 1
    urdf = [l for l in three_d[0]["layers"].values() if l["layerId"] == "foxglove.Urdf"]
    assert urdf and urdf[0]["sourceType"] == "topic" and urdf[0]["topic"] == "/robot_description"
    assert three_d[0]["followTf"] == "base_link"  # the root of /tf (urdf/jk5.urdf)
    fields = msg_fields()
    paths = [p["value"] for k, c in panels.items() if k.startswith("Plot!") for p in c["paths"]]
    assert {"/naic/params.measured_force", "/naic/params.desired_force", "/naic/params.k_e_hat"} <= set(paths)
    for p in paths:
        topic, field = p.split(".", 1)
        assert topic == "/naic/params" and field in fields, p
