"""A test fixture: `plugins/constructs-program` in Python, over the helpers
of `radar_program`: every construct of the `system` interface (anonymous
slots included) on a system of E (TestEvent counting to 2), F (a timer
event, 3 s) and R (TestResponse counting 2 s). It logs what it saw, fails
when anything is not what the semantics say, and gives the Rust program's
trace."""

from radar_program import (
    Busy, Err, config, info, inject, now, on, once, plugin_state, program, sleep, waitfor,
    whenever,
)


def check(what, ok):
    if not ok:
        raise Err(f"failed: {what}")
    info(f"ok: {what}")


def main():
    check("R starts idle", plugin_state("R") == "idle")
    check("E is inactive", plugin_state("E") == "inactive")
    # waitfor with a timeout that passes first, then without one.
    check("waitfor times out at 1.5 s", waitfor("E", timeout=1.5) is None)
    count = waitfor("E.triggered")
    check("waitfor returns E's payload", count == 2)
    check("at 2 s", now() == 2.0)
    # A scoped whenever with a queue: ends with the block.
    with whenever("E", "R.start", busy=Busy.QUEUE, queue=1) as c:
        check("a connection has its id", len(c.ids()) == 1)
        sleep(4)
        check("R runs meanwhile", plugin_state("R") == "running")
    # A kept connection outlives its object; once ... until.
    once("F", "R.interrupt").keep()
    until = once("E", "R", until="F")
    inject("R.start", 7)
    exited = waitfor("R.exited", timeout=10)
    check("R exited", exited is not None)
    try:
        inject("R.nothing", 1)
        refused = False
    except Err as e:
        refused = "nothing" in e.value
    check("a bad slot is an error", refused)
    check("config reaches the program", config("greeting", "") == "hello")
    # An anonymous slot: its handler runs at each delivery, while the
    # program waits.
    seen = [0]

    def slot(payload):
        info(f"anonymous slot: E.triggered({payload}) at {_duration(now())}")
        seen[0] += 1

    with on("E", slot):
        sleep(5)
        check("the anonymous slot ran twice", seen[0] == 2)
        # A waitfor meanwhile still sees its own signal.
        count = waitfor("E", timeout=3)
        check("waitfor beside an anonymous slot", count == 2)
        # The slot's delivery of that same emission runs at the next wait.
        sleep(0)
        check("the slot ran for that one too", seen[0] == 3)
    del until


def _duration(seconds):
    """Rust's Debug form of a Duration (`8s`, `1.5s`), as the Rust
    program logs it."""
    return f"{seconds:g}s"


WitWorld = program(main)
