"""An independent peer of the node's frames: Eclipse Cyclone DDS (PyPI `cyclonedds`) with
tf2_msgs/TFMessage declared here from its definition (tf2_msgs is not on PyPI):
  tf2_msgs/TFMessage: geometry_msgs/TransformStamped[] transforms
  geometry_msgs/TransformStamped: std_msgs/Header header, string child_frame_id,
                                  geometry_msgs/Transform transform
  geometry_msgs/Transform: Vector3 translation, Quaternion rotation (float64 each)
subscribing rt/tf_static reliable + transient local + keep last 1 (tf2's static listener), and
STATE_TOPIC (pbr_msgs/PbrState, built from MSG_DIR/PbrState.msg) reliable + volatile.
Prints one JSON object per message: {"tf": [{"parent", "child", "stamp": ns, "translation":
[x, y, z], "rotation": [x, y, z, w]}]} or {"state": {"pbr_id", "frame_id", "station", "mode",
"theta", "slide", "direction_deg", "not_monitored"}}; exits after --seconds.
Usage: cyclone_frames.py MSG_DIR STATE_TOPIC --seconds S
"""
import json
import sys
import time

from cyclone_common import Header, domain_id, struct  # first: sets CYCLONEDDS_URI
from cyclone_alerts import msg_type  # noqa: E402
from cyclonedds.core import Qos, Policy  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import types as t  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

Vector3 = struct("Vector3", "geometry_msgs::msg::dds_::Vector3_",
                 [("x", t.float64), ("y", t.float64), ("z", t.float64)])
Quaternion = struct("Quaternion", "geometry_msgs::msg::dds_::Quaternion_",
                    [("x", t.float64), ("y", t.float64), ("z", t.float64), ("w", t.float64)])
Transform = struct("Transform", "geometry_msgs::msg::dds_::Transform_",
                   [("translation", Vector3), ("rotation", Quaternion)])
TransformStamped = struct("TransformStamped", "geometry_msgs::msg::dds_::TransformStamped_",
                          [("header", Header), ("child_frame_id", str), ("transform", Transform)])
TFMessage = struct("TFMessage", "tf2_msgs::msg::dds_::TFMessage_",
                   [("transforms", t.sequence[TransformStamped])])


def main():
    msg_dir, state_topic = sys.argv[1], sys.argv[2]
    seconds = float(sys.argv[sys.argv.index("--seconds") + 1])
    PbrState = msg_type(msg_dir, "PbrState")
    dp = DomainParticipant(domain_id())
    latched = Qos(
        Policy.Reliability.Reliable(max_blocking_time=1_000_000_000),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1),
    )
    tf_reader = DataReader(dp, Topic(dp, "rt/tf_static", TFMessage, qos=latched), qos=latched)
    volatile = Qos(
        Policy.Reliability.Reliable(max_blocking_time=1_000_000_000),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(1000),
    )
    state_reader = DataReader(dp, Topic(dp, "rt" + state_topic, PbrState, qos=volatile),
                              qos=volatile)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        for m in tf_reader.take(N=10):
            print(json.dumps({"tf": [{
                "parent": x.header.frame_id, "child": x.child_frame_id,
                "stamp": x.header.stamp.sec * 1_000_000_000 + x.header.stamp.nanosec,
                "translation": [x.transform.translation.x, x.transform.translation.y,
                                x.transform.translation.z],
                "rotation": [x.transform.rotation.x, x.transform.rotation.y,
                             x.transform.rotation.z, x.transform.rotation.w],
            } for x in m.transforms]}), flush=True)
        for s in state_reader.take(N=100):
            print(json.dumps({"state": {
                "pbr_id": s.pbr_id, "frame_id": s.header.frame_id, "station": s.station,
                "mode": s.mode, "theta": s.theta, "slide": s.slide,
                "direction_deg": s.direction_deg, "not_monitored": s.not_monitored,
            }}), flush=True)
        time.sleep(0.02)


if __name__ == "__main__":
    main()
