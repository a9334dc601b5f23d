"""Shared by the Cyclone DDS test peers (cyclone_alerts.py, cyclone_imu.py): the loopback-only
Cyclone configuration and the ROS 2 types every message needs, declared as Cyclone IDL structs
under their ROS 2 DDS type names (`<package>::msg::dds_::<Type>_`).

Import it before `cyclonedds.domain` is used: it sets CYCLONEDDS_URI (unless already set).
"""
import dataclasses
import os
import types

# Loopback only, unicast discovery of same-host peers (lo has no multicast in a netns).
os.environ.setdefault(
    "CYCLONEDDS_URI",
    "<CycloneDDS><Domain><General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>"
    "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>",
)

from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl import types as t  # noqa: E402


def struct(name, typename, fields):
    """A Cyclone IDL struct `name` with (field, type) in order."""
    def body(ns):
        ns["__annotations__"] = dict(fields)
    cls = types.new_class(name, (IdlStruct,), {"typename": typename}, body)
    return dataclasses.dataclass(cls)


Time = struct("Time", "builtin_interfaces::msg::dds_::Time_", [("sec", t.int32), ("nanosec", t.uint32)])
Header = struct("Header", "std_msgs::msg::dds_::Header_", [("stamp", Time), ("frame_id", str)])


def domain_id():
    return int(os.environ.get("ROS_DOMAIN_ID", "0"))
