"""The ROS 2 side of the DDS robot example (docs/examples/ros2-dds-robot),
written with rclpy: a laser driver that publishes sensor_msgs/msg/LaserScan
on /scan (360 ranges, 10 Hz) and a base that listens to /cmd_vel (Twist).

    robot.py [--timeout S] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run` of the example), waits for its `ros2:
node` line, publishes clear scans (2 m everywhere) until Radar's node has
matched /scan and /cmd_vel, then for 1 s scans with an obstacle 0.3 m away in a sector,
then clear scans until two Twists have arrived (backing away, then the
stop) or the timeout. It prints one JSON object once Radar's run has ended
by itself: each Twist's linear and angular parts, the graph as rclpy sees
it, and Radar's exit code and stderr. Run it inside a private network
namespace (tests/clients/rclpy/netns).
"""

import argparse
import json
import sys
import time

import rclpy
from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import LaserScan

import radar_run


def scan(near):
    message = LaserScan()
    message.header.frame_id = "laser"
    message.angle_min, message.angle_max = -3.14159, 3.14159
    message.angle_increment = 2 * 3.14159 / 360
    message.range_min, message.range_max = 0.05, 12.0
    ranges = [2.0] * 360
    if near:
        ranges[170:190] = [0.3] * 20
    message.ranges = ranges
    return message


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar
    radar, joined = radar_run.start(command)
    report = {"joined": joined, "cmd_vel": []}
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1

    rclpy.init()
    node = Node("laser_and_base")
    publisher = node.create_publisher(LaserScan, "/scan", 10)
    base = node.create_subscription(
        Twist,
        "/cmd_vel",
        lambda m: report["cmd_vel"].append(
            {"linear": [m.linear.x, m.linear.y, m.linear.z],
             "angular": [m.angular.x, m.angular.y, m.angular.z]}
        ),
        10,
    )
    began = time.time()
    near_from = None
    while time.time() - began < args.timeout and len(report["cmd_vel"]) < 2:
        # Radar's reader has matched ours, and its writer ours.
        matched = publisher.get_subscription_count() > 0 and base.get_publisher_count() > 0
        if matched and near_from is None:
            near_from = time.time() + 0.5
        near = near_from is not None and near_from <= time.time() < near_from + 1.0
        publisher.publish(scan(near))
        rclpy.spin_once(node, timeout_sec=0.1)
    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    sys.exit(main())
