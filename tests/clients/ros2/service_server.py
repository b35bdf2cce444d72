"""ROS 2 service server (zenoh-ros2-sdk, rmw_zenoh wire format) for Radar's
tests: std_srvs/srv/SetBool at a service name.

    service_server.py --port P [--service /beep] [--count N] [--timeout S]
                      [--domain D]

Connects to the Zenoh peer at tcp/127.0.0.1:P, declares a ROS 2 node and a
SetBool server (its liveliness token and queryable; the SDK computes the
service's type hash itself) and prints `ready`. For each request it prints
the request as Radar JSON and answers success = the request's data, message
= "beeped N" for the N-th. Exits 0 after N requests, 1 at the timeout.
"""

import argparse
import json
import sys
import threading

import ros2_common as rc
from zenoh_ros2_sdk import ROS2ServiceServer


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--service", default="/beep")
    parser.add_argument("--count", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=20.0)
    parser.add_argument("--domain", type=int, default=0)
    args = parser.parse_args()

    answered = []
    done = threading.Event()
    rc.timeout(args.timeout, lambda: f"timeout: answered {len(answered)} of {args.count}")

    def beep(request):
        answered.append(bool(request.data))
        print(json.dumps({"data": bool(request.data)}), flush=True)
        if len(answered) >= args.count:
            # After this reply has gone out.
            threading.Timer(0.5, done.set).start()
        return server.response_msg_class(
            success=bool(request.data), message=f"beeped {len(answered)}"
        )

    server = ROS2ServiceServer(
        args.service,
        "std_srvs/srv/SetBool",
        callback=beep,
        request_definition="bool data\n",
        response_definition="bool success\nstring message\n",
        node_name="beeper",
        domain_id=args.domain,
        router_ip="127.0.0.1",
        router_port=args.port,
    )
    print("ready", flush=True)
    done.wait()
    server.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
