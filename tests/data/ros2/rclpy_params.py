"""A real ROS 2 peer: rclpy with Fast DDS from PyPI (`ros-rclpy[fastrtps]`), loopback only
(ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST). Waits for the node NODE (default /rockwatch) in the
node graph, then reads, describes and sets its parameters through the standard services
(NODE/get_parameters, NODE/describe_parameters, NODE/set_parameters), as `ros2 param` does.

Usage: rclpy_params.py --wait-s S [--node /ns/name] [--events] [--writers TOPIC]...
                       [--get NAME]... [--describe NAME]... [--set NAME=VALUE]...
VALUE is a double if it parses as one, else a string. Actions run in command-line order;
prints one JSON object per line:
  {"graph": [[name, namespace], ...]}            the graph once NODE is in it
  {"get": NAME, "type": T, "value": V}           after each --get (V: double or string value)
  {"describe": NAME, "type": T, "description": D, "additional_constraints": C,
   "read_only": B, "floating_point_range": [[from, to, step], ...]}   after each --describe
  {"set": NAME, "value": V, "successful": B, "reason": R}   after each --set
  {"writers": TOPIC, "of_node": [{"durability": D, "reliability": R, "depth": N}, ...]}
      after each --writers: NODE's writers of TOPIC in the graph (once one is seen, 2 s more
      for others to be discovered)
  {"event": {"node": N, "changed": [[NAME, DOUBLE], ...]}}   with --events: each
      /parameter_events message of NODE received by 3 s after the last action
Exit status 2 if NODE never appears or a service call times out.
"""
import json
import sys
import time

import rclpy
from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterType, ParameterValue
from rclpy.qos import qos_profile_parameter_events
from rcl_interfaces.srv import DescribeParameters, GetParameters, SetParameters


def call(node, client, request, timeout_s):
    if not client.wait_for_service(timeout_sec=timeout_s):
        print(json.dumps({"error": "service %s not available" % client.srv_name}), flush=True)
        sys.exit(2)
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=timeout_s)
    if not future.done():
        print(json.dumps({"error": "no reply from %s" % client.srv_name}), flush=True)
        sys.exit(2)
    return future.result()


def value_of(text):
    try:
        return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(text))
    except ValueError:
        return ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=text)


def main():
    args = sys.argv[1:]
    wait_s = float(args[args.index("--wait-s") + 1])
    fqn = args[args.index("--node") + 1] if "--node" in args else "/rockwatch"
    namespace, name = fqn.rsplit("/", 1)
    namespace = namespace or "/"
    rclpy.init()
    node = rclpy.create_node("rockwatch_param_peer")
    deadline = time.monotonic() + wait_s
    while True:
        names = node.get_node_names_and_namespaces()
        if (name, namespace) in names:
            break
        if time.monotonic() > deadline:
            print(json.dumps({"error": "no %s in the graph" % fqn, "graph": names}), flush=True)
            sys.exit(2)
        rclpy.spin_once(node, timeout_sec=0.1)
    print(json.dumps({"graph": sorted(names)}), flush=True)
    events = []
    if "--events" in args:
        node.create_subscription(
            ParameterEvent, "/parameter_events",
            lambda m: events.append(m) if m.node == fqn else None, qos_profile_parameter_events)
    get = node.create_client(GetParameters, fqn + "/get_parameters")
    put = node.create_client(SetParameters, fqn + "/set_parameters")
    describe = node.create_client(DescribeParameters, fqn + "/describe_parameters")
    i = 0
    while i < len(args):
        if args[i] == "--get":
            pname = args[i + 1]
            reply = call(node, get, GetParameters.Request(names=[pname]), wait_s)
            v = reply.values[0] if reply.values else ParameterValue()
            value = v.string_value if v.type == ParameterType.PARAMETER_STRING else v.double_value
            print(json.dumps({"get": pname, "type": v.type, "value": value}), flush=True)
            i += 2
        elif args[i] == "--describe":
            pname = args[i + 1]
            reply = call(node, describe, DescribeParameters.Request(names=[pname]), wait_s)
            d = reply.descriptors[0]
            print(json.dumps({
                "describe": pname, "type": d.type, "description": d.description,
                "additional_constraints": d.additional_constraints, "read_only": d.read_only,
                "floating_point_range": [[r.from_value, r.to_value, r.step]
                                         for r in d.floating_point_range],
            }), flush=True)
            i += 2
        elif args[i] == "--writers":
            topic = args[i + 1]

            def of_node():
                return [w for w in node.get_publishers_info_by_topic(topic)
                        if (w.node_name, w.node_namespace) == (name, namespace)]
            end = time.monotonic() + wait_s
            while not of_node() and time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.1)
            end = time.monotonic() + 2.0
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.1)
            print(json.dumps({"writers": topic, "of_node": [{
                "durability": w.qos_profile.durability.name,
                "reliability": w.qos_profile.reliability.name,
                "depth": w.qos_profile.depth,
            } for w in of_node()]}), flush=True)
            i += 2
        elif args[i] == "--set":
            pname, text = args[i + 1].split("=", 1)
            p = Parameter(name=pname, value=value_of(text))
            reply = call(node, put, SetParameters.Request(parameters=[p]), wait_s)
            r = reply.results[0]
            print(json.dumps({"set": pname, "value": text,
                              "successful": r.successful, "reason": r.reason}), flush=True)
            i += 2
        else:
            i += 1
    if "--events" in args:
        end = time.monotonic() + 3.0
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.1)
        for m in events:
            print(json.dumps({"event": {"node": m.node, "changed": [
                [p.name, p.value.double_value] for p in m.changed_parameters]}}), flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
