// `{{plugin}}`: a response. `start` runs when it is started, one step a
// second for `steps` steps (default 3); an interruption ends it at its next
// sleep, then `interrupt` and `exit` run.
#include "radar_guest.h"

// What the plugin keeps, also across a hot swap.
static struct {
    uint32_t starts;
} state;

bool exports_local_{{snake}}_slots_start(uint32_t payload, uint32_t *ret,
                                         radar_interruption_t *err) {
    state.starts += 1;
    radar_info("started with %u (start %u)", payload, state.starts);
    int64_t steps = radar_config_i64("steps", 3);
    for (int64_t step = 1; step <= steps; step++) {
        if (!radar_sleep(radar_config_f64("interval_s", 1.0), err)) {
            return false; // an interruption ends `start` with it
        }
        radar_info("step %lld", (long long)step);
    }
    *ret = (uint32_t)steps;
    return true;
}

void exports_local_{{snake}}_slots_interrupt(void) { radar_info("interrupted"); }

// Always runs last: after `start` returns, after a fault (on a fresh
// instance) and when the run is stopped. Stop the motors here, with
// constants, so that running it twice is harmless. For a fail-safe that
// holds even when this cannot run, see radar.toml.
void exports_local_{{snake}}_slots_exit(void) { radar_info("exit"); }

// Hand the state over on a hot swap.
void exports_local_{{snake}}_slots_snapshot({{snake}}_list_u8_t *ret) { RADAR_SAVE(state, ret); }

bool exports_local_{{snake}}_slots_restore({{snake}}_list_u8_t *saved, {{snake}}_string_t *err) {
    return RADAR_RESTORE(state, saved, err);
}
