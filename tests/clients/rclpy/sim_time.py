"""ROS 2 time shared between rclpy (ROS 2's own Python client library, on
Fast DDS) and Radar, both ways, on /clock (rosgraph_msgs/msg/Clock)
(docs/ros2.md).

    sim_time.py [--timeout S] --follow -- RADAR_COMMAND...
    sim_time.py [--timeout S] --drive [--factor F] -- RADAR_COMMAND...

--follow: an rclpy node with use_sim_time follows the /clock Radar
publishes (`[ros2] publish_clock`, a paced virtual-clock run). Until the run
ends it reads its own clock every 50 ms; the report has `times`, the
distinct readings in seconds.

--drive: an rclpy node publishes /clock as a simulator does, 100 times a
second, its time starting at 1000 s and moving 10 ms x F each time (F
times as fast as the wall clock, slower when ticks come late); Radar
follows it (`[ros2] use_sim_time`). The report has
`wall`, the wall-clock seconds from the first tick to the end of Radar's
run.

It prints one JSON object once Radar's run has ended by itself: the above,
the graph as rclpy sees it, and Radar's exit code and stderr. Run it inside
a private network namespace (tests/clients/rclpy/netns): DDS discovers by
multicast.
"""

import argparse
import json
import time

import radar_run

import rclpy
from builtin_interfaces.msg import Time
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock


def follow(node, radar, report):
    times = []
    began = time.time()
    while radar.poll() is None and time.time() - began < 30.0:
        rclpy.spin_once(node, timeout_sec=0.05)
        now = node.get_clock().now().nanoseconds / 1e9
        if now > 0 and (not times or now != times[-1]):
            times.append(now)
    report["times"] = times


def drive(node, radar, report, factor):
    clock = node.create_publisher(Clock, "/clock", 10)
    began = time.time()
    # A fixed step a tick: a late tick slows the simulator, never makes
    # its time jump.
    sim = 0.0
    while radar.poll() is None and time.time() - began < 60:
        now = 1000.0 + sim
        sim += 0.01 * factor
        sec = int(now)
        clock.publish(Clock(clock=Time(sec=sec, nanosec=int((now - sec) * 1e9))))
        rclpy.spin_once(node, timeout_sec=0.01)
    report["wall"] = time.time() - began


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--follow", action="store_true")
    parser.add_argument("--drive", action="store_true")
    parser.add_argument("--factor", type=float, default=10.0)
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar

    rclpy.init()
    overrides = [Parameter("use_sim_time", Parameter.Type.BOOL, args.follow)]
    node = Node("sim_time", parameter_overrides=overrides)
    report = {}
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is None:
        report["radar_stderr"] = "".join(radar.stderr_lines)
        print(json.dumps(report))
        return 1
    if args.follow:
        follow(node, radar, report)
    if args.drive:
        drive(node, radar, report, args.factor)
    radar_run.report_at_end(radar, node, report, args.timeout + 30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
