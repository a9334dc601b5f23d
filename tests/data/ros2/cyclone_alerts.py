"""An independent ROS 2 peer: Eclipse Cyclone DDS (PyPI `cyclonedds`) subscribing to
rt/pbr/alerts with the pbr_msgs/PbrAlert type built from msg/pbr_msgs/msg/PbrAlert.msg (the one source
of truth), reliable + transient local + keep last 1000 like the node's writer.

Prints one JSON object per alert received, then exits after --seconds.
Usage: cyclone_alerts.py MSG_DIR --seconds S
"""
import json
import os
import sys
import time

from cyclone_common import Header, domain_id, struct  # first: sets CYCLONEDDS_URI
from cyclonedds.core import Qos, Policy  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import types as t  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

PRIMITIVES = {
    "bool": bool, "uint8": t.uint8, "uint32": t.uint32, "uint64": t.uint64, "int32": t.int32,
    "float32": t.float32, "float64": t.float64, "string": str, "std_msgs/Header": Header,
}


def msg_type(msg_dir, name):
    fields = []
    with open(os.path.join(msg_dir, name + ".msg")) as f:
        for line in f:
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
    return struct(name, "pbr_msgs::msg::dds_::%s_" % name, fields)


def main():
    msg_dir = sys.argv[1]
    seconds = float(sys.argv[sys.argv.index("--seconds") + 1])
    PbrAlert = msg_type(msg_dir, "PbrAlert")
    dp = DomainParticipant(domain_id())
    qos = Qos(
        Policy.Reliability.Reliable(max_blocking_time=1_000_000_000),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1000),
    )
    topic = Topic(dp, "rt/pbr/alerts", PbrAlert, qos=qos)
    reader = DataReader(dp, topic, qos=qos)
    print(json.dumps({"ready": True}), flush=True)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        for a in reader.take(N=100):
            print(json.dumps({
                "pbr_id": a.pbr_id, "station": a.station, "level": a.level, "mode": a.mode,
                "frame_id": a.header.frame_id, "stamp_s": a.header.stamp.sec,
                "theta_over_alpha": a.theta_over_alpha, "message": a.message,
                "episode": a.episode,
            }), flush=True)
        time.sleep(0.02)


if __name__ == "__main__":
    main()
