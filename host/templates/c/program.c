// `{{plugin}}`: a deliberative program. It wires the system at run time, as
// the paper's Listing 2 does: whenever Trigger triggers, Responder starts;
// and it waits for Responder's first run to end and logs its result.
#include "radar_program.h"

static bool wire(void) {
    // whenever Trigger start Responder, for the rest of the run (without
    // radar_keep, a connection lasts until radar_disconnect).
    radar_connection_t c;
    if (!radar_whenever("Trigger", "Responder", &c)) {
        return false; // the program ends with the host's message
    }
    radar_keep(c);
    // waitfor: the first run's end, or nothing after 30 s.
    char exited[256];
    int got = radar_waitfor("Responder.exited", 30, exited, sizeof exited);
    if (got < 0) {
        return false;
    }
    radar_info("Responder exited with %s", got ? exited : "null");
    return true;
}

RADAR_PROGRAM(wire)
