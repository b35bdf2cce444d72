// `{{plugin}}`: a deliberative program. It wires the system at run time, as
// the paper's Listing 2 does: whenever Trigger triggers, Responder starts;
// and it waits for Responder's first run to end and logs its result.
#include <string>

#include "radar_program.h"

namespace {

bool wire() {
    // whenever Trigger start Responder, for the rest of the run (without
    // radar_keep, a connection lasts until radar_disconnect).
    radar_connection_t c;
    if (!radar_whenever("Trigger", "Responder", &c)) {
        return false; // the program ends with the host's message
    }
    radar_keep(c);
    // waitfor: the first run's end, or nothing after 30 s.
    char exited[256];
    const int got = radar_waitfor("Responder.exited", 30, exited, sizeof exited);
    if (got < 0) {
        return false;
    }
    const std::string result = got ? exited : "null";
    radar_log(RADAR_INFO, ("Responder exited with " + result).c_str());
    return true;
}

} // namespace

RADAR_PROGRAM(wire)
