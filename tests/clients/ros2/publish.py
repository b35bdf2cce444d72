"""ROS 2 publisher (zenoh-ros2-sdk, rmw_zenoh wire format) for Radar's tests.

    publish.py --port P --topic T --type TYPE [--domain 0]
               [--qos reliable|best_effort] [--interval S] [--wait-subscriber]
               [--timeout S] [--node NAME] MESSAGES_JSON

MESSAGES_JSON is a JSON array of Radar-JSON messages, or @file holding one.
Connects to the Zenoh peer at tcp/127.0.0.1:P and declares a ROS 2 node and
publisher. With --wait-subscriber it first waits until the ROS graph shows a
subscription on T, printing `subscriber: <node> <topic> <type> <qos>`, and
until the subscription's Zenoh subscriber matches the publisher's key. Then
publishes each message (--interval seconds apart) and prints `published N`.
Exits 1 if that takes longer than --timeout.
"""

import argparse
import json
import sys
import time

import ros2_common as rc
from zenoh_ros2_sdk import ROS2Publisher, get_topic_info


def wait_subscriber(pub, args):
    """Polls the graph (the SDK's liveliness-based discovery) for an MS token
    on the topic, then waits for a Zenoh subscriber matching pub's key."""
    while True:
        info = get_topic_info(args.topic, domain_id=args.domain, router_ip="127.0.0.1",
                              router_port=args.port, timeout=0.5, verbose=True)
        if info and info.subscribers:
            break
        time.sleep(0.1)
    for s in info.subscribers:
        print(f"subscriber: {s.node_name} {info.topic_name} {s.topic_type} {s.qos}", flush=True)
    while not pub.pub.matching_status:
        time.sleep(0.05)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--topic", required=True)
    parser.add_argument("--type", required=True)
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--qos", choices=["reliable", "best_effort"], default="reliable")
    parser.add_argument("--interval", type=float, default=0.1)
    parser.add_argument("--wait-subscriber", action="store_true")
    parser.add_argument("--timeout", type=float, default=10.0)
    parser.add_argument("--node", help="node name (default: zenoh_publisher_<random>)")
    parser.add_argument("messages", metavar="MESSAGES_JSON")
    args = parser.parse_args()

    text = args.messages
    if text.startswith("@"):
        with open(text[1:], encoding="utf-8") as f:
            text = f.read()
    messages = json.loads(text)
    if not isinstance(messages, list):
        parser.error("MESSAGES_JSON must be a JSON array")

    stage = "connecting"
    rc.timeout(args.timeout, lambda: f"timeout after {args.timeout}s while {stage}")
    pub = ROS2Publisher(args.topic, args.type, node_name=args.node, domain_id=args.domain,
                        router_ip="127.0.0.1", router_port=args.port, qos=rc.qos(args.qos))
    store = pub.session_mgr.store
    try:
        msgs = [rc.from_json(store, args.type, m) for m in messages]
    except ValueError as err:
        sys.exit(f"publish.py: {err}")
    if args.wait_subscriber:
        stage = f"waiting for a subscriber on {args.topic} (key {pub.keyexpr})"
        wait_subscriber(pub, args)
    stage = "publishing"
    for i, msg in enumerate(msgs):
        if i:
            time.sleep(args.interval)
        pub.publish(**{name: getattr(msg, name) for name, _ in rc.fields(store, args.type)})
    print(f"published {len(msgs)}", flush=True)
    stage = "closing"
    time.sleep(0.2)  # let the last samples leave before the session closes
    pub.close()
    pub.session_mgr.close()
    sys.exit(0)


if __name__ == "__main__":
    main()
