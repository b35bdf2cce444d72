"""Helpers for Radar plugins written in Python (built with componentize-py).

The bindings componentize-py generates for a plugin's world are complete
but low level: nanoseconds, `Err` exceptions, text-only configuration.
These helpers make the usual things read like Python:

    from radar_guest import Interrupted, sleep, info, config

    class WitWorld(wit_world.WitWorld):
        def start(self, trigger: int) -> int:
            info(f"started with {trigger}")
            sleep(config("interval_s", 1.0))   # raises Interrupted
            return 1

`sleep` raises `Interrupted` when the host asks the running slot to stop;
left uncaught in a slot that returns `result<_, interruption>`, it becomes
that slot's error, as the Rust SDK's `?` does. `except Interrupted` catches
interruptions only; `except Err` catches them and any other error result.
"""

import functools
import json

import wit_world
from componentize_py_types import Err
from wit_world.imports import config as host_config, logging, types

try:  # every plugin world imports the clock; a program's world does not
    from wit_world.imports import clock
except ImportError:
    clock = None

class Interrupted(Err):
    """Raised by `sleep` and `yield_now` when the host asks the running slot
    to stop; `.value` is the reason (`types.Interruption`).

    It is an `Err`, so left uncaught in a slot that returns
    `result<_, interruption>` it becomes that slot's error; but
    `except Interrupted` catches only interruptions, not the error results
    of other host calls."""


def _interruptible(call, *args) -> None:
    try:
        call(*args)
    except Interrupted:
        raise
    except Err as e:
        raise Interrupted(e.value) from None


# componentize-py turns only an exception of type `Err` itself (not of a
# subclass) into a slot's error result. So `start`, the slot that returns
# `result<_, interruption>`, is wrapped in every class that implements the
# world's exports: an `Interrupted` leaving it leaves as a plain `Err`.


def _plain_err(start):
    @functools.wraps(start)
    def slot(self, *args):
        try:
            return start(self, *args)
        except Interrupted as e:
            raise Err(e.value) from None

    slot._radar_wrapped = True
    return slot


def _wrap_start_of_subclasses(protocol) -> None:
    def hook(cls, **kwargs):
        super(protocol, cls).__init_subclass__(**kwargs)
        start = cls.__dict__.get("start")
        if callable(start) and not getattr(start, "_radar_wrapped", False):
            cls.start = _plain_err(start)

    protocol.__init_subclass__ = classmethod(hook)


def _export_protocols():
    yield wit_world.WitWorld
    try:
        from wit_world import exports
    except ImportError:
        return
    for value in vars(exports).values():
        if isinstance(value, type) and value.__module__.startswith("wit_world"):
            yield value


for _protocol in _export_protocols():
    if hasattr(_protocol, "start"):
        _wrap_start_of_subclasses(_protocol)

Level = types.Level


def now() -> float:
    """Scheduler time in seconds since the system began to run."""
    return clock.now() / 1e9


def sleep(seconds: float) -> None:
    """Waits `seconds` of scheduler time (virtual in tests); raises
    `Interrupted` if the host asks the running slot to stop."""
    _interruptible(clock.sleep, nanos(seconds))


def sleep_nanos(nanos_: int) -> None:
    """`sleep` in whole nanoseconds."""
    _interruptible(clock.sleep, nanos_)


def yield_now() -> None:
    """Lets every other task ready at this instant run first; raises
    `Interrupted` if the host asks the running slot to stop."""
    _interruptible(clock.yield_)


def interrupted():
    """Why the host asked the running slot to stop, or None."""
    return clock.interrupted()


def nanos(seconds: float) -> int:
    """Seconds as whole nanoseconds (never negative)."""
    return max(0, int(seconds * 1_000_000_000))


def log(level: types.Level, message: str) -> None:
    """Records `message` in the system's trace."""
    logging.log(level, message)


def info(message: str) -> None:
    logging.log(types.Level.INFO, message)


def debug(message: str) -> None:
    logging.log(types.Level.DEBUG, message)


def warn(message: str) -> None:
    logging.log(types.Level.WARN, message)


def error(message: str) -> None:
    logging.log(types.Level.ERROR, message)


def config(key: str, default=None):
    """The configuration value `key`, parsed as the type of `default` (text
    if there is no default); `default` if it is missing or does not parse."""
    text = host_config.get(key)
    if text is None:
        return default
    if default is None or isinstance(default, str):
        return text
    try:
        if isinstance(default, bool):
            return text.strip().lower() in ("true", "1", "yes")
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
    except ValueError:
        return default
    return text


def config_keys() -> list:
    """Every configured key, sorted."""
    return host_config.keys()


class State:
    """What a plugin keeps across a hot swap, as named fields with their
    first values:

        state = State(count=0, near=False)

        class WitWorld(wit_world.WitWorld):
            def check(self):
                state.count += 1
                ...
            snapshot = state.snapshot   # the world exports snapshot and
            restore = state.restore     # restore: hand the state over

    `snapshot` gives the fields as JSON; `restore` takes the old version's
    fields that this version still has (a new field keeps its first value,
    a field the new version dropped is ignored) and refuses what is not
    such JSON, which rolls the swap back. Keep it at module level: every
    export sees it."""

    def __init__(self, **fields) -> None:
        self.__dict__.update(fields)

    def snapshot(self) -> bytes:
        """The fields as JSON bytes, for the world's `snapshot`."""
        return json.dumps(vars(self), sort_keys=True).encode()

    def restore(self, saved: bytes) -> None:
        """The old version's fields back, for the world's `restore`;
        raises `Err` (the swap rolls back) if `saved` is not theirs."""
        try:
            fields = json.loads(bytes(saved))
        except ValueError as e:
            raise Err(f"the old version's state does not fit: {e}") from None
        if not isinstance(fields, dict):
            raise Err("the old version's state does not fit: not a table of fields")
        for name in vars(self).keys() & fields.keys():
            setattr(self, name, fields[name])
