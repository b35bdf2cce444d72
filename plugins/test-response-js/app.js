// TestResponse (paper Listing 2/3) in JavaScript: counts for `count_for_s`
// seconds (default 10), one count every `interval_s` (default 1), and may be
// interrupted between counts. `start` returns the number of counts made.
import { config, info, nanos, sleepNanos } from './radar_guest.js';

// The world exports its slots in the interface `slots`.
export const slots = {
    start(trigger) {
        const interval = nanos(config('interval_s', 1));
        const total = nanos(config('count_for_s', 10));
        const counts = Math.floor(total / Math.max(interval, 1));
        info(`started by a trigger at count ${trigger}`);
        for (let count = 1; count <= counts; count++) {
            sleepNanos(interval); // an interruption ends `start` with it
            info(`count ${count}`);
        }
        return counts;
    },
    interrupt() {
        info('interrupted');
    },
    exit() {
        info('exit');
    },
};
