"""Lists the ROS 2 graph seen through rmw_zenoh liveliness tokens, like
`ros2 node list` and `ros2 topic list -t`, for Radar's tests.

    graph.py --port P [--timeout S] [--domain D] [--verbose]
             [--expect-node NAME]... [--expect-topic T]...

Connects to the Zenoh peer at tcp/127.0.0.1:P and prints one line per entity
as it is first seen: `node <ns>/<name>` and `topic <name> <type> pub|sub`
(--verbose appends the node, type hash and QoS string of each endpoint).
Polls until every expected node (full name like /talker, or bare name) and
topic has appeared, then exits 0; exits 1 at the timeout. Without
expectations it polls for --settle seconds (the mesh to the other clients of
the peer at P forms a moment after connecting) and exits 0.
"""

import argparse
import sys
import time

import ros2_common as rc
from zenoh_ros2_sdk import ZenohSession

KINDS = {"MP": "pub", "MS": "sub"}


def entity_lines(token, verbose):
    if token["kind"] == "NN":
        return [f"node {token['fqn']}"]
    if token["kind"] in KINDS and "topic" in token:
        line = f"topic {token['topic']} {token['type']} {KINDS[token['kind']]}"
        if verbose:
            line += f" {token['fqn']} {token['hash']} {token['qos']}"
        return [line]
    return []  # services and clients


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--timeout", type=float, default=10.0)
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--verbose", "-v", action="store_true")
    parser.add_argument("--expect-node", action="append", default=[])
    parser.add_argument("--expect-topic", action="append", default=[])
    parser.add_argument("--settle", type=float, default=1.5)
    args = parser.parse_args()

    nodes, topics = set(), set()
    missing = lambda: ([n for n in args.expect_node if n not in nodes]
                       + [t for t in args.expect_topic if "/" + t.lstrip("/") not in topics])
    rc.timeout(args.timeout, lambda: f"timeout after {args.timeout}s, not seen: {' '.join(missing())}")
    session = ZenohSession.get_instance("127.0.0.1", args.port)
    seen = set()
    expecting = args.expect_node or args.expect_topic
    settled = time.monotonic() + args.settle
    while True:
        lines = set()
        for reply in session.liveliness.get(f"@ros2_lv/{args.domain}/**", timeout=1.0):
            token = reply.ok is not None and rc.parse_token(reply.ok.key_expr)
            if not token:
                continue
            if token["kind"] == "NN":
                nodes.update((token["fqn"], token["node"]))
            elif token["kind"] in KINDS and "topic" in token:
                topics.add(token["topic"])
            lines.update(entity_lines(token, args.verbose))
        for line in sorted(lines - seen):
            print(line, flush=True)
        seen |= lines
        if not missing() if expecting else time.monotonic() > settled:
            break
        time.sleep(0.2)
    session.close()
    sys.exit(0)


if __name__ == "__main__":
    main()
