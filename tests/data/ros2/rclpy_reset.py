"""A ROS 2 client of rockwatch's /pbr/reset service on the GENERATED pbr_msgs/srv/ResetPbr
Python type (a colcon build of msg/, e.g. by launch-scripts/build-msgs.sh; the environment set
up from that install) and rclpy with Fast DDS, loopback only
(ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST).

Usage: rclpy_reset.py ID [ID ...] --wait-s S
Waits (up to S seconds) for the service, then asks for the reset of each ID in turn, waiting up
to S seconds for each response. Prints one JSON object per line:
  {"fields": {"request": {...}, "response": {...}}}   the generated types' fields and types
  {"pbr_id": ID, "success": B, "message": M}           each response
Exit status 2 if the service never appears, 3 if a response does not come in time.
"""
import json
import sys

import rclpy
from pbr_msgs.srv import ResetPbr


def main():
    args = sys.argv[1:]
    at = args.index("--wait-s")
    wait_s = float(args[at + 1])
    ids = args[:at] + args[at + 2:]
    print(json.dumps({"fields": {
        "request": ResetPbr.Request.get_fields_and_field_types(),
        "response": ResetPbr.Response.get_fields_and_field_types(),
    }}), flush=True)

    rclpy.init()
    node = rclpy.create_node("pbr_reset_peer")
    client = node.create_client(ResetPbr, "/pbr/reset")
    if not client.wait_for_service(timeout_sec=wait_s):
        print(json.dumps({"error": "/pbr/reset never appeared"}), flush=True)
        sys.exit(2)
    for pbr_id in ids:
        future = client.call_async(ResetPbr.Request(pbr_id=pbr_id))
        rclpy.spin_until_future_complete(node, future, timeout_sec=wait_s)
        if not future.done() or future.result() is None:
            print(json.dumps({"error": f"no response for {pbr_id}"}), flush=True)
            sys.exit(3)
        r = future.result()
        print(json.dumps({"pbr_id": pbr_id, "success": r.success, "message": r.message}),
              flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
