"""A ROS 2 peer on the GENERATED pbr_msgs Python types (a colcon build of msg/, e.g. by
launch-scripts/build-msgs.sh; the environment set up from that install) and rclpy with Fast DDS,
loopback only (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST).

It subscribes /pbr/alerts (pbr_msgs/PbrAlert; reliable, transient local, keep last 1000 like
the node's writer), waits until the node subscribes /pbr/accel, publishes there the packets of
PACKETS.json (a JSON list of {station, start_time_ns, sample_rate_hz, sequence, east, north, up})
as pbr_msgs/AccelPacket (reliable, volatile, keep all), restamped so that the record ends
now (it is sent flat out: a live node rejects data stamped ahead of its clock), waits until
the node has acknowledged them all, and prints every alert received.

Usage: rclpy_pbr_msgs.py PACKETS.json --wait-s S --quiet-s Q
Prints one JSON object per line:
  {"constants": {...}}      the generated types' constants (PbrAlert levels, PbrState modes)
  {"sent": N, "acked": B, "first_stamp_ns": T0, "end_stamp_ns": T1}
                            after publishing (T1: end of the last packet's last sample period)
  {"alert": {...}}          each alert: every field, the stamp as sec/nanosec and as ns
Exits once Q seconds pass without an alert after the acknowledgement, or after S seconds in all.
Exit status 2 if the node's subscription or alert publisher never appears.
"""
import json
import sys
import time

import rclpy
from builtin_interfaces.msg import Time
from pbr_msgs.msg import AccelPacket, PbrAlert, PbrState
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Header

NS_PER_S = 1_000_000_000


def constants(cls, names):
    return {name: getattr(cls, name) for name in names}


def alert_json(a):
    stamp_ns = a.header.stamp.sec * NS_PER_S + a.header.stamp.nanosec
    return {
        "stamp_sec": a.header.stamp.sec, "stamp_nanosec": a.header.stamp.nanosec,
        "stamp_ns": stamp_ns, "frame_id": a.header.frame_id,
        "pbr_id": a.pbr_id, "station": a.station, "level": a.level, "mode": a.mode,
        "is_overturned": a.level == PbrAlert.OVERTURNED,
        "theta_over_alpha": a.theta_over_alpha, "slide": a.slide,
        "overturn_probability": a.overturn_probability, "pga": a.pga, "pgv": a.pgv,
        "message": a.message, "direction_deg": a.direction_deg, "episode": a.episode,
        "pbr_name": a.pbr_name, "latitude_deg": a.latitude_deg,
        "longitude_deg": a.longitude_deg,
    }


def packet_msg(p, shift_ns):
    start_ns = p["start_time_ns"] + shift_ns
    return AccelPacket(
        header=Header(stamp=Time(sec=start_ns // NS_PER_S, nanosec=start_ns % NS_PER_S),
                      frame_id=p["station"]),
        sample_rate=p["sample_rate_hz"], sequence=p["sequence"],
        east=p["east"], north=p["north"], up=p["up"])


def main():
    args = sys.argv[1:]
    packets_path = args[0]
    wait_s = float(args[args.index("--wait-s") + 1])
    quiet_s = float(args[args.index("--quiet-s") + 1])
    with open(packets_path) as f:
        packets = json.load(f)
    print(json.dumps({"constants": {
        "PbrAlert": constants(PbrAlert, ["MOTION_ONSET", "OVERTURN_IMMINENT", "OVERTURNED"]),
        "PbrState": constants(PbrState, ["REST", "SLIDE", "ROCK", "SLIDE_ROCK", "OVERTURNED",
                                         "FLIGHT"]),
    }}), flush=True)

    rclpy.init()
    node = rclpy.create_node("pbr_msgs_peer")
    deadline = time.monotonic() + wait_s
    last_alert = [time.monotonic()]

    def on_alert(a):
        last_alert[0] = time.monotonic()
        print(json.dumps({"alert": alert_json(a)}), flush=True)

    alerts_qos = QoSProfile(reliability=ReliabilityPolicy.RELIABLE,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL,
                            history=HistoryPolicy.KEEP_LAST, depth=1000)
    sub = node.create_subscription(PbrAlert, "/pbr/alerts", on_alert, alerts_qos)
    accel_qos = QoSProfile(reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.VOLATILE,
                           history=HistoryPolicy.KEEP_ALL)
    pub = node.create_publisher(AccelPacket, "/pbr/accel", accel_qos)

    while pub.get_subscription_count() < 1 or sub.get_publisher_count() < 1:
        if time.monotonic() > deadline:
            print(json.dumps({"error": "the node's /pbr/accel subscription or /pbr/alerts "
                              "publisher never appeared"}), flush=True)
            sys.exit(2)
        rclpy.spin_once(node, timeout_sec=0.05)

    # Sent flat out, so stamped to END now: the whole record lies in the past, as a live
    # node requires (it rejects data stamped ahead of its clock, engine.plausibility).
    last = packets[-1]
    duration_ns = (last["start_time_ns"] - packets[0]["start_time_ns"]
                   + round(len(last["east"]) * NS_PER_S / last["sample_rate_hz"]))
    shift_ns = time.time_ns() - duration_ns - packets[0]["start_time_ns"]
    for p in packets:
        pub.publish(packet_msg(p, shift_ns))
    end_ns = packets[0]["start_time_ns"] + shift_ns + duration_ns
    acked = pub.wait_for_all_acked(Duration(seconds=max(deadline - time.monotonic(), 0.0)))
    print(json.dumps({"sent": len(packets), "acked": acked,
                      "first_stamp_ns": packets[0]["start_time_ns"] + shift_ns,
                      "end_stamp_ns": end_ns}), flush=True)

    last_alert[0] = max(last_alert[0], time.monotonic())
    while time.monotonic() < deadline and time.monotonic() - last_alert[0] < quiet_s:
        rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
