// Test fixture: a JavaScript event that does in each check what its `mode`
// config says:
// - `wait` (the default): waits `ms` (200) milliseconds the way a script
//   without timers would, spinning on `Date.now()`, then triggers with the
//   number of checks so far. (This runtime has no `setTimeout`.) Under the
//   virtual clock time stands still during a call, so the wait never ends
//   and its fuel does;
// - `log`: logs `bytes` bytes (1 MiB) in lines of 1 KiB, in one call;
// - `alloc`: keeps a `mib` MiB (32) array from its first check on.
import { config, info } from './radar_guest.js';

let checks = 0;
const kept = [];

export function check() {
    checks += 1;
    const mode = config('mode', 'wait');
    if (mode === 'wait') {
        const until = Date.now() + config('ms', 200);
        while (Date.now() < until) { /* wait */ }
        return checks;
    }
    if (mode === 'log') {
        const line = 'x'.repeat(1024);
        for (let i = 0; i < config('bytes', 1 << 20) / 1024; i++) {
            info(line);
        }
        return checks;
    }
    if (mode === 'alloc') {
        if (kept.length === 0) {
            kept.push(new Uint8Array(config('mib', 32) * 1048576).fill(1));
        }
        return checks;
    }
    return undefined;
}
