"""A simulator's clock on rmw_zenoh's wire format (zenoh-ros2-sdk's
publisher): rosgraph_msgs/msg/Clock on /clock, as Gazebo publishes it for
nodes with use_sim_time.

    sim_clock.py --port P [--start S] [--factor F] [--pause-at T --pause-for W]
                 [--timeout S] [--domain D]

Connects to the Zenoh peer at tcp/127.0.0.1:P and prints `ready`. Then,
every 10 ms of wall time, publishes a simulated time that starts at S
seconds and moves 10 ms x F each tick (F times as fast as the wall clock,
slower when ticks come late); with --pause-at, the simulated time stands
still at T seconds (after the start) for W seconds' worth of ticks, as a
paused simulator's does. Exits 0 when --timeout seconds of wall time have
passed.
"""

import argparse
import sys
import time

import ros2_common as rc  # noqa: F401 (loopback settings before the SDK)
from zenoh_ros2_sdk import ROS2Publisher


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--start", type=float, default=1000.0)
    parser.add_argument("--factor", type=float, default=1.0)
    parser.add_argument("--pause-at", type=float, default=None)
    parser.add_argument("--pause-for", type=float, default=0.0)
    parser.add_argument("--timeout", type=float, default=20.0)
    parser.add_argument("--domain", type=int, default=0)
    args = parser.parse_args()

    clock = ROS2Publisher(
        "/clock", "rosgraph_msgs/msg/Clock",
        node_name="simulator", domain_id=args.domain,
        router_ip="127.0.0.1", router_port=args.port)
    time_cls = clock.session_mgr.register_message_type(None, "builtin_interfaces/msg/Time")
    print("ready", flush=True)
    # Each tick moves the simulated time by a fixed step, whatever the
    # wall clock did meanwhile: a late tick slows the simulator down, it
    # never makes its time jump.
    step = 0.01 * args.factor
    sim, paused, pause_ticks = 0.0, 0, int(args.pause_for / 0.01)
    began = time.monotonic()
    while time.monotonic() - began < args.timeout:
        now = args.start + sim
        sec = int(now)
        clock.publish(clock=time_cls(sec=sec, nanosec=int((now - sec) * 1e9)))
        if args.pause_at is not None and sim >= args.pause_at and paused < pause_ticks:
            paused += 1
        else:
            sim += step
        time.sleep(0.01)
    print(f"paused {paused * 0.01:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
