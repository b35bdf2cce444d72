// A test fixture: `plugins/constructs-program` in JavaScript, over the
// helpers of `radar_program.js`: every construct of the `system` interface
// (anonymous slots included) on a system of E (TestEvent counting to 2), F
// (a timer event, 3 s) and R (TestResponse counting 2 s). It logs what it
// saw, fails when anything is not what the semantics say, and gives the
// Rust program's trace.
import {
    Busy, config, errorMessage, info, inject, now, on, once, pluginState, program, scope, sleep,
    waitfor, whenever,
} from './radar_program.js';

function check(what, ok) {
    if (!ok) throw new Error(`failed: ${what}`);
    info(`ok: ${what}`);
}

function main() {
    check('R starts idle', pluginState('R') === 'idle');
    check('E is inactive', pluginState('E') === 'inactive');
    // waitfor with a timeout that passes first, then without one.
    check('waitfor times out at 1.5 s', waitfor('E', 1.5) === undefined);
    const count = waitfor('E.triggered');
    check("waitfor returns E's payload", count === 2);
    check('at 2 s', now() === 2);
    // A scoped whenever with a queue: ends with the block.
    scope(() => {
        const c = whenever('E', 'R.start', { busy: Busy.QUEUE, queue: 1 });
        check('a connection has its id', c.ids().length === 1);
        sleep(4);
        check('R runs meanwhile', pluginState('R') === 'running');
    });
    // A kept connection outlives its scope; once ... until.
    once('F', 'R.interrupt').keep();
    once('E', 'R', { until: 'F' });
    inject('R.start', 7);
    const exited = waitfor('R.exited', 10);
    check('R exited', exited !== undefined);
    let refused = false;
    try {
        inject('R.nothing', 1);
    } catch (e) {
        refused = errorMessage(e).includes('nothing');
    }
    check('a bad slot is an error', refused);
    check('config reaches the program', config('greeting', '') === 'hello');
    // An anonymous slot: its handler runs at each delivery, while the
    // program waits.
    let seen = 0;
    scope(() => {
        on('E', (payload) => {
            info(`anonymous slot: E.triggered(${payload}) at ${now()}s`);
            seen += 1;
        });
        sleep(5);
        check('the anonymous slot ran twice', seen === 2);
        // A waitfor meanwhile still sees its own signal.
        check('waitfor beside an anonymous slot', waitfor('E', 3) === 2);
        // The slot's delivery of that same emission runs at the next wait.
        sleep(0);
        check('the slot ran for that one too', seen === 3);
    });
}

export const run = program(main);
