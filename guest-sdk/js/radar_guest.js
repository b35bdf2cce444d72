// Helpers for Radar plugins written in JavaScript (built with jco
// componentize). The imports of `radar:reactive` are complete but low level:
// nanoseconds, text-only configuration. These make the usual things short:
//
//     import { info, sleep, config } from './radar_guest.js';
//     export function check() {
//         sleep(config('interval_s', 1));   // throws when interrupted
//         return 1;
//     }
//
// `sleep` throws when the host asks the running slot to stop; left uncaught
// in a slot that returns `result<_, interruption>`, the slot returns that
// interruption as its error, as the Rust SDK's `?` does. `interrupted(e)`
// tells such an error from a bug.
import { now as hostNow, sleep as hostSleep, yield as hostYield, interrupted as hostInterrupted } from 'radar:reactive/clock@0.1.0';

// Logging and configuration, shared with programs' helpers (radar_program.js).
export * from './radar_base.js';

/** Scheduler time in seconds since the system began to run. */
export function now() {
    return Number(hostNow()) / 1e9;
}

/** Seconds as whole nanoseconds (never negative). */
export function nanos(seconds) {
    return Math.max(0, Math.trunc(seconds * 1e9));
}

/** Waits `seconds` of scheduler time (virtual in tests); throws when interrupted. */
export function sleep(seconds) {
    hostSleep(nanos(seconds));
}

/** `sleep` in whole nanoseconds. */
export function sleepNanos(n) {
    hostSleep(n);
}

/** Lets every other task ready at this instant run first; throws when interrupted. */
export function yieldNow() {
    hostYield();
}

/** Why the host asked the running slot to stop (`'interrupt'`, `'exit'`, `'deactivate'`), or undefined. */
export function stopRequested() {
    return hostInterrupted();
}

/** Whether `error` is an interruption thrown by `sleep` or `yieldNow`. */
export function interrupted(error) {
    return error !== null && typeof error === 'object'
        && ['interrupt', 'exit', 'deactivate'].includes(error.payload);
}

// UTF-8 without TextEncoder, which not every engine has.
const utf8 = (text) => Uint8Array.from(unescape(encodeURIComponent(text)), (c) => c.charCodeAt(0));
const fromUtf8 = (bytes) => decodeURIComponent(escape(String.fromCharCode(...bytes)));

/**
 * What a plugin keeps across a hot swap, as named fields with their first
 * values:
 *
 *     const state = new State({ count: 0, near: false });
 *     export function check() { state.count += 1; ... }
 *     export const snapshot = state.snapshot;  // the world exports snapshot
 *     export const restore = state.restore;    // and restore: hand it over
 *
 * `snapshot` gives the fields as JSON; `restore` takes the old version's
 * fields that this version still has (a new field keeps its first value, a
 * dropped one is ignored) and refuses what is not such JSON, which rolls the
 * swap back.
 */
export class State {
    constructor(fields) {
        Object.assign(this, fields);
        // Bound, and not fields themselves: `export const snapshot =
        // state.snapshot` works, and JSON.stringify(this) skips them.
        Object.defineProperty(this, 'snapshot', {
            value: () => utf8(JSON.stringify(this)),
        });
        Object.defineProperty(this, 'restore', {
            value: (saved) => {
                let fields;
                try {
                    fields = JSON.parse(fromUtf8(saved));
                } catch (e) {
                    throw refusal(`the old version's state does not fit: ${e.message}`);
                }
                if (fields === null || typeof fields !== 'object' || Array.isArray(fields)) {
                    throw refusal("the old version's state does not fit: not a table of fields");
                }
                for (const name of Object.keys(this)) {
                    if (Object.prototype.hasOwnProperty.call(fields, name)) this[name] = fields[name];
                }
            },
        });
    }
}

/** An error whose `payload` is the `err` value of a `result<_, string>`. */
function refusal(message) {
    const e = new Error(message);
    e.payload = message;
    return e;
}
