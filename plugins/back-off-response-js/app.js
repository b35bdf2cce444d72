// BackOff, in JavaScript: `start(speed)` sends a whole Twist backing away
// at `speed` (its signal `cmd-vel`), says so (`moving`), keeps the command
// on the blackboard (`last-command`) and backs away for `back_s` seconds
// (default 1); `exit` sends the zero Twist, whatever ended the activation.
// The world is `plugins/wit/back-off`, shared with Rust, Python and C.
// Records are plain objects; a variant is `{ tag, val }`.
import { config, info, nanos, sleepNanos } from './radar_guest.js';
import { writeLastCommand } from 'radar-examples:back-off/board';
import { cmdVel, moving } from 'radar-examples:back-off/signals';

function command(forward) {
    const twist = { linear: { x: forward, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } };
    cmdVel(twist);
    writeLastCommand(twist);
}

function start(speed) {
    command(-speed);
    moving({ tag: 'reversing', val: speed });
    sleepNanos(nanos(config('back_s', 1.0))); // an interruption ends `start`
}

function exit() {
    command(0);
    moving({ tag: 'stopped' });
    info('motors stopped');
}

// The world exports its slots in the interface `slots`.
export const slots = { start, exit };
