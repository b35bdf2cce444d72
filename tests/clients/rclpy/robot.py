"""The ROS 2 side of the DDS robot example (docs/examples/ros2-dds-robot),
written with rclpy: a laser driver that publishes sensor_msgs/msg/LaserScan
on /scan (360 ranges, 10 Hz), a base that listens to /cmd_vel (Twist), a
battery driver that publishes sensor_msgs/msg/BatteryState on /battery
(2 Hz), and a docking server, the stand-in action /dock
(test_msgs/action/Fibonacci, fibonacci_server.py, 0.1 s a step).

    robot.py [--timeout S] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run` of the example), waits for its `ros2:
node` line, publishes clear scans (2 m everywhere) and a full battery
(80 %) until Radar's node has matched /scan, /cmd_vel and /battery, then
for 1 s scans with an obstacle 0.3 m away in a sector, then clear scans
until two Twists have arrived (backing away, then the stop); then the
battery falls to 15 %, until the docking goal has ended (or the timeout).
It prints one JSON object once Radar's run has ended by itself: each
Twist's linear and angular parts, each docking goal's order and how it
ended, the graph as rclpy sees it (with its actions), and Radar's exit code
and stderr. Run it inside a private network namespace
(tests/clients/rclpy/netns).
"""

import argparse
import json
import sys
import threading
import time

import fibonacci_server
import radar_run
import rclpy
from geometry_msgs.msg import Twist
from rclpy.action import get_action_names_and_types
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import BatteryState, LaserScan


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


def battery(percentage):
    message = BatteryState()
    message.header.frame_id = "battery"
    message.voltage = 24.0 * (0.8 + 0.2 * percentage)
    message.percentage = percentage
    message.power_supply_status = BatteryState.POWER_SUPPLY_STATUS_DISCHARGING
    message.present = True
    message.cell_voltage = [4.0] * 6
    message.location = "base"
    return message


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar

    rclpy.init()
    node = Node("laser_base_and_dock")
    report = {"cmd_vel": []}
    lock = threading.Lock()
    # Kept for as long as the node spins.
    _dock = fibonacci_server.serve(node, "/dock", 0.1, report, lock)
    executor = MultiThreadedExecutor()
    executor.add_node(node)
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1

    scans = node.create_publisher(LaserScan, "/scan", 10)
    batteries = node.create_publisher(BatteryState, "/battery", 10)

    def on_twist(m):
        with lock:
            report["cmd_vel"].append(
                {"linear": [m.linear.x, m.linear.y, m.linear.z],
                 "angular": [m.angular.x, m.angular.y, m.angular.z]}
            )

    base = node.create_subscription(Twist, "/cmd_vel", on_twist, 10)
    began = time.time()
    near_from = None
    step = 0
    while time.time() - began < args.timeout:
        with lock:
            backed_off = len(report["cmd_vel"]) >= 2
            docked = len(report["goals"]) >= 1
        if docked:
            break
        # Radar's readers have matched ours, and its writer ours.
        matched = (
            scans.get_subscription_count() > 0
            and batteries.get_subscription_count() > 0
            and base.get_publisher_count() > 0
        )
        if matched and near_from is None:
            near_from = time.time() + 0.5
        near = near_from is not None and near_from <= time.time() < near_from + 1.0
        scans.publish(scan(near))
        if step % 5 == 0:
            batteries.publish(battery(0.15 if backed_off else 0.8))
        step += 1
        executor.spin_once(timeout_sec=0.1)
    # A moment for the result to go out, and for the graph.
    settle = time.time() + 1.0
    while time.time() < settle:
        executor.spin_once(timeout_sec=0.1)
    report["actions"] = dict(get_action_names_and_types(node))
    executor.shutdown()
    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    sys.exit(main())
