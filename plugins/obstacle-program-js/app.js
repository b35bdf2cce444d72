// The blackboard example's deliberative part (`radar run --example
// obstacle`) as a JavaScript component, as plugins/obstacle-program-py does
// it in Python: `whenever Obstacle start Avoid`; a simulated range sensor
// writes a reading to the blackboard every 0.5 s; an anonymous slot checks,
// at each of Avoid's exits, how many obstacles Avoid has handed back (the
// entry `avoided`), and the program fails if the count is not what the
// readings make it.
import { boardRead, boardWrite, on, program, sleep, waitUntil, whenever } from './radar_program.js';

// One every 0.5 s: two approaches, the first too close twice in a row.
const RANGE_READINGS = [2.0, 1.6, 1.1, 0.45, 0.3, 0.8, 1.5, 2.0, 1.2, 0.6, 0.35, 1.8];
const APPROACHES = 2;

function main() {
    const handedBack = [];
    whenever('Obstacle', 'Avoid');
    on('Avoid.exited', () => {
        handedBack.push(boardRead('avoided'));
        const expected = handedBack.length;
        if (handedBack[expected - 1] !== expected) {
            throw new Error(`Avoid handed back ${handedBack[expected - 1]}, expected ${expected}`);
        }
    });
    for (const reading of RANGE_READINGS) {
        boardWrite('range', reading);
        sleep(0.5);
    }
    if (!waitUntil(() => handedBack.length === APPROACHES, 10)) {
        throw new Error(`Avoid handed back ${handedBack.length} of ${APPROACHES} in time`);
    }
}

export const run = program(main);
