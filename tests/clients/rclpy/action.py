"""A test_msgs/action/Fibonacci server at /fib written with rclpy (ROS 2's
own Python client library, on Fast DDS), beside a Radar system whose
response `Fib` is backed by that action (docs/ros2.md).

    action.py [--timeout S] [--goals N] [--step S] [--radar-node NAME]
              -- RADAR_COMMAND...

Starts the server, then RADAR_COMMAND (a `radar run`). Each goal of order
n is worked through in n steps of `--step` seconds (fibonacci_server.py:
feedback after each step, above 40 rejected, cancels accepted). Once N
goals have ended (or the timeout) and Radar's run has ended by itself, it
prints one JSON object: each goal's order and how it ended, the cancels
asked for, the actions in ROS 2's graph, the action clients of Radar's node
(--radar-node, asked once the first goal has ended) and Radar's exit code
and stderr.
Run it inside a private network namespace (tests/clients/rclpy/netns): DDS
discovers by multicast.
"""

import argparse
import json
import threading
import time

import fibonacci_server
import radar_run
import rclpy
from rclpy.action import get_action_names_and_types
from rclpy.action.graph import get_action_client_names_and_types_by_node
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--goals", type=int, default=2)
    parser.add_argument("--step", type=float, default=0.1)
    parser.add_argument("--radar-node", default="radar")
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar

    rclpy.init()
    node = Node("fibonacci_server")
    report = {"goals": [], "cancels": 0}
    lock = threading.Lock()

    # Kept for as long as the node spins.
    _server = fibonacci_server.serve(node, "/fib", args.step, report, lock)
    executor = MultiThreadedExecutor()
    executor.add_node(node)
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1
    began = time.time()
    while time.time() - began < args.timeout:
        with lock:
            ended = len(report["goals"])
        if ended >= args.goals:
            break
        if ended >= 1 and "radar_action_clients" not in report:
            # While Radar's node is surely there: its action clients.
            try:
                report["radar_action_clients"] = dict(
                    get_action_client_names_and_types_by_node(node, args.radar_node, "/")
                )
            except Exception as e:  # the node is not in the graph
                report["radar_action_clients"] = str(e)
        executor.spin_once(timeout_sec=0.1)
    # A moment for the last result to go out, and for the graph.
    settle = time.time() + 1.0
    while time.time() < settle:
        executor.spin_once(timeout_sec=0.1)
    report["actions"] = dict(get_action_names_and_types(node))
    executor.shutdown()
    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
