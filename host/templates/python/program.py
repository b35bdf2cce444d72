"""`{{plugin}}`: a deliberative program. It wires the system at run time, as
the paper's Listing 2 does: whenever Trigger triggers, Responder starts;
and it waits for Responder's first run to end and logs its result."""

from radar_program import info, program, waitfor, whenever


def main():
    # whenever Trigger start Responder, for the rest of the run (without
    # keep(), a connection ends with the function that made it, or with
    # its `with` block).
    whenever("Trigger", "Responder").keep()
    # waitfor: the first run's end, or None after 30 s.
    exited = waitfor("Responder.exited", timeout=30)
    info(f"Responder exited with {exited}")


WitWorld = program(main)
