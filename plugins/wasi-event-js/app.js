// Test fixture: every second, triggers with what JavaScript reads through
// WASI: Date.now(), the monotonic clock (ns since the first check) and
// Math.random(). Under the virtual clock all must be deterministic.
import { interrupted, sleepNanos } from './radar_guest.js';

let first;

// WIT u64 is a JavaScript number here (QuickJS backend).
function monotonicNs() {
    // performance.now() where the engine has it, else the wall clock.
    const ms = typeof performance !== 'undefined' ? performance.now() : Date.now();
    return Math.round(ms * 1e6);
}

export function check() {
    try {
        sleepNanos(1000000000);
    } catch (e) {
        if (interrupted(e)) return undefined;
        throw e;
    }
    const now = monotonicNs();
    if (first === undefined) first = now;
    let random;
    if (typeof crypto !== 'undefined' && crypto.getRandomValues) {
        const words = crypto.getRandomValues(new Uint32Array(2));
        random = (words[0] & 0x1fffff) * 2 ** 32 + words[1];
    } else {
        random = Math.floor(Math.random() * 2 ** 53);
    }
    return { wallMs: Date.now(), monotonicNs: now - first, random };
}
