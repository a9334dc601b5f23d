"""An independent ROS 2 service client on the wire of rmw_cyclonedds (ROS 2's Cyclone DDS
middleware), with Eclipse Cyclone DDS (PyPI `cyclonedds`): rmw_cyclonedds is not on PyPI, so
this peer speaks its request/reply mapping itself, as rmw_cyclonedds_cpp does
(src/serdata.hpp `cdds_request_header_t`, src/rmw_node.cpp `rmw_send_request` /
`rmw_take_response`): on `rq/<service>Request` a request is the header {uint64 client id,
int64 sequence number} followed by the request's fields; the server's reply on
`rr/<service>Reply` starts with the same header, and the client takes only replies carrying
its own id. The types are declared under their ROS 2 DDS names, the reset service's fields
from msg/pbr_msgs/srv/ResetPbr.srv.

Usage: cyclone_service.py SRV_DIR --wait-s S [--node /ns/name] ACTION...
  --reset ID        call <ns>/pbr/reset               -> {"reset": ID, "success": B, "message": M}
  --list            call NODE/list_parameters         -> {"list": [NAME, ...]}
  --get NAME        call NODE/get_parameters (NAME)   -> {"get": NAME, "type": T, "double": D, "string": S}
Exit status 2 when a reply does not come within S seconds (each call waits for the server's
request reader and response writer to match first, as rmw_cyclonedds's clients do).
"""
import json
import os
import random
import sys
import time

from cyclone_common import domain_id, struct  # first: sets CYCLONEDDS_URI
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import types as t  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

HEADER = [("client_id", t.uint64), ("sequence", t.int64)]
PRIMITIVES = {"bool": bool, "string": str, "uint8": t.uint8, "int64": t.int64,
              "uint64": t.uint64, "float64": t.float64}

ParameterValue = struct("ParameterValue", "rcl_interfaces::msg::dds_::ParameterValue_", [
    ("type", t.uint8), ("bool_value", bool), ("integer_value", t.int64),
    ("double_value", t.float64), ("string_value", str),
    ("byte_array_value", t.sequence[t.uint8]), ("bool_array_value", t.sequence[bool]),
    ("integer_array_value", t.sequence[t.int64]), ("double_array_value", t.sequence[t.float64]),
    ("string_array_value", t.sequence[str]),
])
ListParametersResult = struct(
    "ListParametersResult", "rcl_interfaces::msg::dds_::ListParametersResult_",
    [("names", t.sequence[str]), ("prefixes", t.sequence[str])])


def srv_fields(path):
    """The request's and the response's (name, type) fields of a .srv file."""
    parts, fields = [], []
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line == "---":
                parts.append(fields)
                fields = []
            elif line:
                ty, name = line.split()
                fields.append((name, PRIMITIVES[ty]))
    parts.append(fields)
    return parts


class Service:
    """One service in rmw_cyclonedds's mapping: request writer, reply reader, own client id."""

    def __init__(self, dp, name, package, type_name, request_fields, reply_fields):
        qos = Qos(Policy.Reliability.Reliable(max_blocking_time=1_000_000_000),
                  Policy.Durability.Volatile, Policy.History.KeepLast(10))
        dds = "%s::srv::dds_::%s_" % (package, type_name)
        self.Request = struct(type_name + "Request", dds + "Request_", HEADER + request_fields)
        self.Reply = struct(type_name + "Reply", dds + "Response_", HEADER + reply_fields)
        self.writer = DataWriter(dp, Topic(dp, "rq%sRequest" % name, self.Request, qos=qos), qos=qos)
        self.reader = DataReader(dp, Topic(dp, "rr%sReply" % name, self.Reply, qos=qos), qos=qos)
        self.client_id = random.getrandbits(64)
        self.sequence = 0
        self.name = name

    def call(self, wait_s, **fields):
        deadline = time.monotonic() + wait_s
        while not (self.writer.get_matched_subscriptions()
                   and self.reader.get_matched_publications()):
            if time.monotonic() > deadline:
                fail("service %s never matched" % self.name)
            time.sleep(0.05)
        self.sequence += 1
        self.writer.write(self.Request(client_id=self.client_id, sequence=self.sequence, **fields))
        while time.monotonic() < deadline:
            for reply in self.reader.take(N=10):
                if reply.client_id == self.client_id and reply.sequence == self.sequence:
                    return reply
            time.sleep(0.02)
        fail("no reply from %s" % self.name)


def fail(why):
    print(json.dumps({"error": why}), flush=True)
    sys.exit(2)


def main():
    args = sys.argv[1:]
    srv_dir = args[0]
    wait_s = float(args[args.index("--wait-s") + 1])
    node = args[args.index("--node") + 1] if "--node" in args else "/rockwatch"
    namespace = node.rsplit("/", 1)[0]
    dp = DomainParticipant(domain_id())
    request_fields, reply_fields = srv_fields(os.path.join(srv_dir, "ResetPbr.srv"))
    reset = Service(dp, "%s/pbr/reset" % namespace, "pbr_msgs", "ResetPbr",
                    request_fields, reply_fields)
    listing = Service(dp, node + "/list_parameters", "rcl_interfaces", "ListParameters",
                      [("prefixes", t.sequence[str]), ("depth", t.uint64)],
                      [("result", ListParametersResult)])
    get = Service(dp, node + "/get_parameters", "rcl_interfaces", "GetParameters",
                  [("names", t.sequence[str])], [("values", t.sequence[ParameterValue])])
    i = 1
    while i < len(args):
        if args[i] == "--reset":
            r = reset.call(wait_s, pbr_id=args[i + 1])
            print(json.dumps({"reset": args[i + 1], "success": r.success, "message": r.message}),
                  flush=True)
            i += 2
        elif args[i] == "--list":
            r = listing.call(wait_s, prefixes=[], depth=0)
            print(json.dumps({"list": list(r.result.names)}), flush=True)
            i += 1
        elif args[i] == "--get":
            r = get.call(wait_s, names=[args[i + 1]])
            v = r.values[0]
            print(json.dumps({"get": args[i + 1], "type": v.type, "double": v.double_value,
                              "string": v.string_value}), flush=True)
            i += 2
        else:
            i += 1


if __name__ == "__main__":
    main()
