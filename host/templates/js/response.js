// `{{plugin}}`: a response. `start` runs when it is started, one step a
// second for `steps` steps (default 3); an interruption ends it at its next
// `sleep`, then `interrupt` and `exit` run.
import { State, config, info, sleep } from './radar_guest.js';

// What the plugin keeps, also across a hot swap.
const state = new State({ starts: 0 });

// The world exports its slots in the interface `slots`.
export const slots = {
    start(payload) {
        state.starts += 1;
        info(`started with ${payload} (start ${state.starts})`);
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
    // Always runs last: after `start` returns, after a fault (on a fresh
    // instance) and when the run is stopped. Stop the motors here, with
    // constants, so that running it twice is harmless. For a fail-safe that
    // holds even when this cannot run, see radar.toml.
    exit() {
        info('exit');
    },
    // Hand the state over on a hot swap.
    snapshot: state.snapshot,
    restore: state.restore,
};
