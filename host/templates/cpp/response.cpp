// `{{plugin}}`: a response. `start` runs when it is started, one step a
// second for `steps` steps (default 3); an interruption ends it at its next
// sleep, then `interrupt` and `exit` run.
#include <string>

#include "radar_guest.h"

namespace {

// What the plugin keeps, also across a hot swap.
struct State {
    uint32_t starts = 0;
};

State state;

void say(const std::string &line) { radar_log(RADAR_INFO, line.c_str()); }

} // namespace

extern "C" bool exports_local_{{snake}}_slots_start(uint32_t payload, uint32_t *ret,
                                                    radar_interruption_t *err) {
    state.starts += 1;
    say("started with " + std::to_string(payload) + " (start " + std::to_string(state.starts) +
        ")");
    const int64_t steps = radar_config_i64("steps", 3);
    for (int64_t step = 1; step <= steps; ++step) {
        if (!radar_sleep(radar_config_f64("interval_s", 1.0), err)) {
            return false; // an interruption ends `start` with it
        }
        say("step " + std::to_string(step));
    }
    *ret = static_cast<uint32_t>(steps);
    return true;
}

extern "C" void exports_local_{{snake}}_slots_interrupt() { say("interrupted"); }

// Always runs last: after `start` returns, after a fault (on a fresh
// instance) and when the run is stopped. Stop the motors here, with
// constants, so that running it twice is harmless. For a fail-safe that
// holds even when this cannot run, see radar.toml.
extern "C" void exports_local_{{snake}}_slots_exit() { say("exit"); }

// Hand the state over on a hot swap.
extern "C" void exports_local_{{snake}}_slots_snapshot({{snake}}_list_u8_t *ret) {
    RADAR_SAVE(state, ret);
}

extern "C" bool exports_local_{{snake}}_slots_restore({{snake}}_list_u8_t *saved,
                                                      {{snake}}_string_t *err) {
    return RADAR_RESTORE(state, saved, err);
}
