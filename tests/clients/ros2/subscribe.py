"""ROS 2 subscriber (zenoh-ros2-sdk, rmw_zenoh wire format) for Radar's tests.

    subscribe.py --port P --topic T --type TYPE [--count N] [--timeout S]
                 [--domain D] [--qos reliable|best_effort] [--node NAME]

Connects to the Zenoh peer at tcp/127.0.0.1:P, declares a ROS 2 node and
subscription (liveliness tokens) and prints `ready`. Then for each message
prints two lines: `attachment {"seq": .., "ts": .., "gid": "<hex>"}` (the
rmw_zenoh attachment) and the message as Radar JSON. Exits 0 after N
messages, 1 at the timeout.
"""

import argparse
import json
import struct
import sys
import threading

import ros2_common as rc
from zenoh_ros2_sdk import ROS2Subscriber, ZenohSession


def parse_attachment(raw):
    """rmw_zenoh attachment: i64 sequence number, i64 source timestamp (ns),
    GID as a length-prefixed byte array (all little-endian)."""
    if raw is None:
        return None
    raw = raw.to_bytes()
    seq, ts, gid_len = struct.unpack_from("<qqB", raw)
    return {"seq": seq, "ts": ts, "gid": raw[17:17 + gid_len].hex()}


class Subscriber(ROS2Subscriber):
    """The SDK subscriber, calling on_message(msg, attachment): the SDK hands
    its callback the deserialized message only."""

    def __init__(self, topic, msg_type, on_message, **kwargs):
        self.attachment = None
        super().__init__(topic, msg_type, lambda msg: on_message(msg, self.attachment), **kwargs)

    def _listener(self, sample):
        self.attachment = parse_attachment(sample.attachment)
        super()._listener(sample)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--topic", required=True)
    parser.add_argument("--type", required=True)
    parser.add_argument("--count", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=10.0)
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--qos", choices=["reliable", "best_effort"], default="reliable")
    parser.add_argument("--node", help="node name (default: zenoh_subscriber_<random>)")
    args = parser.parse_args()

    received = 0
    ready, done = threading.Event(), threading.Event()
    rc.timeout(args.timeout, lambda: f"timeout: received {received} of {args.count} "
               f"messages on {args.topic} after {args.timeout}s")

    def on_message(msg, attachment):
        nonlocal received
        ready.wait()  # print nothing before `ready`
        if done.is_set():
            return
        store = ZenohSession.get_instance().store
        lines = [json.dumps(rc.to_json(store, args.type, msg), ensure_ascii=False)]
        if attachment is not None:
            lines.insert(0, "attachment " + json.dumps(attachment))
        print("\n".join(lines), flush=True)
        received += 1
        if received >= args.count:
            done.set()

    sub = Subscriber(args.topic, args.type, on_message, node_name=args.node,
                     domain_id=args.domain, router_ip="127.0.0.1", router_port=args.port,
                     qos=rc.qos(args.qos))
    print("ready", flush=True)
    ready.set()
    done.wait()
    sub.close()
    sub.session_mgr.close()
    sys.exit(0)


if __name__ == "__main__":
    main()
