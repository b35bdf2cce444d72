"""An rclpy service client (ROS 2's own Python client library, on Fast
DDS) calling a Radar response served as the service std_srvs/srv/SetBool
at /radar/grip (`[[ros2.serve]]`, docs/ros2.md).

    service_client.py [--timeout S] [--radar-node NAME] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run`), waits for the service, then calls it
with data = true and, once answered, with data = false; then makes two
calls at once (the second finds the response busy, and gets no reply
within 2 s). It prints one JSON object once Radar's run has ended by
itself: each call's request and its reply (null: none), how long each
answered call took, the services of Radar's node, and Radar's exit code
and stderr. Run it inside a private network namespace
(tests/clients/rclpy/netns).
"""

import argparse
import json
import time

import radar_run
from radar_run import spin_until
import rclpy
from rclpy.node import Node
from std_srvs.srv import SetBool


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--radar-node", default="radar")
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar

    rclpy.init()
    node = Node("gripper_client")
    client = node.create_client(SetBool, "/radar/grip")
    report = {"calls": []}
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1
    report["server"] = client.wait_for_service(timeout_sec=10.0)

    def call(data):
        request = SetBool.Request()
        request.data = data
        return {"data": data, "sent": time.time()}, client.call_async(request)

    def answered(seen, future, timeout):
        reply = spin_until(node, future, timeout)
        if reply is None:
            seen["reply"] = None
        else:
            seen["reply"] = {"success": reply.success, "message": reply.message}
            seen["took"] = time.time() - seen["sent"]
        del seen["sent"]
        report["calls"].append(seen)

    for data in (True, False):
        answered(*call(data), 10.0)
    report["radar_services"] = dict(
        node.get_service_names_and_types_by_node(args.radar_node, "/")
    )
    # Two at once: the second finds the response busy.
    first = call(True)
    time.sleep(0.1)
    busy = call(False)
    answered(*first, 10.0)
    answered(*busy, 2.0)
    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
