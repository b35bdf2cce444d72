// TestResponse (paper Listing 2/3) in C++: counts for `count_for_s` seconds
// (default 10), one count every `interval_s` (default 1), and may be
// interrupted between counts. `start` returns the number of counts made.
#include <algorithm>
#include <string>

#include "radar_guest.h"

namespace {

void say(const std::string &line) { radar_log(RADAR_INFO, line.c_str()); }

} // namespace

extern "C" bool exports_radar_examples_test_response_slots_start(
    uint32_t trigger, uint32_t *ret, radar_interruption_t *err) {
    const uint64_t interval = radar_nanos(radar_config_f64("interval_s", 1.0));
    const uint64_t total = radar_nanos(radar_config_f64("count_for_s", 10.0));
    const uint64_t counts = total / std::max<uint64_t>(interval, 1);
    say("started by a trigger at count " + std::to_string(trigger));
    for (uint64_t count = 1; count <= counts; ++count) {
        if (!radar_sleep_nanos(interval, err)) {
            return false; // an interruption ends `start` with it
        }
        say("count " + std::to_string(count));
    }
    *ret = static_cast<uint32_t>(counts);
    return true;
}

extern "C" void exports_radar_examples_test_response_slots_interrupt() { say("interrupted"); }

extern "C" void exports_radar_examples_test_response_slots_exit() { say("exit"); }
