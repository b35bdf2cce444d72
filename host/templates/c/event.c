// `{{plugin}}`: an event. `check` runs again and again while the event is
// connected; returning true (with *ret set) triggers it with that payload.
// Every `every`-th check (default 3) triggers, one check a second.
#include "radar_guest.h"

// What the plugin keeps, also across a hot swap (RADAR_SAVE, RADAR_RESTORE):
// a new build of this file carries on from the old one's count.
static struct {
    uint32_t checks;
} state;

bool exports_{{snake}}_check(uint32_t *ret) {
    if (!radar_sleep(radar_config_f64("interval_s", 1.0), NULL)) {
        return false; // deactivated meanwhile
    }
    state.checks += 1;
    radar_info("check %u", state.checks);
    int64_t every = radar_config_i64("every", 3);
    if (state.checks % (every > 1 ? every : 1) != 0) {
        return false;
    }
    *ret = state.checks;
    return true;
}

// Hand the state over on a hot swap.
void exports_{{snake}}_snapshot({{snake}}_list_u8_t *ret) { RADAR_SAVE(state, ret); }

bool exports_{{snake}}_restore({{snake}}_list_u8_t *saved, {{snake}}_string_t *err) {
    return RADAR_RESTORE(state, saved, err);
}
