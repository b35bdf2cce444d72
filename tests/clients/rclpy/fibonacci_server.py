"""A test_msgs/action/Fibonacci server written with rclpy, shared by the
drivers that put one beside Radar (action.py at /fib, robot.py's stand-in
docking server at /dock).

Each goal of order n is worked through in n steps of `step` seconds, with
the sequence so far as feedback after each; a goal of order above 40 is
rejected; a cancel is accepted and ends the goal as canceled at its next
step. How each goal ended goes into `report["goals"]` and each cancel
asked for counts in `report["cancels"]`, under `lock`.
"""

import time

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from test_msgs.action import Fibonacci


def serve(node, name, step, report, lock):
    """Serves the action `name` on `node` (spun by a multi-threaded
    executor, so that goals are worked through beside other callbacks)."""
    report.setdefault("goals", [])
    report.setdefault("cancels", 0)

    def on_goal(goal):
        if goal.order > 40:
            with lock:
                report["goals"].append({"order": goal.order, "ended": "rejected"})
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_cancel(_handle):
        with lock:
            report["cancels"] += 1
        return CancelResponse.ACCEPT

    def execute(handle):
        sequence = [0, 1]
        result = Fibonacci.Result()
        for _ in range(1, handle.request.order):
            time.sleep(step)
            if handle.is_cancel_requested:
                handle.canceled()
                result.sequence = sequence
                with lock:
                    report["goals"].append({"order": handle.request.order, "ended": "canceled"})
                return result
            sequence.append(sequence[-1] + sequence[-2])
            feedback = Fibonacci.Feedback()
            feedback.sequence = sequence
            handle.publish_feedback(feedback)
        handle.succeed()
        result.sequence = sequence
        with lock:
            report["goals"].append({"order": handle.request.order, "ended": "succeeded"})
        return result

    return ActionServer(
        node,
        Fibonacci,
        name,
        execute_callback=execute,
        goal_callback=on_goal,
        cancel_callback=on_cancel,
        callback_group=ReentrantCallbackGroup(),
    )
