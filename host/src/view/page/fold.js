// The system at an instant, folded from a trace's records: the same fold
// as `view::Graph::apply` in Rust (host/src/view/graph.rs), which the text
// timeline and `radar graph` use. The page (view.js) keeps one as records
// arrive, and checkpoints of it to fold any instant from.
"use strict";
const radarFold = (function () {
  function newGraph() {
    return { plugins: new Map(), connections: new Map(), board: new Map() };
  }
  function cloneGraph(g) {
    const c = newGraph();
    for (const [k, v] of g.plugins) c.plugins.set(k, Object.assign({}, v));
    for (const [k, v] of g.connections) c.connections.set(k, v);
    for (const [k, v] of g.board) c.board.set(k, v);
    return c;
  }
  function plugin(g, name) {
    let p = g.plugins.get(name);
    if (!p) {
      p = { state: "", event: false, queued: 0 };
      g.plugins.set(name, p);
    }
    return p;
  }
  const pluginOf = (port) => port.split(".")[0];
  // Starts withdrawn from a queue: trace::WITHDRAWN (host/src/trace/check.rs)
  // but `restarted`, which replaces the start waiting to begin, not a queued one.
  const WITHDRAWN = ["fault", "node-lost", "swap-refused"];
  function fold(g, r) {
    if (!r) return g;
    switch (r.kind) {
      case "state": {
        const p = plugin(g, r.plugin);
        p.state = r.state;
        if (r.state === "inactive" || r.state === "active") p.event = true;
        if (r.state === "error" || r.state === "idle") p.queued = 0;
        break;
      }
      case "activate":
      case "deactivate": {
        const p = plugin(g, r.plugin);
        p.event = true;
        p.state = r.kind === "activate" ? "active" : "inactive";
        break;
      }
      case "connect":
        g.connections.set(r.id, {
          from: r.from,
          to: r.to,
          mode: r.mode,
          busy: r.queue === undefined ? r.busy : r.busy + ":" + r.queue,
          until_of: r.until_of === undefined ? null : r.until_of,
        });
        break;
      case "disconnect":
        g.connections.delete(r.id);
        break;
      case "deliver":
        if (r.queued !== undefined) plugin(g, pluginOf(r.to)).queued = r.queued;
        break;
      case "slot-begin":
        if (r.queued !== undefined) plugin(g, r.plugin).queued = r.queued;
        break;
      case "dropped":
        if (WITHDRAWN.includes(r.reason)) {
          const p = g.plugins.get(pluginOf(r.to));
          if (p && p.queued > 0) p.queued -= 1;
        }
        break;
      case "board-write":
        g.board.set(r.entry, { value: r.value, by: r.by });
        break;
    }
    return g;
  }
  return { newGraph, cloneGraph, fold, pluginOf };
})();
