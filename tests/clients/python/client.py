"""A plain Zenoh client, written against Radar's documented key expressions
only (docs/network.md): it follows a running system's signals, board writes
and trace, writes a blackboard entry and injects into a slot with puts, and
prints what it saw as one JSON object.

    client.py ENDPOINT SYSTEM SECONDS [KEY]

KEY is the system's local control key (control = "local"), sent as the
puts' attachment; leave it out for control = "open".
"""

import json
import sys
import threading
import time

import zenoh


def main():
    endpoint, system, seconds = sys.argv[1], sys.argv[2], float(sys.argv[3])
    key = sys.argv[4] if len(sys.argv) > 4 else None
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps("client"))
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    seen = {"signals": [], "board": [], "trace_kinds": [], "systems": []}
    lock = threading.Lock()

    def on_signal(sample):
        with lock:
            seen["signals"].append(
                {"key": str(sample.key_expr), "payload": json.loads(sample.payload.to_string())}
            )

    def on_board(sample):
        with lock:
            seen["board"].append(
                {"key": str(sample.key_expr), "value": json.loads(sample.payload.to_string())}
            )

    def on_trace(sample):
        with lock:
            seen["trace_kinds"].append(json.loads(sample.payload.to_string())["kind"])

    with zenoh.open(conf) as session:
        for reply in session.liveliness().get("radar/*/alive"):
            if reply.ok is not None:
                seen["systems"].append(str(reply.ok.key_expr))
        subs = [
            session.declare_subscriber(f"radar/{system}/signal/**", on_signal),
            session.declare_subscriber(f"radar/{system}/board/**", on_board),
            session.declare_subscriber(f"radar/{system}/trace", on_trace),
        ]
        time.sleep(0.5)
        extra = {"attachment": key.encode()} if key else {}
        session.put(f"radar/{system}/write/range", "0.3", **extra)
        session.put(f"radar/{system}/write/range", "\"not a number\"", **extra)
        session.put(f"radar/{system}/inject/Avoid/start", "0.25", **extra)
        time.sleep(seconds)
        for sub in subs:
            sub.undeclare()
    with lock:
        print(json.dumps(seen))


if __name__ == "__main__":
    main()
