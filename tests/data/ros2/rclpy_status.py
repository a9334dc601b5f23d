"""An independent ROS 2 peer of the node's status: rclpy with Fast DDS (PyPI wheels) and the
message definitions of diagnostic_msgs, rcl_interfaces and pbr_msgs (the colcon build of
msg/), loopback only. Subscribes /diagnostics (diagnostic_msgs/msg/DiagnosticArray), /rosout
(rcl_interfaces/msg/Log) and /pbr/state (pbr_msgs/msg/PbrState) for --seconds S, and prints
one JSON object per line per message received (with --diagnostics-only, /diagnostics alone:
then neither rcl_interfaces nor the pbr_msgs build is needed, as for `rockwatch acquire`'s
status in tests/acquire_faults.rs):
  {"diagnostics": [{"level", "name", "message", "hardware_id", "values": {k: v}}, ...],
   "stamp": ns}
  {"rosout": {"level", "name", "msg", "function"}}
  {"state": {"pbr_id", "station", "mode", "not_monitored", "stamp": ns}}
"""
import json
import sys
import time

import rclpy
import rclpy.executors
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from diagnostic_msgs.msg import DiagnosticArray


def stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def main():
    seconds = float(sys.argv[sys.argv.index("--seconds") + 1])
    diagnostics_only = "--diagnostics-only" in sys.argv
    rclpy.init()
    node = rclpy.create_node("rockwatch_status_peer")
    qos = QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST,
        depth=100,
    )

    def on_diagnostics(m):
        print(json.dumps({
            "stamp": stamp_ns(m.header),
            "diagnostics": [
                {
                    "level": int.from_bytes(s.level, "little") if isinstance(s.level, bytes) else int(s.level),
                    "name": s.name,
                    "message": s.message,
                    "hardware_id": s.hardware_id,
                    "values": {kv.key: kv.value for kv in s.values},
                }
                for s in m.status
            ],
        }), flush=True)

    def on_rosout(m):
        print(json.dumps({"rosout": {"level": int(m.level), "name": m.name, "msg": m.msg,
                                     "function": m.function}}), flush=True)

    def on_state(m):
        print(json.dumps({"state": {"pbr_id": m.pbr_id, "station": m.station, "mode": int(m.mode),
                                    "not_monitored": bool(m.not_monitored),
                                    "stamp": stamp_ns(m.header)}}), flush=True)

    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, qos)
    if not diagnostics_only:
        from rcl_interfaces.msg import Log
        from pbr_msgs.msg import PbrState
        node.create_subscription(Log, "/rosout", on_rosout, qos)
        node.create_subscription(PbrState, "/pbr/state", on_state, qos)
    print(json.dumps({"ready": True}), flush=True)
    deadline = time.monotonic() + seconds
    try:
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        return  # stopped by the test (SIGINT/SIGTERM): what was received is printed
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
