"""A std_srvs/srv/SetBool server at /beep written with rclpy (ROS 2's own
Python client library, on Fast DDS), beside a Radar system whose response
`Beep` is backed by that service (docs/ros2.md).

    service.py [--timeout S] [--count N] [--delay S] [--radar-node NAME]
               -- RADAR_COMMAND...

Starts the server, then RADAR_COMMAND (a `radar run`), and answers each
request `--delay` seconds after it came (success = the request's data,
message = "beeped N" for the N-th request), until N requests were
answered (or the timeout). It prints one JSON object once Radar's run has
ended by itself: the requests' data in order, the graph as rclpy sees it
(nodes, topics, services with their types, and the service clients of
Radar's node, --radar-node), and Radar's exit code and stderr. Run it inside a private network namespace
(tests/clients/rclpy/netns): DDS discovers by multicast.
"""

import argparse
import json
import time

import radar_run

import rclpy
from rclpy.node import Node
from std_srvs.srv import SetBool


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--count", type=int, default=2)
    parser.add_argument("--delay", type=float, default=0.0)
    parser.add_argument("--radar-node", default="radar")
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar

    rclpy.init()
    node = Node("beeper")
    report = {"requests": []}

    def beep(request, response):
        report["requests"].append(request.data)
        time.sleep(args.delay)
        response.success = request.data
        response.message = f"beeped {len(report['requests'])}"
        return response

    node.create_service(SetBool, "/beep", beep)
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1
    began = time.time()
    while time.time() - began < args.timeout and len(report["requests"]) < args.count:
        rclpy.spin_once(node, timeout_sec=0.1)
    # A moment for the last reply to go out, and for the graph.
    settle = time.time() + 1.0
    while time.time() < settle:
        rclpy.spin_once(node, timeout_sec=0.1)
    report["services"] = dict(node.get_service_names_and_types())
    try:
        report["radar_clients"] = dict(
            node.get_client_names_and_types_by_node(args.radar_node, "/")
        )
    except Exception as e:  # the node is not (or no longer) in the graph
        report["radar_clients"] = str(e)
    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
