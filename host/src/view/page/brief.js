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
    if (m !== 0 && (m < 1e-3 || m >= 1e6)) return x.toExponential(3);
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
      if (v.every((x) => typeof x === "number")) {
        let min = Infinity, max = -Infinity, sum = 0;
        for (const x of v) { min = Math.min(min, x); max = Math.max(max, x); sum += x; }
        return `[${thousands(v.length)} numbers: min ${number(min)}, max ${number(max)}, mean ${number(sum / v.length)}; ${first}…]`;
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
  // `value` as one short line, at most `widest` characters.
  function brief(value, widest) {
    const w = widest || WIDEST;
    const out = write(value, 0);
    const chars = [...out];
    return chars.length > w ? chars.slice(0, w - 1).join("") + "…" : out;
  }
  return { brief };
})();
