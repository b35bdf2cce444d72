"""An rclpy action client (ROS 2's own Python client library, on Fast DDS)
driving a Radar response served as the action test_msgs/action/Fibonacci
at /radar/fib (`[[ros2.serve]]`, docs/ros2.md).

    action_client.py [--timeout S] [--radar-node NAME] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run`), waits for the action's server, then:
a goal of order 5 (feedback and the result awaited); a goal of order 30
with a second goal sent while it runs (refused: the response is busy),
then a cancel of the first 0.5 s in. It prints one JSON object once
Radar's run has ended by itself: what each goal got (accepted, feedback
count, last feedback, status, result), the cancel's return code, the
action servers of Radar's node, and Radar's exit code and stderr. Run it
inside a private network namespace (tests/clients/rclpy/netns).
"""

import argparse
import json
import time

import radar_run
from radar_run import spin_until

import rclpy
from rclpy.action import ActionClient
from rclpy.action.graph import get_action_server_names_and_types_by_node
from rclpy.node import Node
from test_msgs.action import Fibonacci


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--radar-node", default="radar")
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar

    rclpy.init()
    node = Node("fibonacci_client")
    client = ActionClient(node, Fibonacci, "/radar/fib")
    report = {"goals": []}
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1
    report["server"] = client.wait_for_server(timeout_sec=10.0)

    def goal(order):
        seen = {"order": order, "feedback": 0, "last_feedback": None}

        def on_feedback(message):
            seen["feedback"] += 1
            seen["last_feedback"] = list(message.feedback.sequence)

        request = Fibonacci.Goal()
        request.order = order
        future = client.send_goal_async(request, feedback_callback=on_feedback)
        return seen, future

    def finish(seen, handle):
        seen["accepted"] = bool(handle and handle.accepted)
        if seen["accepted"]:
            result = spin_until(node, handle.get_result_async(), args.timeout)
            if result is not None:
                seen["status"] = result.status
                seen["result"] = list(result.result.sequence)
        report["goals"].append(seen)

    # One goal to its end.
    seen, future = goal(5)
    finish(seen, spin_until(node, future, 10.0))
    report["radar_action_servers"] = dict(
        get_action_server_names_and_types_by_node(node, args.radar_node, "/")
    )
    # One interrupted half-way; a second refused meanwhile.
    first, future = goal(30)
    handle = spin_until(node, future, 10.0)
    time.sleep(0.2)
    busy, busy_future = goal(3)
    finish(busy, spin_until(node, busy_future, 10.0))
    time.sleep(0.3)
    if handle is not None and handle.accepted:
        cancel = spin_until(node, handle.cancel_goal_async(), 10.0)
        report["cancel_return_code"] = None if cancel is None else cancel.return_code
    finish(first, handle)
    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
