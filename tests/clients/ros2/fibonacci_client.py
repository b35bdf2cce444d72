"""A test_msgs/action/Fibonacci client on rmw_zenoh's wire format, built
from zenoh-ros2-sdk's parts (the SDK has service clients and subscribers
but no actions), driving a Radar response served as an action at
/radar/fib (`[[ros2.serve]]`, docs/ros2.md). As rcl makes an action client
of any middleware's services and topics, it calls NAME/_action/send_goal,
NAME/_action/cancel_goal and NAME/_action/get_result and hears
NAME/_action/feedback and NAME/_action/status, each with the type name and
the RIHS01 hash rosidl gives it (fibonacci_server.py has them).

    fibonacci_client.py --port P [--action /radar/fib] [--timeout S]
                        [--domain D]

Connects to the Zenoh peer at tcp/127.0.0.1:P and waits for the action's
send_goal server in the graph. Then, as tests/clients/rclpy/action_client.py
does on DDS: a goal of order 5 to its end; a goal of order 30 with a second
(order 3) sent while it runs (refused: the response is busy), then a cancel
of the first 0.5 s in. Prints one JSON line: the send_goal server's node
and type, what each goal got (accepted, feedback count, status, result),
the cancel's return code and the statuses heard. Exits 0, or 1 at the
timeout.
"""

import argparse
import json
import os
import sys
import threading
import time
import uuid as uuids

import ros2_common as rc
from fibonacci_server import CANCEL_GOAL, FEEDBACK, GET_RESULT, SEND_GOAL, messages
from zenoh_ros2_sdk import ROS2ServiceClient, ROS2Subscriber
from zenoh_ros2_sdk.discovery import get_service_info

# rosidl's hash of action_msgs/msg/GoalStatusArray.
STATUS = "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--action", default="/radar/fib")
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--domain", type=int, default=0)
    args = parser.parse_args()

    report = {"goals": [], "statuses": []}
    rc.timeout(args.timeout, lambda: f"timeout: {json.dumps(report)}")
    common = dict(node_name="fibonacci_client", domain_id=args.domain,
                  router_ip="127.0.0.1", router_port=args.port)

    def part(name):
        return f"{args.action}/_action/{name}"

    message, uuid_msg = messages(args.port)

    lock = threading.Lock()
    feedback = {}  # uuid bytes -> count

    def on_feedback(msg):
        with lock:
            uuid = bytes(msg.goal_id.uuid)
            feedback[uuid] = feedback.get(uuid, 0) + 1

    def on_status(msg):
        with lock:
            report["statuses"].append([int(s.status) for s in msg.status_list])

    ROS2Subscriber(part("feedback"), "test_msgs/action/Fibonacci_FeedbackMessage",
                   on_feedback,
                   msg_definition="unique_identifier_msgs/UUID goal_id\n"
                                  "test_msgs/Fibonacci_Feedback feedback\n",
                   type_hash=FEEDBACK, **common)
    ROS2Subscriber(part("status"), "action_msgs/msg/GoalStatusArray", on_status,
                   msg_definition="action_msgs/GoalStatus[] status_list\n",
                   type_hash=STATUS, **common)
    send_goal = ROS2ServiceClient(
        part("send_goal"), "test_msgs/action/Fibonacci_SendGoal",
        request_definition="unique_identifier_msgs/UUID goal_id\n"
                           "test_msgs/Fibonacci_Goal goal\n",
        response_definition="bool accepted\nbuiltin_interfaces/Time stamp\n",
        type_hash=SEND_GOAL, timeout=5.0, **common)
    cancel_goal = ROS2ServiceClient(
        part("cancel_goal"), "action_msgs/srv/CancelGoal",
        request_definition="action_msgs/GoalInfo goal_info\n",
        response_definition="int8 return_code\naction_msgs/GoalInfo[] goals_canceling\n",
        type_hash=CANCEL_GOAL, timeout=5.0, **common)
    get_result = ROS2ServiceClient(
        part("get_result"), "test_msgs/action/Fibonacci_GetResult",
        request_definition="unique_identifier_msgs/UUID goal_id\n",
        response_definition="int8 status\ntest_msgs/Fibonacci_Result result\n",
        type_hash=GET_RESULT, timeout=15.0, **common)

    # The server's token, as ROS 2's graph shows it: its node and type.
    while True:
        info = get_service_info(part("send_goal"), domain_id=args.domain,
                                router_ip="127.0.0.1", router_port=args.port,
                                verbose=True)
        if info is not None and info.server_count > 0:
            server = info.servers[0]
            report["server"] = {
                "node": f"{server.node_namespace.rstrip('/')}/{server.node_name}",
                "type": server.service_type,
            }
            break
        time.sleep(0.2)

    def goal(order):
        uuid = uuids.uuid4().bytes
        answer = send_goal.call(goal_id=uuid_msg(uuid),
                                goal=message("test_msgs/msg/Fibonacci_Goal", order=order))
        seen = {"order": order, "accepted": bool(answer is not None and answer.accepted)}
        return uuid, seen

    def finish(uuid, seen):
        if seen["accepted"]:
            result = get_result.call(goal_id=uuid_msg(uuid))
            if result is not None:
                seen["status"] = int(result.status)
                seen["result"] = [int(x) for x in result.result.sequence]
            time.sleep(0.1)
            with lock:
                seen["feedback"] = feedback.get(uuid, 0)
        report["goals"].append(seen)

    # One goal to its end.
    finish(*goal(5))
    # One interrupted half-way; a second refused meanwhile.
    first, first_seen = goal(30)
    time.sleep(0.2)
    finish(*goal(3))
    time.sleep(0.3)
    if first_seen["accepted"]:
        stamp = message("builtin_interfaces/msg/Time", sec=0, nanosec=0)
        info = message("action_msgs/msg/GoalInfo", goal_id=uuid_msg(first), stamp=stamp)
        cancel = cancel_goal.call(goal_info=info)
        report["cancel_return_code"] = None if cancel is None else int(cancel.return_code)
    finish(first, first_seen)
    print(json.dumps(report), flush=True)
    # The SDK's session keeps threads of its own alive: end here.
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
