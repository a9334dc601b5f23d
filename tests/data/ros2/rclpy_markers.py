"""An independent ROS 2 peer of the node's 3-D view: rclpy with Fast DDS (PyPI wheels) and the
message definitions of visualization_msgs (PyPI `ros-visualization-msgs`), loopback only.
Subscribes TOPIC (visualization_msgs/msg/MarkerArray) reliable + transient local + keep last 1,
as RViz does for a latched marker topic, for --seconds S (or until --until-fallen ID: an array
in which rock ID's body is red), and prints one JSON object per array received:
  {"markers": [{"ns", "id", "type", "action", "frame_id", "stamp": ns, "position": [x, y, z],
                "orientation": [x, y, z, w], "scale": [x, y, z], "color": [r, g, b, a],
                "points": n, "bbox": [[min x, y, z], [max x, y, z]], "text"}, ...]}
Usage: rclpy_markers.py TOPIC --seconds S [--until-fallen ID]
"""
import json
import sys
import time

import rclpy
import rclpy.executors
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from visualization_msgs.msg import Marker, MarkerArray


def describe(m):
    pts = [(p.x, p.y, p.z) for p in m.points]
    bbox = None
    if pts:
        bbox = [[min(p[k] for p in pts) for k in range(3)], [max(p[k] for p in pts) for k in range(3)]]
    return {
        "ns": m.ns, "id": m.id, "type": m.type, "action": m.action,
        "frame_id": m.header.frame_id,
        "stamp": m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec,
        "position": [m.pose.position.x, m.pose.position.y, m.pose.position.z],
        "orientation": [m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z,
                        m.pose.orientation.w],
        "scale": [m.scale.x, m.scale.y, m.scale.z],
        "color": [m.color.r, m.color.g, m.color.b, m.color.a],
        "points": len(pts), "bbox": bbox, "text": m.text,
    }


def main():
    topic = sys.argv[1]
    seconds = float(sys.argv[sys.argv.index("--seconds") + 1])
    until = sys.argv[sys.argv.index("--until-fallen") + 1] if "--until-fallen" in sys.argv else None
    rclpy.init()
    node = rclpy.create_node("rockwatch_markers_peer")
    qos = QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
        history=HistoryPolicy.KEEP_LAST,
        depth=1,
    )
    done = []

    def on_markers(array):
        described = [describe(m) for m in array.markers]
        print(json.dumps({"markers": described}), flush=True)
        labels = {(d["id"]) for d in described if d["ns"] == "pbr_label" and d["text"] == until}
        for d in described:
            if until and d["ns"] == "pbr" and d["id"] in labels and d["color"][0] > 0.8 \
                    and d["color"][1] < 0.2:
                done.append(True)

    node.create_subscription(MarkerArray, topic, on_markers, qos)
    assert Marker.TRIANGLE_LIST == 11 and Marker.TEXT_VIEW_FACING == 9
    executor = rclpy.executors.SingleThreadedExecutor()
    executor.add_node(node)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not done:
        executor.spin_once(timeout_sec=0.1)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
