// A value as a person reads it: the same rules as `view::brief` in Rust
// (host/src/view/brief.rs), which the text timeline, `ctl read` and
// `radar graph` use. A small value is its JSON; a long list shows its
// length, min, max and mean if it holds numbers, and its first items; a
// long string its start and length; a value the trace cut its size. The
// whole value is one click away, in the record's details.
"use strict";
const radarBrief = (function () {
  const MOST_ITEMS = 8, FIRST_ITEMS = 3, LONGEST_STRING = 120, DEEPEST = 4, WIDEST = 200;
  function thousands(n) {
    return String(n).replace(/\B(?=(\d{3})+(?!\d))/g, ",");
  }
  function number(x) {
    if (!isFinite(x)) return String(x);
    const m = Math.abs(x);
    if (m !== 0 && (m < 1e-3 || m >= 1e6)) return x.toExponential(3).replace("e+", "e");
    const t = x.toFixed(3).replace(/0+$/, "").replace(/\.$/, "");
    return t === "-0" ? "0" : t;
  }
  function cutSize(v) {
    const keys = Object.keys(v);
    if (keys.length !== 1 || keys[0] !== "$cut" || !v.$cut) return null;
    return typeof v.$cut.bytes === "number" ? v.$cut.bytes : null;
  }
  function write(v, depth) {
    if (Array.isArray(v)) {
      if (depth >= DEEPEST && v.length) return "[…]";
      if (v.length <= MOST_ITEMS) return "[" + v.map((x) => write(x, depth + 1)).join(",") + "]";
      const first = v.slice(0, FIRST_ITEMS).map((x) => write(x, depth + 1) + ", ").join("");
      // A float that is not finite is the string the trace writes for it.
      const NON_FINITE = { "Infinity": Infinity, "-Infinity": -Infinity, "NaN": NaN };
      const asNumber = (x) => (typeof x === "number" ? x : typeof x === "string" && x in NON_FINITE ? NON_FINITE[x] : null);
      const numbers = v.map(asNumber);
      if (numbers.every((x) => x !== null)) {
        const finite = numbers.filter((x) => isFinite(x));
        const others = numbers.length - finite.length;
        const parts = [];
        if (finite.length) {
          let min = Infinity, max = -Infinity, sum = 0;
          for (const x of finite) { min = Math.min(min, x); max = Math.max(max, x); sum += x; }
          parts.push(`min ${number(min)}, max ${number(max)}, mean ${number(sum / finite.length)}`);
        }
        if (others) parts.push(`${thousands(others)} not finite`);
        return `[${thousands(v.length)} numbers: ${parts.join(", ")}; ${first}…]`;
      }
      return `[${thousands(v.length)} items: ${first}…]`;
    }
    if (v !== null && typeof v === "object") {
      const bytes = cutSize(v);
      if (bytes !== null) return `‹${thousands(bytes)} bytes, cut from the trace›`;
      const keys = Object.keys(v);
      if (depth >= DEEPEST && keys.length) return "{…}";
      return "{" + keys.map((k) => JSON.stringify(k) + ":" + write(v[k], depth + 1)).join(",") + "}";
    }
    if (typeof v === "string" && [...v].length > LONGEST_STRING) {
      const chars = [...v];
      return JSON.stringify(chars.slice(0, LONGEST_STRING - 20).join("")) + `… (${thousands(chars.length)} chars)`;
    }
    return JSON.stringify(v);
  }
  // Whether `v` holds something `write` summarises.
  function isLarge(v) {
    if (Array.isArray(v)) return v.length > MOST_ITEMS || v.some(isLarge);
    if (v !== null && typeof v === "object") return cutSize(v) !== null || Object.values(v).some(isLarge);
    return typeof v === "string" && [...v].length > LONGEST_STRING;
  }
  // A record too wide for its line: what was summarised first, records
  // inside it folded (as `write_tight` in brief.rs).
  function writeTight(v) {
    if (v === null || typeof v !== "object" || Array.isArray(v) || cutSize(v) !== null) return write(v, 0);
    const keys = Object.keys(v);
    const ordered = keys.filter((k) => isLarge(v[k])).concat(keys.filter((k) => !isLarge(v[k])));
    const field = (k) => {
      const x = v[k];
      const depth = x !== null && typeof x === "object" && !Array.isArray(x) ? DEEPEST : 1;
      return JSON.stringify(k) + ":" + write(x, depth);
    };
    return "{" + ordered.map(field).join(",") + "}";
  }
  // `value` as one short line, at most `widest` characters.
  function brief(value, widest) {
    const w = widest || WIDEST;
    let out = write(value, 0);
    if ([...out].length > w) out = writeTight(value);
    const chars = [...out];
    return chars.length > w ? chars.slice(0, w - 1).join("") + "…" : out;
  }
  return { brief };
})();
