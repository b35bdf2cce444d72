"""An rclpy subscriber of /cmd_vel (geometry_msgs/msg/Twist, on Fast DDS)
beside a Radar coordinator that is killed while its response runs on an
agent: what reaches the robot's base from the agent's own ROS 2 node
(docs/ros2.md, "An agent's own node").

    agent_failsafe.py [--timeout S] --radar BIN --agent-port P -- RADAR_COMMAND...

Starts `BIN agent --name base` listening on tcp/127.0.0.1:P, then
RADAR_COMMAND (a `radar run` whose plugin runs on that agent), waits for
the first Twist (the coordinator's), kills the coordinator (SIGKILL),
takes the Twists that come in the next 5 s, and stops the agent. Prints
one JSON object: each Twist's linear x and z in order, the nodes rclpy
saw, the agent's stderr. Run it inside a private network namespace
(tests/clients/rclpy/netns).
"""

import argparse
import json
import subprocess
import time

import radar_run
import rclpy
from geometry_msgs.msg import Twist
from rclpy.node import Node


def spin_for(node, seconds, done=lambda: False):
    deadline = time.time() + seconds
    while time.time() < deadline and not done():
        rclpy.spin_once(node, timeout_sec=0.05)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--radar", required=True)
    parser.add_argument("--agent-port", type=int, required=True)
    parser.add_argument("radar_command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar_command[1:] if args.radar_command[:1] == ["--"] else args.radar_command

    rclpy.init()
    node = Node("base_driver")
    twists = []
    node.create_subscription(
        Twist, "/cmd_vel", lambda m: twists.append([m.linear.x, m.linear.z]), 10
    )
    agent = subprocess.Popen(
        [args.radar, "agent", "--name", "base", "--listen", f"tcp/127.0.0.1:{args.agent_port}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    report = {"agent_up": agent.stdout.readline().strip()}
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is not None:
        spin_for(node, args.timeout, lambda: len(twists) > 0)
        report["nodes_before"] = radar_run.graph(node)["nodes"]
        radar.kill()
        radar.wait()
        spin_for(node, 5.0)
    report["twists"] = twists
    agent.send_signal(2)
    try:
        _, report["agent_stderr"] = agent.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        agent.kill()
        _, report["agent_stderr"] = agent.communicate()
    node.destroy_node()
    rclpy.shutdown()
    print(json.dumps(report))


if __name__ == "__main__":
    main()
