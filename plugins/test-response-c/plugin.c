// TestResponse (paper Listing 2/3) in C: counts for `count_for_s` seconds
// (default 10), one count every `interval_s` (default 1), and may be
// interrupted between counts. `start` returns the number of counts made.
#include "radar_guest.h"

bool exports_radar_examples_test_response_slots_start(uint32_t trigger, uint32_t *ret,
                                                      radar_interruption_t *err) {
    uint64_t interval = radar_nanos(radar_config_f64("interval_s", 1.0));
    uint64_t total = radar_nanos(radar_config_f64("count_for_s", 10.0));
    uint64_t counts = total / (interval > 0 ? interval : 1);
    radar_info("started by a trigger at count %u", trigger);
    for (uint64_t count = 1; count <= counts; count++) {
        if (!radar_sleep_nanos(interval, err)) {
            return false; // an interruption ends `start` with it
        }
        radar_info("count %llu", (unsigned long long)count);
    }
    *ret = (uint32_t)counts;
    return true;
}

void exports_radar_examples_test_response_slots_interrupt(void) {
    radar_info("interrupted");
}

void exports_radar_examples_test_response_slots_exit(void) {
    radar_info("exit");
}
