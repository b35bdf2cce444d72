"""An action's round trip on DDS, timed from rclpy's action client: a
test_msgs/action/Fibonacci goal of order 1 sent, accepted and its result
received, through a Radar response served as the action (/radar/fib)
against through a plain rclpy action server (/fib, fibonacci_server.py, in
a process of its own: what a ROS 2 user would write instead), interleaved
in one run.

    action_latency.py [--samples N] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run` whose system serves /radar/fib) and the
rclpy server. Each sample sends a goal, waits for its acceptance, asks for
its result and times until the result arrives. Samples alternate between
the two servers. Prints one line per path with p50, p90 and p99 in
microseconds, and their ratio. Run it inside a private network namespace
(tests/clients/rclpy/netns).
"""

import argparse
import statistics
import subprocess
import sys
import threading
import time

import fibonacci_server
import radar_run
import rclpy
from rclpy.action import ActionClient
from rclpy.node import Node
from test_msgs.action import Fibonacci

from latency import percentile


def server():
    """The plain rclpy action server, answering at once."""
    rclpy.init()
    node = Node("fibonacci_server")
    _server = fibonacci_server.serve(node, "/fib", 0.0, {}, threading.Lock())
    try:
        rclpy.spin(node)
    except Exception:  # pylint: disable=broad-except
        pass  # stopped by the measuring process (rclpy raises as it shuts down)


def round_trip(node, client):
    """Sends a goal of order 1; the microseconds until its result arrived,
    or None if it was not accepted or took over 5 s."""
    goal = Fibonacci.Goal()
    goal.order = 1
    began = time.perf_counter()
    sent = client.send_goal_async(goal)
    rclpy.spin_until_future_complete(node, sent, timeout_sec=5.0)
    handle = sent.result()
    if handle is None or not handle.accepted:
        return None
    result = handle.get_result_async()
    rclpy.spin_until_future_complete(node, result, timeout_sec=5.0)
    if result.result() is None:
        return None
    return (time.perf_counter() - began) * 1e6


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--server", action="store_true")
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    if args.server:
        server()
        return 0
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar
    radar, joined = radar_run.start(command)
    if joined is None:
        print("radar ended before joining the graph:", *radar.stderr_lines, file=sys.stderr)
        return 1
    server_process = subprocess.Popen([sys.executable, __file__, "--server"])

    rclpy.init()
    node = Node("action_latency")
    clients = {
        "radar": ActionClient(node, Fibonacci, "/radar/fib"),
        "rclpy": ActionClient(node, Fibonacci, "/fib"),
    }
    for path, client in clients.items():
        # Discovery, then one goal each to warm up.
        if not client.wait_for_server(timeout_sec=30.0) or round_trip(node, client) is None:
            print(f"{path}: no action server within 30 s", file=sys.stderr)
            return 1

    times = {"radar": [], "rclpy": []}
    for i in range(2 * args.samples):
        path = "radar" if i % 2 == 0 else "rclpy"
        took = round_trip(node, clients[path])
        if took is not None:
            times[path].append(took)

    radar.terminate()
    server_process.terminate()
    radar.wait()
    server_process.wait()
    for path, label in (
        ("radar", "rclpy client → Radar response served as the action"),
        ("rclpy", "rclpy client → plain rclpy action server          "),
    ):
        t = times[path]
        print(
            f"{label}  n={len(t):4d}  p50 {percentile(t, 50):8.1f} µs  "
            f"p90 {percentile(t, 90):8.1f} µs  p99 {percentile(t, 99):8.1f} µs"
        )
    ratio = statistics.median(times["radar"]) / statistics.median(times["rclpy"])
    print(f"Radar p50 / rclpy p50: {ratio:.2f}×")
    return 0


if __name__ == "__main__":
    sys.exit(main())
