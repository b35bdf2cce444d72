// Helpers for deliberative programs written in JavaScript (the
// `radar:reactive/deliberative` world, built with jco componentize), as
// short as the Rust SDK's `radar_guest::deliberative`:
//
//     import { program, scope, whenever, once, sleep, waitfor } from './radar_program.js';
//
//     function main() {
//         whenever('TestEvent', 'TestResponse');          // for the whole run
//         scope(() => {                                     // ends with the block
//             once('TestEvent2', 'TestResponse.interrupt');
//             for (let i = 0; i < 15; i++) sleep(1);
//         });
//         waitfor('TestResponse.exited', 10);
//     }
//
//     export const run = program(main);
//
// JavaScript has no scope-bound destructors, so RADAR's scoped connections
// are `scope(() => {...})` blocks: every connection and anonymous slot made
// inside ends when the block returns or throws, unless kept (`.keep()`).
// What `main` makes outside any inner block ends when `main` returns (as a
// Rust program's guards do), unless kept; `.close()` ends one at once. A call the system refuses throws an Error with the host's
// message; left uncaught, it ends the program with it. Payloads are
// JavaScript values (JSON on the way).
import {
    connect as hostConnect,
    listen as hostListen,
    wait as hostWait,
    now as hostNow,
    inject as hostInject,
    pluginState,
    boardRead as hostBoardRead,
    boardWrite as hostBoardWrite,
    stop as hostStop,
} from 'radar:reactive/system@0.1.0';

export * from './radar_base.js';
export { pluginState };

/** What a start does while the response runs. */
export const Busy = { DROP: 'drop', QUEUE: 'queue', RESTART: 'restart' };

// Nanoseconds as numbers: QuickJS traps on a BigInt passed to a u64.
const nanos = (seconds) => Math.max(0, Math.round(seconds * 1e9));
const hostNanos = () => Number(hostNow());

// The open scopes, innermost last: the connections each must end.
const scopes = [];
// The handlers of the program's anonymous slots, by connection id.
const handlers = new Map();

/** A live connection (two, for `... until`). */
class Connection {
    constructor(handle) {
        this.handle = handle;
        if (scopes.length > 0) scopes[scopes.length - 1].push(this);
    }

    /** Its ids in the trace. */
    ids() {
        return this.handle ? Array.from(this.handle.ids(), Number) : [];
    }

    /** Keeps it for the rest of the run, whatever its scope (an anonymous
     * slot keeps its handler). */
    keep() {
        const handle = this.handle;
        this.handle = undefined;
        if (handle) {
            handle.keep();
            handle[Symbol.dispose]();
        }
    }

    /** Removes it now (unless kept). */
    close() {
        const handle = this.handle;
        this.handle = undefined;
        if (handle) handle[Symbol.dispose]();
    }
}

/** An anonymous slot (see `on`): it ends as a connection does. */
class Listener extends Connection {
    constructor(handle, handler) {
        super(handle);
        this.id = this.ids()[0];
        handlers.set(this.id, handler);
    }

    close() {
        handlers.delete(this.id);
        super.close();
    }
}

/**
 * Runs `body`; every connection and anonymous slot made while it runs (and
 * not kept) ends when it returns or throws. Returns what `body` returns.
 */
export function scope(body) {
    scopes.push([]);
    try {
        return body();
    } finally {
        for (const connection of scopes.pop().reverse()) connection.close();
    }
}

function connect(mode, source, target, options = {}) {
    const { until, busy = Busy.DROP, queue = 1, minInterval } = options;
    return new Connection(hostConnect({
        source,
        target: target.includes('.') ? target : `${target}.start`,
        mode,
        until,
        busy,
        queueLength: queue,
        minIntervalNs: minInterval === undefined ? undefined : nanos(minInterval),
    }));
}

/**
 * `whenever source target`: every emission of `source` (`Plugin.signal`, or
 * `Plugin` for its `triggered`) goes to `target` (`Plugin.slot`, or `Plugin`
 * for its `start`). Options: `until` (a signal that interrupts what this
 * starts), `busy` (`Busy.DROP`, `Busy.QUEUE` with `queue` waiting at most,
 * `Busy.RESTART`), `minInterval` (seconds under which a second emission is
 * dropped).
 */
export function whenever(source, target, options) {
    return connect('whenever', source, target, options);
}

/** `once source target`: the first emission only (see `whenever`). */
export function once(source, target, options) {
    return connect('once', source, target, options);
}

/**
 * An anonymous slot: `handler(payload)` runs at every emission of `signal`,
 * while the program waits (in `sleep` or `waitfor`), at the time of the
 * delivery.
 */
export function on(signal, handler) {
    return new Listener(hostListen(signal, 'whenever'), handler);
}

/** `on` for the first emission only. */
export function onOnce(signal, handler) {
    return new Listener(hostListen(signal, 'once'), handler);
}

function dispatch(delivery) {
    const id = Number(delivery.connection);
    const handler = handlers.get(id);
    if (handler === undefined) return;
    // Taken out while it runs: a handler may wait, and so run others.
    handlers.delete(id);
    try {
        handler(JSON.parse(delivery.payload));
    } finally {
        if (!handlers.has(id)) handlers.set(id, handler);
    }
}

/** Waits, running anonymous slots as their deliveries come; the signal's
 * payload (JSON text), or '' once `condition()` holds after a handler, or
 * undefined at the deadline. */
function wait(deadline, signal, condition) {
    for (;;) {
        const woke = hostWait(deadline, signal);
        if (woke.tag === 'deadline') return undefined;
        if (woke.tag === 'signal') return woke.val;
        dispatch(woke.val);
        if (condition !== undefined && condition()) return '';
    }
}

/**
 * Waits until `condition()` holds, checked now and after each of the
 * anonymous slots' handlers runs (what they see is what changes it); false
 * if `timeout` seconds pass first.
 */
export function waitUntil(condition, timeout) {
    if (condition()) return true;
    const deadline = timeout === undefined ? undefined : hostNanos() + nanos(timeout);
    return wait(deadline, undefined, condition) !== undefined;
}

/** Waits `seconds` of the system's time; anonymous slots run meanwhile. */
export function sleep(seconds) {
    wait(hostNanos() + nanos(seconds), undefined);
}

/**
 * Waits for `signal` and returns its payload (`null` for a signal without
 * one), or `undefined` when `timeout` seconds pass first. Anonymous slots
 * run meanwhile.
 */
export function waitfor(signal, timeout) {
    const deadline = timeout === undefined ? undefined : hostNanos() + nanos(timeout);
    const payload = wait(deadline, signal);
    return payload === undefined ? undefined : JSON.parse(payload);
}

/** The system's time in seconds since the run began. */
export function now() {
    return hostNanos() / 1e9;
}

/** Sends `payload` straight into `slot` (`Plugin.slot`). */
export function inject(slot, payload = null) {
    hostInject(slot, JSON.stringify(payload));
}

/** A blackboard entry's value, or undefined if nothing wrote it yet. */
export function boardRead(entry) {
    const value = hostBoardRead(entry);
    return value === undefined || value === null ? undefined : JSON.parse(value);
}

/** Writes a blackboard entry (checked against its type). */
export function boardWrite(entry, value) {
    hostBoardWrite(entry, JSON.stringify(value));
}

/**
 * Ends the program at once (it does not return) and the run with it, with
 * `status` for `radar run` to exit with (0: success): every running
 * response runs its exit, nothing new begins. Returning from `main` ends
 * the run too (status 0, or 1 with its error), unless it kept connections.
 */
export function stop(status = 0) {
    hostStop(status);
}

/**
 * The world's `run` for a program whose body is `main()`: `export const run
 * = program(main);`. What `main` throws ends the program with its message.
 * `main` is itself a scope: what it made and did not keep ends with it.
 */
export function program(main) {
    return () => {
        try {
            scope(main);
        } catch (e) {
            const message = errorMessage(e);
            const failure = new Error(message);
            failure.payload = message;
            throw failure;
        }
    };
}

/** The host's message of a refused call (its `payload`), else the error's
 * (`TypeError: ...`; a plain `Error`'s message alone). */
export function errorMessage(e) {
    if (e !== null && typeof e === 'object' && typeof e.payload === 'string') return e.payload;
    if (!(e instanceof Error)) return String(e);
    return e.name === 'Error' ? e.message : `${e.name}: ${e.message}`;
}
