// Near, in JavaScript: reads the blackboard entry `range` every
// `interval_s` (0.1 s); once per approach nearer than `near_m` (0.5 m) it
// writes the count of approaches to `near-count`, emits its signal
// `too-near` and triggers with the range; it emits `clear` when the range
// is clear again.
import { config, info, interrupted, sleep } from './radar_guest.js';
import { readRange, writeNearCount } from 'radar-examples:near/board';
import { tooNear, clear } from 'radar-examples:near/signals';

let near = false; // lives in the instance, between checks
let count = 0;

export function check() {
    try {
        sleep(config('interval_s', 0.1));
    } catch (e) {
        if (interrupted(e)) return undefined; // deactivated meanwhile
        throw e;
    }
    const range = readRange();
    if (range == null) return undefined; // null until something writes it
    const isNear = range < config('near_m', 0.5);
    const wasNear = near;
    near = isNear;
    if (isNear && !wasNear) {
        count += 1;
        writeNearCount(count);
        tooNear(range);
        info(`too near: ${range.toFixed(2)} m`);
        return range;
    }
    if (wasNear && !isNear) clear();
    return undefined;
}
