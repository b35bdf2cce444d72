// `{{plugin}}`: a deliberative program. It wires the system at run time, as
// the paper's Listing 2 does: whenever Trigger triggers, Responder starts;
// and it waits for Responder's first run to end and logs its result.
import { info, program, waitfor, whenever } from './radar_program.js';

function main() {
    // whenever Trigger start Responder, for the rest of the run (without
    // keep(), a connection ends with main, or with its `scope` block).
    whenever('Trigger', 'Responder').keep();
    // waitfor: the first run's end, or undefined after 30 s.
    const exited = waitfor('Responder.exited', 30);
    info(`Responder exited with ${JSON.stringify(exited)}`);
}

export const run = program(main);
