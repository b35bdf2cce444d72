// A TestEvent whose sensor fails: its first check throws, for the test that
// an uncaught JavaScript exception becomes a fault that says why.
export function check() {
    throw new Error('no reading from the range sensor');
}
