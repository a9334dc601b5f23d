"""A real ROS 2 peer: rclpy with Fast DDS from PyPI (`ros-rclpy[fastrtps]`), loopback only
(ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST). Waits for /rockwatch in the node graph, then reads
and sets its parameters through the standard services
(/rockwatch/get_parameters, /rockwatch/set_parameters).

Usage: rclpy_params.py --wait-s S [--get NAME]... [--set NAME=FLOAT]...
Actions run in command-line order; prints one JSON object per line:
  {"graph": [[name, namespace], ...]}            the graph once /rockwatch is in it
  {"get": NAME, "type": T, "value": V}           after each --get
  {"set": NAME, "value": V, "successful": B, "reason": R}   after each --set
Exit status 2 if /rockwatch never appears or a service call times out.
"""
import json
import sys
import time

import rclpy
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters


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


def main():
    args = sys.argv[1:]
    wait_s = float(args[args.index("--wait-s") + 1])
    rclpy.init()
    node = rclpy.create_node("rockwatch_param_peer")
    deadline = time.monotonic() + wait_s
    while True:
        names = node.get_node_names_and_namespaces()
        if ("rockwatch", "/") in names:
            break
        if time.monotonic() > deadline:
            print(json.dumps({"error": "no /rockwatch in the graph", "graph": names}), flush=True)
            sys.exit(2)
        rclpy.spin_once(node, timeout_sec=0.1)
    print(json.dumps({"graph": sorted(names)}), flush=True)
    get = node.create_client(GetParameters, "/rockwatch/get_parameters")
    put = node.create_client(SetParameters, "/rockwatch/set_parameters")
    i = 0
    while i < len(args):
        if args[i] == "--get":
            name = args[i + 1]
            reply = call(node, get, GetParameters.Request(names=[name]), wait_s)
            v = reply.values[0] if reply.values else ParameterValue()
            print(json.dumps({"get": name, "type": v.type, "value": v.double_value}), flush=True)
            i += 2
        elif args[i] == "--set":
            name, value = args[i + 1].split("=", 1)
            p = Parameter(name=name, value=ParameterValue(
                type=ParameterType.PARAMETER_DOUBLE, double_value=float(value)))
            reply = call(node, put, SetParameters.Request(parameters=[p]), wait_s)
            r = reply.results[0]
            print(json.dumps({"set": name, "value": float(value),
                              "successful": r.successful, "reason": r.reason}), flush=True)
            i += 2
        else:
            i += 1
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
