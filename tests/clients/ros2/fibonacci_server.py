"""A test_msgs/action/Fibonacci server on rmw_zenoh's wire format, built
from zenoh-ros2-sdk's parts (the SDK has service servers and publishers but
no actions): as rcl makes an action of any middleware's services and
topics, the action NAME is served as the services NAME/_action/send_goal,
NAME/_action/cancel_goal and NAME/_action/get_result and the topic
NAME/_action/feedback, each with the type name and the RIHS01 hash rosidl
gives it (copied from test_msgs' Fibonacci.json and action_msgs'
CancelGoal.json).

    fibonacci_server.py --port P [--action /dock] [--goals N] [--step S]
                        [--timeout S] [--domain D]

Connects to the Zenoh peer at tcp/127.0.0.1:P and prints `ready`. Each goal
of order n is worked through in n - 1 steps of S seconds, with the sequence
so far as feedback after each; a goal of order above 40 is rejected; a
cancel is accepted and ends the goal as canceled at its next step. After N
goals have ended (or at the timeout) it prints one JSON report line:
{"goals": [{"order", "ended"}...], "cancels": n} and exits 0 (1 at the
timeout).
"""

import argparse
import json
import os
import sys
import threading
import time

import ros2_common as rc
from zenoh_ros2_sdk import ROS2Publisher, ROS2ServiceServer
from zenoh_ros2_sdk.session import ZenohSession

# rosidl's hashes (Kilted and Jazzy alike).
SEND_GOAL = "RIHS01_d807633803e38e164276573cd97e9fbd71e109c290bbf4cc312a0a1c9da7bbd9"
GET_RESULT = "RIHS01_5d30fdeb21d20e117aa5f36c7b4f0b6874f1a8cf7a9c038d58f1156c5737b209"
FEEDBACK = "RIHS01_37487bae8cea358366b97003c1ef1ca7ce7c08df36f9e8cca496624226aee64e"
CANCEL_GOAL = "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a"

# action_msgs/msg/GoalStatus
SUCCEEDED, CANCELED = 4, 5
# action_msgs/srv/CancelGoal's return codes
NONE, UNKNOWN_GOAL = 0, 2


def messages(port):
    """The action's parts' messages on the SDK's session at `port`, nested
    as rosidl nests them (rosbags reads `pkg/Name` as `pkg/msg/Name`),
    registered before the parts are made; returns `message(name, **fields)`
    and `uuid_msg(bytes)` to make them."""
    store = ZenohSession.get_instance("127.0.0.1", port)
    for definition, name in [
        ("int32 order\n", "test_msgs/msg/Fibonacci_Goal"),
        ("int32[] sequence\n", "test_msgs/msg/Fibonacci_Result"),
        ("int32[] sequence\n", "test_msgs/msg/Fibonacci_Feedback"),
        (None, "unique_identifier_msgs/msg/UUID"),
        (None, "builtin_interfaces/msg/Time"),
        (None, "action_msgs/msg/GoalInfo"),
        (None, "action_msgs/msg/GoalStatus"),
    ]:
        store.register_message_type(definition, name)

    def message(name, **fields):
        return store.register_message_type(None, name)(**fields)

    def uuid_msg(uuid):
        return message("unique_identifier_msgs/msg/UUID",
                       uuid=rc.numpy.frombuffer(uuid, dtype=rc.numpy.uint8).copy())

    return message, uuid_msg


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--action", default="/dock")
    parser.add_argument("--goals", type=int, default=1)
    parser.add_argument("--step", type=float, default=0.1)
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--domain", type=int, default=0)
    args = parser.parse_args()

    lock = threading.Lock()
    report = {"goals": [], "cancels": 0}
    done = threading.Event()
    rc.timeout(args.timeout, lambda: f"timeout: {json.dumps(report)}")
    common = dict(node_name="docker", domain_id=args.domain,
                  router_ip="127.0.0.1", router_port=args.port)

    def part(name):
        return f"{args.action}/_action/{name}"

    message, uuid_msg = messages(args.port)

    feedback_pub = ROS2Publisher(
        part("feedback"), "test_msgs/action/Fibonacci_FeedbackMessage",
        msg_definition="unique_identifier_msgs/UUID goal_id\n"
                       "test_msgs/Fibonacci_Feedback feedback\n",
        type_hash=FEEDBACK, **common)

    goals = {}  # uuid bytes -> {"order", "cancel", "status", "sequence", "waiting"}

    def finish(uuid, status, sequence):
        goal = goals[uuid]
        goal["status"], goal["sequence"] = status, sequence
        ended = "succeeded" if status == SUCCEEDED else "canceled"
        report["goals"].append({"order": goal["order"], "ended": ended})
        for key in goal.pop("waiting"):
            answer_result(key, uuid)
        if len(report["goals"]) >= args.goals:
            threading.Timer(0.5, done.set).start()

    def execute(uuid):
        order = goals[uuid]["order"]
        sequence = [0, 1]
        for _ in range(1, order):
            time.sleep(args.step)
            with lock:
                if goals[uuid]["cancel"]:
                    return finish(uuid, CANCELED, sequence)
            sequence.append(sequence[-1] + sequence[-2])
            feedback_pub.publish(goal_id=uuid_msg(uuid),
                                 feedback=fibonacci("Feedback", sequence))
        with lock:
            finish(uuid, SUCCEEDED, sequence)

    def fibonacci(kind, sequence):
        return message(f"test_msgs/msg/Fibonacci_{kind}",
                       sequence=rc.numpy.array(sequence, dtype=rc.numpy.int32))

    def on_goal(request):
        uuid = bytes(request.goal_id.uuid)
        accepted = request.goal.order <= 40
        with lock:
            if accepted:
                goals[uuid] = {"order": request.goal.order, "cancel": False,
                               "status": None, "sequence": [], "waiting": []}
            else:
                report["goals"].append({"order": request.goal.order, "ended": "rejected"})
                if len(report["goals"]) >= args.goals:
                    threading.Timer(0.5, done.set).start()
        if accepted:
            threading.Timer(0.05, execute, [uuid]).start()
        stamp = message("builtin_interfaces/msg/Time", sec=0, nanosec=0)
        return send_goal.response_msg_class(accepted=accepted, stamp=stamp)

    def on_cancel(request):
        uuid = bytes(request.goal_info.goal_id.uuid)
        with lock:
            known = uuid in goals and goals[uuid]["status"] is None
            if known:
                goals[uuid]["cancel"] = True
                report["cancels"] += 1
        return cancel_goal.response_msg_class(
            return_code=NONE if known else UNKNOWN_GOAL, goals_canceling=[])

    def answer_result(key, uuid):
        goal = goals[uuid]
        get_result.send_response(key, get_result.response_msg_class(
            status=goal["status"], result=fibonacci("Result", goal["sequence"])))

    def results():
        while True:
            key, request = get_result.take_request()
            uuid = bytes(request.goal_id.uuid)
            with lock:
                if uuid in goals and goals[uuid]["status"] is None:
                    goals[uuid]["waiting"].append(key)
                elif uuid in goals:
                    answer_result(key, uuid)

    send_goal = ROS2ServiceServer(
        part("send_goal"), "test_msgs/action/Fibonacci_SendGoal", callback=on_goal,
        request_definition="unique_identifier_msgs/UUID goal_id\n"
                           "test_msgs/Fibonacci_Goal goal\n",
        response_definition="bool accepted\nbuiltin_interfaces/Time stamp\n",
        type_hash=SEND_GOAL, **common)
    cancel_goal = ROS2ServiceServer(
        part("cancel_goal"), "action_msgs/srv/CancelGoal", callback=on_cancel,
        request_definition="action_msgs/GoalInfo goal_info\n",
        response_definition="int8 return_code\naction_msgs/GoalInfo[] goals_canceling\n",
        type_hash=CANCEL_GOAL, **common)
    get_result = ROS2ServiceServer(
        part("get_result"), "test_msgs/action/Fibonacci_GetResult", mode="queue",
        request_definition="unique_identifier_msgs/UUID goal_id\n",
        response_definition="int8 status\ntest_msgs/Fibonacci_Result result\n",
        type_hash=GET_RESULT, **common)
    threading.Thread(target=results, daemon=True).start()
    print("ready", flush=True)
    done.wait()
    print(json.dumps(report), flush=True)
    # The SDK's session keeps threads of its own alive: end here.
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
