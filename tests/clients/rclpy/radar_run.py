"""Runs `radar run` beside the rclpy test nodes: started, ready once it has
joined the ROS 2 graph, and waited for at its end."""

import json
import subprocess
import threading
import time

import rclpy


def start(command, timeout=60):
    """Starts `command` (a `radar run`) and reads its stdout until its
    `ros2: node` line; returns the process and that line (None if it never
    came). The rest of stdout is drained on a thread so that Radar never
    blocks on a full pipe."""
    radar = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # Its stderr is read as it comes, so that Radar never blocks on it.
    radar.stderr_lines = []
    threading.Thread(
        target=lambda: radar.stderr_lines.extend(radar.stderr), daemon=True
    ).start()
    deadline = time.time() + timeout
    while time.time() < deadline:
        line = radar.stdout.readline()
        if not line:
            break
        if line.startswith("ros2: node"):
            threading.Thread(target=radar.stdout.read, daemon=True).start()
            return radar, line.strip()
    radar.kill()
    radar.wait()
    return radar, None


def spin_until(node, future, timeout):
    """Spins `node` until `future` is done, at most `timeout` seconds: its
    result, or None."""
    deadline = time.time() + timeout
    while not future.done() and time.time() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    return future.result() if future.done() else None


def finish(radar, timeout):
    """Waits for the run to end by itself (its `--for`), stopping it past
    `timeout` seconds; returns its exit code and stderr."""
    try:
        radar.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        radar.terminate()
        radar.wait()
    time.sleep(0.1)  # the last lines of stderr, read on their thread
    return radar.returncode, "".join(radar.stderr_lines)


def report_at_end(radar, node, report, timeout):
    """Adds the graph as `node` sees it, then Radar's exit code and stderr
    once its run has ended (see `finish`) to `report`, shuts rclpy down and
    prints the report as one JSON line."""
    report.update(graph(node))
    report["radar_exit"], report["radar_stderr"] = finish(radar, timeout)
    node.destroy_node()
    rclpy.shutdown()
    print(json.dumps(report))


def graph(node):
    """ROS 2's graph as `node` sees it: node names and topics with types."""
    return {
        "nodes": sorted(
            f"{ns.rstrip('/')}/{name}" for name, ns in node.get_node_names_and_namespaces()
        ),
        "topics": dict(node.get_topic_names_and_types()),
    }
