"""A simulator's clock on rmw_zenoh's wire format (zenoh-ros2-sdk's
publisher): rosgraph_msgs/msg/Clock on /clock, as Gazebo publishes it for
nodes with use_sim_time.

    sim_clock.py --port P [--start S] [--factor F] [--pause-at T --pause-for W]
                 [--timeout S] [--domain D]

Connects to the Zenoh peer at tcp/127.0.0.1:P and prints `ready`. Then,
every 10 ms of wall time, publishes a simulated time that starts at S
seconds and runs F times as fast as the wall clock; with --pause-at, the
simulated time stands still at T seconds (after the start) for W seconds of
wall time, as a paused simulator's does. Exits 0 when --timeout seconds of
wall time have passed.
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
    began = time.monotonic()
    paused = 0.0
    while time.monotonic() - began < args.timeout:
        wall = time.monotonic() - began
        sim = wall * args.factor
        if args.pause_at is not None and sim >= args.pause_at:
            # Stands still for pause-for seconds of wall time, then goes on.
            stood = wall - args.pause_at / args.factor
            paused = min(stood, args.pause_for)
            sim = args.pause_at + max(0.0, stood - args.pause_for) * args.factor
        now = args.start + sim
        sec = int(now)
        clock.publish(clock=time_cls(sec=sec, nanosec=int((now - sec) * 1e9)))
        time.sleep(0.01)
    print(f"paused {paused:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
