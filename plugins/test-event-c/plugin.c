// TestEvent (paper Listing 2/3) in C: counts up to `count_to` (5), one
// count every `interval_s` (1 s), then resets its counter and triggers with
// the count. The counter lives in the instance, between checks.
#include "radar_guest.h"

static uint32_t count = 0;

bool exports_test_event_check(uint32_t *ret) {
    if (!radar_sleep(radar_config_f64("interval_s", 1.0), NULL)) {
        return false; // deactivated meanwhile
    }
    int64_t count_to = radar_config_i64("count_to", 5);
    count += 1;
    if (count < count_to) {
        return false;
    }
    *ret = count;
    count = 0;
    return true;
}
