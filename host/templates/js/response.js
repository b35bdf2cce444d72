// `{{name}}`: a response. `start` runs when it is started, one step a
// second for `steps` steps (default 3); an interruption ends it at its next
// `sleep`, then `interrupt` and `exit` run.
import { config, info, sleep } from './radar_guest.js';

// The world exports its slots in the interface `slots`.
export const slots = {
    start(payload) {
        info(`started with ${payload}`);
        const steps = config('steps', 3);
        for (let step = 1; step <= steps; step++) {
            sleep(config('interval_s', 1)); // an interruption ends `start`
            info(`step ${step}`);
        }
        return steps;
    },
    interrupt() {
        info('interrupted');
    },
    exit() {
        info('exit');
    },
};
