"""Helpers for deliberative programs written in Python (the
`radar:reactive/deliberative` world, built with componentize-py), as short
as the Rust SDK's `radar_guest::deliberative`:

    from radar_program import program, whenever, once, sleep, waitfor

    def main():
        with whenever("TestEvent", "TestResponse"):      # start, scoped
            with once("TestEvent2", "TestResponse.interrupt"):
                for _ in range(15):
                    sleep(1)
        waitfor("TestResponse.exited", timeout=10)

    WitWorld = program(main)

Connections are context managers, so RADAR's scoped connections are `with`
blocks; a connection held in a variable also ends when the variable goes
(at the end of the function), and `.keep()` keeps one for the rest of the
run. A call the system refuses raises `Err` with the host's message; left
uncaught, it ends the program with that message, as the Rust SDK's `?`
does. Payloads are Python values (JSON on the way).
"""

import json

import wit_world
from componentize_py_types import Err
from radar_guest import Level, config, config_keys, debug, error, info, log, warn
from wit_world.imports import system

__all__ = [
    "Busy", "Connection", "Err", "Level", "Listener", "board_read", "board_write",
    "config", "config_keys", "debug", "error", "info", "inject", "log", "now", "on",
    "on_once", "once", "plugin_state", "program", "sleep", "stop", "wait_until", "waitfor",
    "warn", "whenever",
]

Busy = system.Busy


def _nanos(seconds) -> int:
    return max(0, int(seconds * 1_000_000_000))


class Connection:
    """A live connection (two, for `... until`): it ends at the end of a
    `with` block, when nothing refers to it any more, or at `close()`;
    `keep()` keeps it for the rest of the run."""

    def __init__(self, handle) -> None:
        self._handle = handle

    def ids(self) -> list:
        """Its ids in the trace."""
        return self._handle.ids() if self._handle else []

    def keep(self) -> None:
        """Keeps it for the rest of the run, whatever becomes of this object
        (an anonymous slot keeps its handler)."""
        handle, self._handle = self._handle, None
        if handle is not None:
            handle.keep()
            handle.__exit__(None, None, None)

    def close(self) -> None:
        """Removes it now (unless kept)."""
        handle, self._handle = self._handle, None
        if handle is not None:
            handle.__exit__(None, None, None)

    def __enter__(self):
        return self

    def __exit__(self, *_) -> None:
        self.close()

    def __del__(self) -> None:
        self.close()


def _connect(mode, source, target, until, busy, queue, min_interval):
    if "." not in target:
        target += ".start"
    link = system.Link(
        source,
        target,
        mode,
        until,
        busy,
        queue,
        None if min_interval is None else _nanos(min_interval),
    )
    return Connection(system.connect(link))


def whenever(source, target, *, until=None, busy=Busy.DROP, queue=1, min_interval=None):
    """`whenever source target`: every emission of `source` (`Plugin.signal`,
    or `Plugin` for its `triggered`) goes to `target` (`Plugin.slot`, or
    `Plugin` for its `start`). `until`: a signal that interrupts what this
    starts; `busy`: what a start does while the response runs (`Busy.DROP`,
    `Busy.QUEUE` with `queue` waiting at most, `Busy.RESTART`);
    `min_interval`: seconds under which a second emission is dropped."""
    return _connect(system.Mode.WHENEVER, source, target, until, busy, queue, min_interval)


def once(source, target, *, until=None, busy=Busy.DROP, queue=1, min_interval=None):
    """`once source target`: the first emission only (see `whenever`)."""
    return _connect(system.Mode.ONCE, source, target, until, busy, queue, min_interval)


# The handlers of the program's anonymous slots, by connection id.
_handlers = {}


def _dispatch(delivery) -> None:
    # Taken out while it runs: a handler may wait, and so run others.
    handler = _handlers.pop(delivery.connection, None)
    if handler is None:
        return
    try:
        handler(json.loads(delivery.payload))
    finally:
        _handlers.setdefault(delivery.connection, handler)


def _wait(deadline, signal, condition=None):
    """Waits, running anonymous slots' handlers as their deliveries come;
    the signal's payload (JSON text), or "" once `condition()` holds after
    a handler, or None at the deadline."""
    while True:
        woke = system.wait(deadline, signal)
        if isinstance(woke, system.Woke_Deadline):
            return None
        if isinstance(woke, system.Woke_Signal):
            return woke.value
        _dispatch(woke.value)
        if condition is not None and condition():
            return ""


class Listener(Connection):
    """An anonymous slot (see `on`): it ends as a connection does, and its
    handler with it."""

    def __init__(self, handle, handler) -> None:
        super().__init__(handle)
        self._id = handle.ids()[0]
        _handlers[self._id] = handler

    def close(self) -> None:
        _handlers.pop(getattr(self, "_id", None), None)
        super().close()


def on(signal, handler):
    """An anonymous slot: `handler(payload)` runs at every emission of
    `signal`, while the program waits (in `sleep` or `waitfor`), at the
    time of the delivery."""
    return Listener(system.listen(signal, system.Mode.WHENEVER), handler)


def on_once(signal, handler):
    """`on` for the first emission only."""
    return Listener(system.listen(signal, system.Mode.ONCE), handler)


def sleep(seconds) -> None:
    """Waits `seconds` of the system's time; anonymous slots run meanwhile."""
    _wait(system.now() + _nanos(seconds), None)


def waitfor(signal, timeout=None):
    """Waits for `signal` and returns its payload (`()` for a signal without
    one), or `None` when `timeout` seconds pass first. Anonymous slots run
    meanwhile."""
    deadline = None if timeout is None else system.now() + _nanos(timeout)
    payload = _wait(deadline, signal)
    if payload is None:
        return None
    value = json.loads(payload)
    return () if value is None else value


def wait_until(condition, timeout=None) -> bool:
    """Waits until `condition()` holds, checked now and after each of the
    anonymous slots' handlers runs (what they see is what changes it);
    False if `timeout` seconds pass first."""
    if condition():
        return True
    deadline = None if timeout is None else system.now() + _nanos(timeout)
    return _wait(deadline, None, condition) is not None


def now() -> float:
    """The system's time in seconds since the run began."""
    return system.now() / 1e9


def inject(slot, payload=None) -> None:
    """Sends `payload` straight into `slot` (`Plugin.slot`)."""
    system.inject(slot, json.dumps(payload))


def plugin_state(plugin) -> str:
    """`inactive`, `active`, `idle`, `running`, `interrupting`, `exiting` or
    `error`."""
    return system.plugin_state(plugin)


def board_read(entry):
    """A blackboard entry's value, or None if nothing wrote it yet."""
    value = system.board_read(entry)
    return None if value is None else json.loads(value)


def board_write(entry, value) -> None:
    """Writes a blackboard entry (checked against its type)."""
    system.board_write(entry, json.dumps(value))


def stop(status=0) -> None:
    """Ends the program at once (it does not return) and the run with it,
    with `status` for `radar run` to exit with (0: success): every running
    response runs its exit, nothing new begins. Returning from `main` ends
    the run too (status 0, or 1 with its error), unless it kept
    connections."""
    system.stop(status)


def program(main):
    """The world's class for a program whose body is `main()`:
    `WitWorld = program(main)`. An exception leaving `main` ends the
    program with its message."""

    class WitWorld(wit_world.WitWorld):
        def run(self) -> None:
            try:
                main()
            except Err:
                raise
            except Exception as e:
                raise Err(f"{type(e).__name__}: {e}") from None

    return WitWorld
