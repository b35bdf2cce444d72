// `{{plugin}}`: an event. `check` runs again and again while the event is
// connected; returning a value triggers it with that payload. Every
// `every`-th check (default 3) triggers, one check a second.
import { State, config, info, interrupted, sleep } from './radar_guest.js';

// What the plugin keeps, also across a hot swap: a new version of this
// file carries on from the old one's count.
const state = new State({ checks: 0 });

export function check() {
    try {
        sleep(config('interval_s', 1));
    } catch (e) {
        if (interrupted(e)) return undefined; // deactivated meanwhile
        throw e;
    }
    state.checks += 1;
    info(`check ${state.checks}`);
    return state.checks % Math.max(config('every', 3), 1) === 0 ? state.checks : undefined;
}

// Hand the state over on a hot swap.
export const snapshot = state.snapshot;
export const restore = state.restore;
