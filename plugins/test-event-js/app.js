// TestEvent (paper Listing 2/3) in JavaScript: counts up to `count_to` (5),
// one count every `interval_s` (1 s), then resets its counter and triggers
// with the count. The counter lives in the instance, between checks.
import { config, interrupted, nanos, sleepNanos } from './radar_guest.js';

let count = 0;

export function check() {
    try {
        sleepNanos(nanos(config('interval_s', 1)));
    } catch (e) {
        if (interrupted(e)) return undefined;
        throw e;
    }
    const countTo = config('count_to', 5);
    count += 1;
    if (count < countTo) return undefined;
    const reached = count;
    count = 0;
    return reached;
}
