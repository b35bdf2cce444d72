"""One hop of a robot's reaction on DDS, timed from rclpy: a Range reading
in, a Twist out, through Radar against through a plain rclpy relay node
(what a ROS 2 user would write instead), interleaved in one run.

    latency.py [--samples N] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run` whose system subscribes to /range and
publishes a Twist with angular.z = 0.8 on /cmd_vel when Avoid starts) and a
relay node in a process of its own (/range_relay in, /cmd_vel_relay out, on
the first near reading after a clear one). Each sample publishes a clear
reading, waits 20 ms, then a near one, and times until the Twist arrives.
Samples alternate between the two paths. Prints one line per path with
p50, p90 and p99 in microseconds, and their ratio. Run it inside a private
network namespace (tests/clients/rclpy/netns).
"""

import argparse
import statistics
import subprocess
import sys
import time

import radar_run
import rclpy
from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import Range

NEAR, CLEAR = 0.3, 2.0


def relay():
    """The plain rclpy relay: near after clear → a turning Twist."""
    rclpy.init()
    node = Node("relay")
    out = node.create_publisher(Twist, "/cmd_vel_relay", 10)
    state = {"near": False}

    def on_range(message):
        near = message.range < 0.5
        if near and not state["near"]:
            twist = Twist()
            twist.angular.z = 0.8
            out.publish(twist)
        state["near"] = near

    node.create_subscription(Range, "/range_relay", on_range, 10)
    try:
        rclpy.spin(node)
    except Exception:  # pylint: disable=broad-except
        pass  # stopped by the measuring process (rclpy raises as it shuts down)


def percentile(samples, p):
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(p / 100 * len(ordered)))]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--relay", action="store_true")
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    if args.relay:
        relay()
        return 0
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar
    radar, joined = radar_run.start(command)
    if joined is None:
        print("radar ended before joining the graph:", *radar.stderr_lines, file=sys.stderr)
        return 1
    relay_process = subprocess.Popen([sys.executable, __file__, "--relay"])

    rclpy.init()
    node = Node("latency")
    paths = {
        "radar": node.create_publisher(Range, "/range", 10),
        "relay": node.create_publisher(Range, "/range_relay", 10),
    }
    arrived = {"radar": None, "relay": None}

    def on_twist(path):
        def record(message):
            if message.angular.z > 0.5:
                arrived[path] = time.perf_counter()

        return record

    node.create_subscription(Twist, "/cmd_vel", on_twist("radar"), 10)
    node.create_subscription(Twist, "/cmd_vel_relay", on_twist("relay"), 10)

    def reading(value):
        message = Range()
        message.range = value
        return message

    def spin_for(seconds):
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            rclpy.spin_once(node, timeout_sec=0.001)

    # Until both paths answer (discovery and matching take a moment).
    deadline = time.time() + 30
    for path in paths:
        while arrived[path] is None and time.time() < deadline:
            paths[path].publish(reading(CLEAR))
            spin_for(0.05)
            paths[path].publish(reading(NEAR))
            spin_for(0.05)
        if arrived[path] is None:
            print(f"{path}: no Twist within 30 s", file=sys.stderr)
            return 1

    times = {"radar": [], "relay": []}
    for i in range(2 * args.samples):
        path = "radar" if i % 2 == 0 else "relay"
        paths[path].publish(reading(CLEAR))
        spin_for(0.02)
        arrived[path] = None
        began = time.perf_counter()
        paths[path].publish(reading(NEAR))
        while arrived[path] is None and time.perf_counter() - began < 1.0:
            rclpy.spin_once(node, timeout_sec=0.0005)
        if arrived[path] is not None:
            times[path].append((arrived[path] - began) * 1e6)

    radar.terminate()
    relay_process.terminate()
    radar.wait()
    relay_process.wait()
    for path, label in (
        ("radar", "rclpy → Radar (event → response → Twist) → rclpy"),
        ("relay", "rclpy → plain rclpy relay node → rclpy          "),
    ):
        t = times[path]
        print(
            f"{label}  n={len(t):4d}  p50 {percentile(t, 50):8.1f} µs  "
            f"p90 {percentile(t, 90):8.1f} µs  p99 {percentile(t, 99):8.1f} µs"
        )
    ratio = statistics.median(times["radar"]) / statistics.median(times["relay"])
    print(f"Radar p50 / relay p50: {ratio:.2f}×")
    return 0


if __name__ == "__main__":
    sys.exit(main())
