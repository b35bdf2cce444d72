// TestEvent (paper Listing 2/3) in C++: counts up to `count_to` (5), one
// count every `interval_s` (1 s), then resets its counter and triggers with
// the count. The counter lives in the instance, between checks.
#include "radar_guest.h"

namespace {

// The event's state: an object of the instance, between checks.
struct Counter {
    uint32_t count = 0;

    // The count once it reaches `to`, starting again from 0.
    bool step(int64_t to, uint32_t &reached) {
        if (++count < to) return false;
        reached = count;
        count = 0;
        return true;
    }
};

Counter counter;

} // namespace

extern "C" bool exports_test_event_check(uint32_t *ret) {
    if (!radar_sleep(radar_config_f64("interval_s", 1.0), nullptr)) {
        return false; // deactivated meanwhile
    }
    return counter.step(radar_config_i64("count_to", 5), *ret);
}
