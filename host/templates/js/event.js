// `{{name}}`: an event. `check` runs again and again while the event is
// connected; returning a value triggers it with that payload. Every
// `every`-th check (default 3) triggers, one check a second.
import { config, info, interrupted, sleep } from './radar_guest.js';

let checks = 0; // lives in the instance, between checks

export function check() {
    try {
        sleep(config('interval_s', 1));
    } catch (e) {
        if (interrupted(e)) return undefined; // deactivated meanwhile
        throw e;
    }
    checks += 1;
    info(`check ${checks}`);
    return checks % Math.max(config('every', 3), 1) === 0 ? checks : undefined;
}
