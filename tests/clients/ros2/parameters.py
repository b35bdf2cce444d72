"""ROS 2 parameter client (zenoh-ros2-sdk, rmw_zenoh wire format) for
Radar's tests: reads and sets a node's parameters through rcl_interfaces'
parameter services, as `ros2 param` does.

    parameters.py --port P --node /NAME [--set NAME=INT] [--timeout S]

Connects to the Zenoh peer at tcp/127.0.0.1:P, waits for the node's
list_parameters server in the graph, then lists the parameters, gets
their values and types, describes the first, sets NAME to the integer
INT, gets NAME again, and tries to set it to the text "fast" (another
type). Prints one JSON line: {"names", "prefixes", "values", "types",
"read_only", "set", "after", "wrong"}. Exits 0, or 1 at the timeout.
"""

import argparse
import json
import pathlib
import sys
import time

import messages
import numpy
import ros2_common as rc
from rosbags.typesys import get_types_from_msg
from zenoh_ros2_sdk import ROS2ServiceClient
from zenoh_ros2_sdk.discovery import get_service_info

VALUE_FIELDS = {1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value",
                5: "byte_array_value", 6: "bool_array_value", 7: "integer_array_value",
                8: "double_array_value", 9: "string_array_value"}


# Each service: its request and response as zenoh-ros2-sdk reads them (the
# nested types named in full: the SDK looks a .srv's relative names up in
# the wrong package), and the type hash rosidl gives it (rcl_interfaces'
# .json files; the SDK's own leaves out that ParameterDescriptor has default
# values, and its key would match no server).
SERVICES = {
    "ListParameters": ("string[] prefixes\nuint64 depth\n",
                       "rcl_interfaces/ListParametersResult result\n",
                       "RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d"),
    "GetParameters": ("string[] names\n", "rcl_interfaces/ParameterValue[] values\n",
                      "RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc"),
    "GetParameterTypes": ("string[] names\n", "uint8[] types\n",
                          "RIHS01_da199c878688b3e530bdfe3ca8f74cb9fa0c303101e980a9e8f260e25e1c80ca"),
    "DescribeParameters": ("string[] names\n",
                           "rcl_interfaces/ParameterDescriptor[] descriptors\n",
                           "RIHS01_845b484d71eb0673dae682f2e3ba3c4851a65a3dcfb97bddd82c5b57e91e4cff"),
    "SetParameters": ("rcl_interfaces/Parameter[] parameters\n",
                      "rcl_interfaces/SetParametersResult[] results\n",
                      "RIHS01_56eed9a67e169f9cb6c1f987bc88f868c14a8fc9f743a263bc734c154015d7e0"),
}
NESTED = ("FloatingPointRange", "IntegerRange", "ListParametersResult", "Parameter",
          "ParameterDescriptor", "ParameterValue", "SetParametersResult")


def register_nested(store):
    """The SDK's type store learns rcl_interfaces' messages the services
    carry (it reads a reply with them, but does not load them itself)."""
    root = pathlib.Path(messages.__file__).parent / "rcl_interfaces" / "msg"
    for name in NESTED:
        text = (root / f"{name}.msg").read_text()
        store.register(get_types_from_msg(text, f"rcl_interfaces/msg/{name}"))


def plain(value):
    """A ParameterValue as plain JSON: its one value, or null when unset."""
    field = VALUE_FIELDS.get(int(value.type))
    if field is None:
        return None
    v = getattr(value, field)
    return v.tolist() if isinstance(v, numpy.ndarray) else v


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--node", required=True)
    parser.add_argument("--set", required=True)
    parser.add_argument("--timeout", type=float, default=20.0)
    args = parser.parse_args()
    rc.timeout(args.timeout, lambda: "timeout")

    def client(service, ty):
        request, response, type_hash = SERVICES[ty]
        made = ROS2ServiceClient(
            f"{args.node}/{service}", f"rcl_interfaces/srv/{ty}",
            request_definition=request, response_definition=response, type_hash=type_hash,
            node_name="param_client", router_ip="127.0.0.1", router_port=args.port,
            timeout=5.0,
        )
        register_nested(made.session_mgr.store)
        return made

    while True:
        info = get_service_info(f"{args.node}/list_parameters", router_ip="127.0.0.1",
                                router_port=args.port)
        if info is not None and info.server_count > 0:
            break
        time.sleep(0.2)
    report = {}
    listed = client("list_parameters", "ListParameters").call(prefixes=[], depth=0)
    names = list(listed.result.names)
    report["names"], report["prefixes"] = names, list(listed.result.prefixes)
    got = client("get_parameters", "GetParameters").call(names=names)
    report["values"] = {n: plain(v) for n, v in zip(names, got.values)}
    types = client("get_parameter_types", "GetParameterTypes").call(names=names)
    report["types"] = {n: int(t) for n, t in zip(names, types.types)}
    described = client("describe_parameters", "DescribeParameters").call(names=names[:1])
    report["read_only"] = bool(described.descriptors[0].read_only)
    setter = client("set_parameters", "SetParameters")
    types = setter.session_mgr.store.types
    name, number = args.set.split("=")
    empty = dict(byte_array_value=numpy.array([], dtype=numpy.uint8),
                 bool_array_value=numpy.array([], dtype=bool),
                 integer_array_value=numpy.array([], dtype=numpy.int64),
                 double_array_value=numpy.array([], dtype=numpy.float64),
                 string_array_value=[])

    def set_one(**value):
        fields = dict(type=2, bool_value=False, integer_value=0, double_value=0.0,
                      string_value="", **empty)
        fields.update(value)
        value = types["rcl_interfaces/msg/ParameterValue"](**fields)
        parameter = types["rcl_interfaces/msg/Parameter"](name=name, value=value)
        results = setter.call(parameters=[parameter]).results
        return [{"successful": bool(r.successful), "reason": str(r.reason)} for r in results]

    report["set"] = set_one(type=2, integer_value=int(number))
    again = client("get_parameters", "GetParameters").call(names=[name])
    report["after"] = plain(again.values[0])
    report["wrong"] = set_one(type=4, string_value="fast")
    print(json.dumps(report), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
