"""The ROS 2 side of the obstacle example on DDS, written with rclpy (ROS 2's
own Python client library, on Fast DDS): a range sensor node that publishes
sensor_msgs/msg/Range on /range, and listens to /cmd_vel (Twist) and
/avoided (UInt32), as the robot around Radar would.

    obstacle.py [--timeout S] [--malformed] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run` of the example with rmw = "dds"), waits
for its `ros2: node` line, then publishes a clear reading (2 m) every 0.1 s
until Radar's node has matched the topics both ways, then near readings (0.3 m) for
1 s, then clear again, until /avoided says 1 (or the timeout). With
--malformed it first publishes, once matched, a Range cut short (raw bytes:
the CDR header and 3 bytes), which Radar must refuse. It prints one
JSON object once Radar's run has ended by itself: what arrived on each
topic, the graph as rclpy sees it (node names, topics and types), and
Radar's exit code and stderr. Run it inside a
private network namespace (tests/clients/rclpy/netns): DDS discovers by
multicast.
"""

import argparse
import json
import sys
import time

import radar_run

import rclpy
from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import Range
from std_msgs.msg import UInt32


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--malformed", action="store_true")
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar
    radar, joined = radar_run.start(command)
    report = {"joined": joined, "cmd_vel": [], "avoided": []}
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1

    rclpy.init()
    node = Node("range_sensor")
    publisher = node.create_publisher(Range, "/range", 10)
    listening = [
        node.create_subscription(
            Twist, "/cmd_vel", lambda m: report["cmd_vel"].append(m.angular.z), 10
        ),
        node.create_subscription(
            UInt32, "/avoided", lambda m: report["avoided"].append(m.data), 10
        ),
    ]

    began = time.time()
    near_from = None
    while time.time() - began < args.timeout and not report["avoided"]:
        # Radar's reader has matched ours, and its writers (on volatile
        # topics, where nothing sent before is kept) ours.
        matched = publisher.get_subscription_count() > 0 and all(
            s.get_publisher_count() > 0 for s in listening
        )
        if matched and near_from is None:
            near_from = time.time() + 0.5
            if args.malformed:
                publisher.publish(b"\x00\x01\x00\x00\x07\x00\x00")
        near = near_from is not None and near_from <= time.time() < near_from + 1.0
        message = Range()
        message.header.frame_id = "sonar"
        message.range = 0.3 if near else 2.0
        publisher.publish(message)
        rclpy.spin_once(node, timeout_sec=0.1)
    # A moment for the zero Twist that follows the turn.
    settle = time.time() + 1.0
    while time.time() < settle:
        rclpy.spin_once(node, timeout_sec=0.1)

    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    sys.exit(main())
