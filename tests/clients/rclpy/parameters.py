"""rclpy's parameter client (rclpy.parameter_client.AsyncParameterClient,
what `ros2 param` is built on, on Fast DDS) reading and setting the
parameters of Radar's node.

    parameters.py [--timeout S] [--radar-node NAME] [--set NAME=INT] -- RADAR_COMMAND...

Starts RADAR_COMMAND (a `radar run`), waits for the node's parameter
services, lists the parameters, gets their values and types, describes
the first, sets NAME to the integer INT, gets NAME again, and tries to
set it to the text "fast" (another type). Prints one JSON object once
Radar's run has ended by itself: what it found, the services of Radar's
node, and Radar's exit code and stderr. Run it inside a private network
namespace (tests/clients/rclpy/netns).
"""

import argparse

import radar_run
from radar_run import spin_until
import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--radar-node", default="radar")
    parser.add_argument("--set", required=True)
    parser.add_argument("radar", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.radar[1:] if args.radar[:1] == ["--"] else args.radar

    rclpy.init()
    node = Node("param_client")
    report = {}
    radar, joined = radar_run.start(command)
    report["joined"] = joined
    if joined is not None:
        client = AsyncParameterClient(node, args.radar_node)
        report["ready"] = client.wait_for_services(timeout_sec=10.0)
        listed = spin_until(node, client.list_parameters(), 10.0)
        names = list(listed.result.names) if listed else []
        report["names"] = names
        report["prefixes"] = list(listed.result.prefixes) if listed else []
        got = spin_until(node, client.get_parameters(names), 10.0)
        report["values"] = {n: parameter_value_to_python(v) for n, v in zip(names, got.values)}
        types = spin_until(node, client.get_parameter_types(names), 10.0)
        report["types"] = {n: int(t) for n, t in zip(names, types.types)}
        described = spin_until(node, client.describe_parameters(names[:1]), 10.0)
        report["read_only"] = bool(described.descriptors[0].read_only)
        name, number = args.set.split("=")
        parameter = Parameter(name, Parameter.Type.INTEGER, int(number))
        results = spin_until(node, client.set_parameters([parameter]), 10.0)
        report["set"] = [{"successful": r.successful, "reason": r.reason}
                         for r in results.results]
        again = spin_until(node, client.get_parameters([name]), 10.0)
        report["after"] = parameter_value_to_python(again.values[0])
        wrong = Parameter(name, Parameter.Type.STRING, "fast")
        results = spin_until(node, client.set_parameters([wrong]), 10.0)
        report["wrong"] = [{"successful": r.successful, "reason": r.reason}
                           for r in results.results]
        report["radar_services"] = dict(
            node.get_service_names_and_types_by_node(args.radar_node, "/")
        )
    radar_run.report_at_end(radar, node, report, args.timeout + 30)


if __name__ == "__main__":
    main()
