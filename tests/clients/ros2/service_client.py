"""ROS 2 service client (zenoh-ros2-sdk, rmw_zenoh wire format) for Radar's
tests: calls std_srvs/srv/SetBool at a service name.

    service_client.py --port P [--service /radar/grip] [--timeout S]
                      [--domain D] [--together] DATA...

Connects to the Zenoh peer at tcp/127.0.0.1:P, makes a ROS 2 client of
SetBool (the SDK computes the service's type hash itself) and, once the
service's server shows in the graph (printed: its node and type, one
JSON line), calls it once per DATA (`true` or
`false`), one after the other; with --together, then two calls at once
(true, then false 0.1 s later). Prints one JSON line per call: the
request's data and the reply as Radar JSON, or null when none came within
the call's timeout (2 s). Exits 0, or 1 at the timeout.
"""

import argparse
import json
import sys
import threading
import time

import ros2_common as rc
from zenoh_ros2_sdk import ROS2ServiceClient
from zenoh_ros2_sdk.discovery import get_service_info


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--service", default="/radar/grip")
    parser.add_argument("--timeout", type=float, default=20.0)
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--together", action="store_true")
    parser.add_argument("data", nargs="+", choices=["true", "false"])
    args = parser.parse_args()
    rc.timeout(args.timeout, lambda: "timeout")

    client = ROS2ServiceClient(
        args.service,
        "std_srvs/srv/SetBool",
        request_definition="bool data\n",
        response_definition="bool success\nstring message\n",
        node_name="gripper_client",
        domain_id=args.domain,
        router_ip="127.0.0.1",
        router_port=args.port,
        timeout=2.0,
    )
    # The server's token, as ROS 2's graph shows it: its node and type.
    while True:
        info = get_service_info(
            args.service,
            domain_id=args.domain,
            router_ip="127.0.0.1",
            router_port=args.port,
            verbose=True,
        )
        if info is not None and info.server_count > 0:
            server = info.servers[0]
            print(
                json.dumps({"server": f"{server.node_namespace.rstrip('/')}/{server.node_name}",
                            "type": server.service_type}),
                flush=True,
            )
            break
        time.sleep(0.2)
    def show(data, reply):
        print(
            json.dumps(
                {
                    "data": data,
                    "reply": None
                    if reply is None
                    else {"success": bool(reply.success), "message": str(reply.message)},
                }
            ),
            flush=True,
        )

    for data in args.data:
        show(data == "true", client.call(data=data == "true"))
    if args.together:
        # Two calls at once: the second finds the response busy.
        replies = [None, None]
        answered = [threading.Event(), threading.Event()]

        def answer(i):
            def take(reply):
                replies[i] = reply
                answered[i].set()

            return take

        client.call_async(answer(0), data=True)
        time.sleep(0.1)
        client.call_async(answer(1), data=False)
        for i, data in enumerate((True, False)):
            answered[i].wait(timeout=2.0)
            show(data, replies[i])
    client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
