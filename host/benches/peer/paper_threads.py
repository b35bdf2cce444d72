"""The paper's own RADAR implementation, as its section II-A describes it:
each response a Python thread sleeping on a coordination object (a
condition) until its start slot is signalled; every active event checked in
sequence by one Event Manager thread; a Connection Manager that tracks who
listens to which signal and calls the listeners when one is emitted.

Written for `benches/peer.rs`, which times it beside Radar on the same
path: an event triggers, the connection manager delivers `triggered` to
the response's start slot, the response's thread wakes and its start
begins. Prints one JSON line: the trigger -> start latencies in microseconds.

    python3 paper_threads.py PERIOD_S COUNT
"""

import json
import sys
import threading
import time


class ConnectionManager:
    """Who listens to which signal; an emission informs every listener."""

    def __init__(self):
        self._lock = threading.Lock()
        self._listeners = {}

    def connect(self, signal, slot):
        with self._lock:
            self._listeners.setdefault(signal, []).append(slot)

    def emit(self, signal, payload):
        with self._lock:
            listeners = list(self._listeners.get(signal, ()))
        for slot in listeners:
            slot(payload)


class Response(threading.Thread):
    """A response: its own thread, asleep on a condition until started."""

    def __init__(self, name, on_start):
        super().__init__(name=name, daemon=True)
        self._cond = threading.Condition()
        self._pending = None
        self._on_start = on_start

    # The start slot, an accessor with a lock, as the paper's were.
    def start_slot(self, payload):
        with self._cond:
            self._pending = payload
            self._cond.notify()

    def run(self):
        while True:
            with self._cond:
                while self._pending is None:
                    self._cond.wait()
                payload, self._pending = self._pending, None
            self._on_start(payload)


class Event:
    """An event: a condition check and its `triggered` signal."""

    def __init__(self, name, check, connections):
        self.name = name
        self._check = check
        self._connections = connections

    def poll(self):
        payload = self._check()
        if payload is not None:
            self._connections.emit(self.name + ".triggered", payload)


class EventManager(threading.Thread):
    """All active events, checked in sequence by one thread."""

    def __init__(self, period_s):
        super().__init__(name="event-manager", daemon=True)
        self._events = []
        self._period = period_s

    def activate(self, event):
        self._events.append(event)

    def run(self):
        next_round = time.monotonic()
        while True:
            for event in list(self._events):
                event.poll()
            next_round += self._period
            time.sleep(max(0.0, next_round - time.monotonic()))


def main():
    period_s = float(sys.argv[1])
    count = int(sys.argv[2])
    latencies = []
    done = threading.Event()

    def on_start(triggered_ns):
        latencies.append((time.perf_counter_ns() - triggered_ns) / 1e3)
        if len(latencies) >= count:
            done.set()

    connections = ConnectionManager()
    response = Response("R", on_start)
    response.start()
    # The check triggers each time, with the time it triggered.
    event = Event("E", time.perf_counter_ns, connections)
    connections.connect("E.triggered", response.start_slot)
    manager = EventManager(period_s)
    manager.activate(event)
    manager.start()
    done.wait()
    print(json.dumps({"trigger_to_start_us": latencies[:count]}))


if __name__ == "__main__":
    main()
