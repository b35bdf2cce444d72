"""The blackboard example's deliberative part (`radar run --example
obstacle`, `radar::example::obstacle_program`) as a Python component:
`whenever Obstacle start Avoid`; a simulated range sensor writes a reading
to the blackboard every 0.5 s; after each approach the program reads how
many obstacles Avoid has handed back (the entry `avoided`) and fails if the
count is not what the readings make it.

The native program runs the sensor on a thread of its own; a component has
one, so here the readings are written between waits and an anonymous slot
checks each of Avoid's exits as it comes. The plugins see the same
blackboard at the same times: the run is the native one's."""

from radar_program import Err, board_read, board_write, on, program, sleep, wait_until, whenever

# One every 0.5 s: two approaches, the first too close twice in a row.
RANGE_READINGS = [2.0, 1.6, 1.1, 0.45, 0.3, 0.8, 1.5, 2.0, 1.2, 0.6, 0.35, 1.8]
APPROACHES = 2


def main():
    handed_back = []

    def check_count(_exited):
        handed_back.append(board_read("avoided"))
        expected = len(handed_back)
        if handed_back[-1] != expected:
            raise Err(f"Avoid handed back {handed_back[-1]}, expected {expected}")

    with whenever("Obstacle", "Avoid"), on("Avoid.exited", check_count):
        for reading in RANGE_READINGS:
            board_write("range", reading)
            sleep(0.5)
        if not wait_until(lambda: len(handed_back) == APPROACHES, timeout=10):
            raise Err(f"Avoid handed back {len(handed_back)} of {APPROACHES} in time")


WitWorld = program(main)
