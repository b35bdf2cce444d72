// Radar's view of a run (docs/view.md): a timeline with a lane per plugin,
// and the connection graph (the paper's Fig. 3) at the instant the slider
// points to. The same page serves `radar view` (the trace is inlined below)
// and `radar run --monitor` (records arrive as server-sent events).
//
// It stays responsive on millions of records: each lane keeps its spans
// and marks in arrays sorted by time, a redraw visits only what is on
// screen and at most one item per pixel column, and the graph at an
// instant is folded from the nearest checkpoint (one every CHECK_EVERY
// records), not from the start.
"use strict";
(function () {
  const CHECK_EVERY = 20000;
  const AXIS = 20;
  const SYSTEM = "(system)";
  const $ = (id) => document.getElementById(id);
  const { newGraph, cloneGraph, fold, pluginOf } = radarFold; // fold.js
  const canvas = $("canvas");
  const ctx = canvas.getContext("2d");
  const laneHeight = () =>
    parseFloat(getComputedStyle(document.documentElement).getPropertyValue("--lane")) || 26;

  const records = [];
  const lanes = [];
  const laneByName = new Map();
  let end = 0;
  let v0 = 0;
  let v1 = 1;
  let cursor = 0;
  let selected = -1;
  const live = fold(newGraph(), null); // the fold of every record so far
  const checkpoints = [];
  const stats = {};

  // The number of records at or before `t`.
  function upTo(t) {
    let lo = 0;
    let hi = records.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (records[mid].t <= t) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  }
  function graphAt(t) {
    const n = upTo(t);
    if (n === records.length) return cloneGraph(live);
    const k = Math.floor(n / CHECK_EVERY);
    const g = cloneGraph(checkpoints[k]);
    for (let i = k * CHECK_EVERY; i < n; i++) fold(g, records[i]);
    return g;
  }

  // --- lanes: what the timeline draws, indexed as records arrive ---

  const MARKS = ["connection", "log", "board", "signal", "swap", "dropped", "fault"];
  function lane(name) {
    let l = laneByName.get(name);
    if (l) return l;
    const el = document.createElement("div");
    el.className = "lane";
    el.dataset.plugin = name;
    el.textContent = name;
    el.title = name;
    l = {
      name,
      el,
      spans: { s: [], e: [], b: [], x: [], slot: [], out: [] },
      open: {},
      bands: { s: [], e: [], state: [] },
      band: null,
      marks: {},
    };
    for (const m of MARKS) l.marks[m] = { t: [], i: [] };
    el.addEventListener("click", () => showPlugin(name));
    const system = laneByName.get(SYSTEM);
    if (system && name !== SYSTEM) {
      $("lanes").insertBefore(el, system.el);
      lanes.splice(lanes.indexOf(system), 0, l);
    } else {
      $("lanes").appendChild(el);
      lanes.push(l);
    }
    laneByName.set(name, l);
    return l;
  }
  const portLane = (port) => lane(port.includes(".") ? pluginOf(port) : SYSTEM);
  function mark(l, cls, t, i) {
    l.marks[cls].t.push(t);
    l.marks[cls].i.push(i);
  }
  // A coloured band while a plugin is active or in error.
  function band(l, state, t) {
    if (l.band) {
      l.bands.s.push(l.band.s);
      l.bands.e.push(t);
      l.bands.state.push(l.band.state);
      l.band = null;
    }
    if (state === "active" || state === "error") l.band = { s: t, state };
  }
  function index(i) {
    const r = records[i];
    const t = r.t;
    if (i % CHECK_EVERY === 0) checkpoints.push(cloneGraph(live));
    fold(live, r);
    if (t > end) end = t;
    switch (r.kind) {
      case "slot-begin":
        lane(r.plugin).open[r.slot] = i;
        break;
      case "slot-end": {
        const l = lane(r.plugin);
        const b = l.open[r.slot];
        if (b !== undefined) {
          delete l.open[r.slot];
          const sp = l.spans;
          sp.s.push(records[b].t);
          sp.e.push(t);
          sp.b.push(b);
          sp.x.push(i);
          sp.slot.push(r.slot);
          sp.out.push(r.outcome);
        }
        break;
      }
      case "signal":
      case "discarded":
        mark(lane(r.plugin), "signal", t, i);
        break;
      case "dropped":
        mark(portLane(r.to), "dropped", t, i);
        break;
      case "fault":
        mark(lane(r.plugin), "fault", t, i);
        break;
      case "log":
        mark(lane(r.plugin), "log", t, i);
        break;
      case "swap":
      case "swap-request":
      case "swap-refused":
      case "swap-rolled-back":
      case "reset":
      case "configured":
        mark(lane(r.plugin), "swap", t, i);
        break;
      case "inject":
        mark(portLane(r.to), "signal", t, i);
        break;
      case "board-write":
        mark(laneByName.has(r.by) ? lane(r.by) : lane(SYSTEM), "board", t, i);
        break;
      case "state":
        band(lane(r.plugin), r.state, t);
        break;
      case "activate":
        band(lane(r.plugin), "active", t);
        break;
      case "deactivate":
        band(lane(r.plugin), "inactive", t);
        break;
      case "connect":
      case "disconnect":
      case "refused":
      case "stopped":
      case "program-end":
        mark(lane(SYSTEM), r.kind === "refused" || r.kind === "stopped" ? "fault" : "connection", t, i);
        break;
    }
  }
  function add(list) {
    for (const r of list) {
      records.push(r);
      index(records.length - 1);
    }
  }

  // --- drawing ---

  const COLORS = {
    start: "#4a90d9",
    interrupt: "#e8a33d",
    exit: "#9b6fc4",
    active: "#cdebd3",
    error: "#f6c6c3",
    signal: "#2e8b57",
    dropped: "#e07b00",
    fault: "#d0342c",
    log: "#888",
    board: "#1b9aaa",
    swap: "#222",
    connection: "#555",
  };
  // First index in sorted `a` with a[k] >= x.
  function lowerBound(a, x, lo) {
    let hi = a.length;
    lo = lo || 0;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (a[mid] < x) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  }
  let scale = 1; // pixels per nanosecond
  const toX = (t) => (t - v0) * scale;
  const toT = (x) => v0 + x / scale;

  function resize() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(100, canvas.clientWidth);
    const h = AXIS + lanes.length * laneHeight();
    canvas.style.height = h + "px";
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(h * dpr);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  }
  function drawAxis(w) {
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, w, AXIS);
    const span = Math.max(1, v1 - v0);
    const raw = span / Math.max(1, w / 90);
    const pow = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 5, 10].map((m) => m * pow).find((s) => s >= raw);
    ctx.fillStyle = "#555";
    ctx.strokeStyle = "#ddd";
    ctx.font = "11px system-ui, sans-serif";
    for (let t = Math.ceil(v0 / step) * step; t <= v1; t += step) {
      const x = Math.round(toX(t)) + 0.5;
      ctx.beginPath();
      ctx.moveTo(x, AXIS - 5);
      ctx.lineTo(x, canvas.clientHeight);
      ctx.stroke();
      ctx.fillText(seconds(t, step), x + 3, 12);
    }
  }
  function seconds(t, step) {
    const digits = step >= 1e9 ? 0 : Math.min(9, Math.ceil(-Math.log10(step / 1e9)));
    return (t / 1e9).toFixed(digits) + " s";
  }
  function glyph(cls, x, y) {
    ctx.beginPath();
    switch (cls) {
      case "signal":
        ctx.moveTo(x, y - 5);
        ctx.lineTo(x + 4, y + 2);
        ctx.lineTo(x - 4, y + 2);
        break;
      case "dropped":
        ctx.moveTo(x, y + 5);
        ctx.lineTo(x + 4, y - 2);
        ctx.lineTo(x - 4, y - 2);
        break;
      case "fault":
        ctx.lineWidth = 2;
        ctx.moveTo(x - 4, y - 4);
        ctx.lineTo(x + 4, y + 4);
        ctx.moveTo(x + 4, y - 4);
        ctx.lineTo(x - 4, y + 4);
        ctx.stroke();
        ctx.lineWidth = 1;
        return;
      case "log":
        ctx.arc(x, y, 2.5, 0, 2 * Math.PI);
        break;
      case "board":
        ctx.rect(x - 3, y - 3, 6, 6);
        break;
      case "connection":
        ctx.rect(x - 1, y - 6, 2, 12);
        break;
      case "swap":
        ctx.moveTo(x, y - 5);
        ctx.lineTo(x + 4, y);
        ctx.lineTo(x, y + 5);
        ctx.lineTo(x - 4, y);
        break;
    }
    ctx.fill();
  }
  const MARK_Y = { signal: 8, dropped: 18, fault: 13, log: 21, board: 5, swap: 13, connection: 13 };
  let drawn = 0;
  function draw() {
    const t0 = performance.now();
    resize();
    const w = canvas.clientWidth;
    const lh = laneHeight();
    scale = w / Math.max(1, v1 - v0);
    ctx.clearRect(0, 0, w, canvas.clientHeight);
    drawAxis(w);
    const onePixel = 1 / scale;
    drawn = 0;
    lanes.forEach((l, k) => {
      const y = AXIS + k * lh;
      if (k % 2 === 0) {
        ctx.fillStyle = "#f3f5f8";
        ctx.fillRect(0, y, w, lh);
      }
      // bands: active, error
      const bs = l.bands;
      const drawBand = (s, e, state) => {
        const x0 = Math.max(0, toX(s));
        const x1 = Math.min(w, toX(e));
        if (x1 < 0 || x0 > w) return;
        ctx.fillStyle = COLORS[state];
        ctx.fillRect(x0, y + 1, Math.max(1, x1 - x0), lh - 2);
        drawn++;
      };
      for (let j = lowerBound(bs.e, v0); j < bs.s.length && bs.s[j] <= v1; ) {
        drawBand(bs.s[j], bs.e[j], bs.state[j]);
        j = Math.max(j + 1, lowerBound(bs.e, bs.e[j] + onePixel, j + 1));
      }
      if (l.band) drawBand(l.band.s, end, l.band.state);
      // spans: slot runs, at most one per pixel column
      const sp = l.spans;
      const drawSpan = (s, e, slot, out, sel) => {
        const x0 = Math.max(-1, toX(s));
        const x1 = Math.min(w + 1, toX(e));
        ctx.fillStyle = COLORS[slot] || "#999";
        ctx.fillRect(x0, y + 7, Math.max(2, x1 - x0), 12);
        if (out === "trapped" || sel) {
          ctx.strokeStyle = sel ? "#000" : COLORS.fault;
          ctx.lineWidth = 2;
          ctx.strokeRect(x0, y + 7, Math.max(2, x1 - x0), 12);
          ctx.lineWidth = 1;
        }
        drawn++;
      };
      for (let j = lowerBound(sp.e, v0); j < sp.s.length; ) {
        if (sp.s[j] > v1) break;
        drawSpan(sp.s[j], sp.e[j], sp.slot[j], sp.out[j], sp.b[j] === selected || sp.x[j] === selected);
        j = Math.max(j + 1, lowerBound(sp.e, sp.e[j] + onePixel, j + 1));
      }
      for (const slot in l.open) {
        const b = l.open[slot];
        if (records[b].t <= v1) drawSpan(records[b].t, Math.max(end, records[b].t + onePixel), slot, "", b === selected);
      }
      // marks, the rarer kinds last (on top)
      for (const cls of MARKS) {
        const m = l.marks[cls];
        ctx.fillStyle = COLORS[cls];
        ctx.strokeStyle = COLORS[cls];
        const hi = lowerBound(m.t, v1 + onePixel);
        for (let j = lowerBound(m.t, v0 - 4 * onePixel); j < hi; ) {
          glyph(cls, toX(m.t[j]), y + MARK_Y[cls]);
          drawn++;
          j = Math.max(j + 1, lowerBound(m.t, m.t[j] + 2 * onePixel, j + 1));
        }
      }
    });
    // the cursor
    const x = Math.round(toX(cursor)) + 0.5;
    ctx.strokeStyle = "#d0342c";
    ctx.beginPath();
    ctx.moveTo(x, 0);
    ctx.lineTo(x, canvas.clientHeight);
    ctx.stroke();
    stats.lastDrawMs = performance.now() - t0;
    stats.lastDrawItems = drawn;
  }

  // --- the graph at the cursor, as SVG ---

  const SVG = "http://www.w3.org/2000/svg";
  function el(name, attrs, parent) {
    const e = document.createElementNS(SVG, name);
    for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(e);
    return e;
  }
  function text(parent, x, y, content, cls) {
    const e = el("text", { x, y }, parent);
    if (cls) e.setAttribute("class", cls);
    e.textContent = content;
    return e;
  }
  function drawGraph() {
    const t0 = performance.now();
    const g = graphAt(cursor);
    stats.lastFoldMs = performance.now() - t0;
    const svg = $("graph-svg");
    svg.textContent = "";
    const W = 820;
    const events = [];
    const responses = [];
    const others = [];
    for (const [name, p] of g.plugins) (p.event ? events : responses).push(name);
    for (const c of g.connections.values()) {
      for (const end of [pluginOf(c.from), c.to.includes(".") ? pluginOf(c.to) : c.to]) {
        if (!g.plugins.has(end) && !others.includes(end)) others.push(end);
      }
    }
    const rows = Math.max(events.length, responses.length, others.length, 1);
    const H = 50 + rows * 80;
    svg.setAttribute("viewBox", `0 0 ${W} ${H}`);
    svg.setAttribute("height", Math.min(H, 600));
    const defs = el("defs", {}, svg);
    const marker = el("marker", { id: "arrow", viewBox: "0 0 10 10", refX: 10, refY: 5, markerWidth: 7, markerHeight: 7, orient: "auto-start-reverse" }, defs);
    el("path", { d: "M0,0 L10,5 L0,10 z", fill: "#333" }, marker);
    const pos = new Map();
    const place = (names, x) =>
      names.forEach((n, k) => pos.set(n, { x, y: 45 + k * 80 + (rows - names.length) * 40 }));
    place(events, 120);
    place(others, W / 2);
    place(responses, W - 120);
    // connections first, under the nodes
    const pairs = new Map();
    for (const [id, c] of g.connections) {
      const a = pluginOf(c.from);
      const b = c.to.includes(".") ? pluginOf(c.to) : c.to;
      const pa = pos.get(a);
      const pb = pos.get(b);
      if (!pa || !pb) continue;
      const key = a + "\u0000" + b;
      const k = pairs.get(key) || 0;
      pairs.set(key, k + 1);
      const until = c.until_of !== null;
      const grp = el("g", { class: `edge ${c.mode}${until ? " until" : ""}`, "data-id": id, "data-from": c.from, "data-to": c.to, "data-mode": c.mode, "data-busy": c.busy }, svg);
      if (until) grp.setAttribute("data-until-of", c.until_of);
      const bend = (k % 2 ? -1 : 1) * Math.ceil(k / 2) * 34 + (a === b ? 60 : 0);
      const x1 = pa.x + (pb.x >= pa.x ? 62 : -62);
      const x2 = pb.x + (pb.x >= pa.x ? -62 : 62);
      const mx = (x1 + x2) / 2;
      const my = (pa.y + pb.y) / 2 + bend;
      el("path", { d: `M${x1},${pa.y} Q${mx},${my} ${x2},${pb.y}`, "marker-end": "url(#arrow)" }, grp);
      const signal = c.from.slice(c.from.indexOf(".") + 1);
      const slot = c.to.includes(".") ? c.to.slice(c.to.indexOf(".") + 1) : c.to;
      const label = until ? `#${id} ${signal} → ${slot} (until of #${c.until_of})` : `#${id} ${c.mode} ${signal} → ${slot} (${c.busy})`;
      const lx = mx;
      const ly = (pa.y + pb.y) / 2 + bend / 2 - 4;
      const tl = text(grp, lx, ly, label);
      tl.setAttribute("text-anchor", "middle");
      grp.addEventListener("click", () => show({ connection: id, ...c }));
    }
    for (const [name, p] of pos) {
      const info = g.plugins.get(name);
      const state = info ? info.state : "";
      const cls = ["node"];
      if (info && info.event && state === "active") cls.push("active");
      if (info && !info.event && state && state !== "idle") cls.push("busy");
      if (state === "error") cls.push("error");
      const grp = el("g", { class: cls.join(" "), "data-plugin": name, "data-state": state, "data-kind": info ? (info.event ? "event" : "response") : "other" }, svg);
      if (info && info.queued) grp.setAttribute("data-queued", info.queued);
      if (info && info.event) el("ellipse", { cx: p.x, cy: p.y, rx: 62, ry: 24 }, grp);
      else el("rect", { x: p.x - 62, y: p.y - 22, width: 124, height: 44, rx: 4 }, grp);
      text(grp, p.x, p.y - 3, name);
      const shown = info ? (info.queued ? `${state}, ${info.queued} queued` : state) : "";
      text(grp, p.x, p.y + 12, shown, "state");
      grp.addEventListener("click", () => showPlugin(name));
    }
    if (pos.size === 0) text(svg, W / 2, 40, "nothing yet", "empty").setAttribute("text-anchor", "middle");
    // the blackboard
    const board = $("board");
    board.textContent = "";
    if (g.board.size) {
      const table = document.createElement("table");
      table.innerHTML = "<tr><th>blackboard entry</th><th>value</th><th>written by</th></tr>";
      for (const [entry, e] of g.board) {
        const tr = document.createElement("tr");
        tr.dataset.entry = entry;
        // A large value brief; the whole of it in the details, on a click.
        for (const v of [entry, radarBrief.brief(e.value, 80), e.by]) {
          const td = document.createElement("td");
          td.textContent = v;
          tr.appendChild(td);
        }
        tr.title = "click: the whole value";
        tr.addEventListener("click", () => show({ entry, at: (cursor / 1e9).toFixed(3) + " s", value: e.value, by: e.by }));
        table.appendChild(tr);
      }
      board.appendChild(table);
    }
    $("graph-time").textContent = (cursor / 1e9).toFixed(3) + " s";
    stats.lastGraphMs = performance.now() - t0;
  }

  // --- details ---

  function show(object) {
    $("record").textContent = JSON.stringify(object, null, 2);
  }
  function showRecord(i) {
    selected = i;
    const r = records[i];
    show(Object.assign({ record: i + 1 }, r));
    $("record").dataset.index = i;
    setCursor(r.t);
  }
  function showPlugin(name) {
    const g = graphAt(cursor);
    const p = g.plugins.get(name);
    const conns = [...g.connections].filter(([, c]) => pluginOf(c.from) === name || pluginOf(c.to) === name).map(([id, c]) => `#${id} ${c.from} → ${c.to} (${c.mode}, ${c.busy})`);
    show({ plugin: name, at: (cursor / 1e9).toFixed(3) + " s", state: p ? p.state : undefined, queued: p ? p.queued : undefined, connections: conns });
  }
  function hit(x, y) {
    const k = Math.floor((y - AXIS) / laneHeight());
    const l = lanes[k];
    if (!l) return -1;
    const t = toT(x);
    const slack = 5 / scale;
    let best = -1;
    let bestD = Infinity;
    for (const cls of MARKS) {
      const m = l.marks[cls];
      for (let j = lowerBound(m.t, t - slack); j < m.t.length && m.t[j] <= t + slack; j++) {
        const d = Math.abs(m.t[j] - t);
        if (d < bestD) {
          bestD = d;
          best = m.i[j];
        }
      }
    }
    if (best >= 0) return best;
    const sp = l.spans;
    for (let j = lowerBound(sp.e, t - slack); j < sp.s.length && sp.s[j] <= t + slack; j++) return sp.b[j];
    for (const slot in l.open) if (records[l.open[slot]].t <= t) return l.open[slot];
    return -1;
  }

  // --- time: the slider, the cursor, the window ---

  function setCursor(t, keepView) {
    cursor = Math.max(0, Math.min(end, t));
    $("slider").max = end;
    $("slider").value = cursor;
    $("clock").textContent = "t = " + (cursor / 1e9).toFixed(3) + " s";
    document.body.dataset.cursor = cursor;
    if (!keepView && (cursor < v0 || cursor > v1)) {
      const w = v1 - v0;
      v0 = Math.max(0, cursor - w / 2);
      v1 = v0 + w;
    }
    drawGraph();
    schedule();
  }
  function fit() {
    v0 = 0;
    v1 = Math.max(end, 1e6) * 1.02;
    schedule();
  }
  let pending = false;
  function schedule() {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => {
      pending = false;
      draw();
      updateStatus();
    });
  }
  function updateStatus() {
    $("slider").max = end;
    document.body.dataset.records = records.length;
    document.body.dataset.end = end;
    for (const l of lanes) {
      l.el.dataset.spans = l.spans.s.length + Object.keys(l.open).length;
      l.el.dataset.marks = MARKS.reduce((n, m) => n + l.marks[m].t.length, 0);
      l.el.classList.toggle("selected", selected >= 0 && laneOfRecord(selected) === l);
    }
    const what = `${records.length} records, ${(end / 1e9).toFixed(3)} s`;
    $("status").textContent = RADAR_LIVE ? `live (${liveState}): ${what}` : what;
  }
  function laneOfRecord(i) {
    const r = records[i];
    return r && r.plugin ? laneByName.get(r.plugin) : null;
  }
  function stepTo(direction) {
    const n = upTo(cursor);
    if (direction > 0 && n < records.length) setCursor(records[n].t);
    if (direction < 0) {
      const k = upTo(cursor - 1) - 1;
      setCursor(k >= 0 ? records[k].t : 0);
    }
  }

  // --- input ---

  // Looking back (the slider, a click, a step, a zoom) stops following
  // the live run; ticking "follow" again catches up.
  const lookBack = () => {
    $("follow").checked = false;
  };

  let drag = null;
  canvas.addEventListener("mousedown", (e) => {
    drag = { x: e.offsetX, v0, v1, moved: false };
  });
  window.addEventListener("mousemove", (e) => {
    if (!drag) return;
    const dx = e.clientX - canvas.getBoundingClientRect().left - drag.x;
    if (Math.abs(dx) > 3) drag.moved = true;
    if (drag.moved) {
      const dt = dx / scale;
      v0 = drag.v0 - dt;
      v1 = drag.v1 - dt;
      $("follow").checked = false;
      schedule();
    }
  });
  window.addEventListener("mouseup", (e) => {
    if (!drag) return;
    const wasDrag = drag.moved;
    drag = null;
    if (wasDrag || e.target !== canvas) return;
    const i = hit(e.offsetX, e.offsetY);
    lookBack();
    if (i >= 0) showRecord(i);
    else setCursor(toT(e.offsetX), true);
  });
  canvas.addEventListener(
    "wheel",
    (e) => {
      e.preventDefault();
      lookBack();
      const t = toT(e.offsetX);
      const f = Math.pow(1.2, e.deltaY / 100);
      const w = Math.max(1000, (v1 - v0) * f);
      v0 = t - (t - v0) * (w / (v1 - v0));
      v1 = v0 + w;
      schedule();
    },
    { passive: false }
  );
  $("slider").addEventListener("input", (e) => {
    lookBack();
    setCursor(Number(e.target.value));
  });
  $("fit").addEventListener("click", fit);
  $("prev").addEventListener("click", () => {
    lookBack();
    stepTo(-1);
  });
  $("next").addEventListener("click", () => {
    lookBack();
    stepTo(1);
  });
  window.addEventListener("resize", schedule);
  window.addEventListener("hashchange", fromHash);

  // `#t=4s`, `#t=1500ms`, `#t=2` (seconds): where the cursor starts.
  function fromHash() {
    const m = /t=([0-9.]+)(ns|us|ms|s)?/.exec(location.hash);
    if (!m) return false;
    const unit = { ns: 1, us: 1e3, ms: 1e6, s: 1e9 }[m[2] || "s"];
    setCursor(Number(m[1]) * unit);
    return true;
  }

  // --- the API tests and tools use ---

  window.radar = {
    records,
    lanes: () => lanes.map((l) => l.name),
    graphAt: (t) => {
      const g = graphAt(t);
      return {
        plugins: Object.fromEntries(g.plugins),
        connections: Object.fromEntries(g.connections),
        board: Object.fromEntries(g.board),
      };
    },
    setCursor,
    stats,
  };

  // --- start: the inlined trace, or the live stream ---

  let liveState = "connecting";
  const t0 = performance.now();
  const inlined = JSON.parse($("trace").textContent || "[]");
  stats.parseMs = performance.now() - t0;
  const t1 = performance.now();
  add(inlined);
  stats.indexMs = performance.now() - t1;
  fit();
  if (!fromHash()) setCursor(0);
  draw();
  updateStatus();
  stats.firstDrawMs = stats.lastDrawMs;
  if (RADAR_LIVE) {
    $("follow").checked = true;
    const source = new EventSource("events");
    source.onopen = () => {
      liveState = "running";
      updateStatus();
    };
    // Between records the run's time goes on: the page moves its end on
    // by the wall clock since the last batch came (a response's open span
    // grows), until the next batch says where the run is.
    let arrived = { t: 0, at: performance.now() };
    const follow = () => {
      if ($("follow").checked) {
        const w = v1 - v0;
        if (end > v1) {
          // Showing the run from its start: it grows with the run. A
          // window zoomed in elsewhere keeps its width and slides.
          if (v0 <= 0) {
            v1 = end * 1.02;
          } else {
            v1 = end + w * 0.02;
            v0 = Math.max(0, v1 - w);
          }
        }
        setCursor(end, true);
      } else {
        schedule();
      }
    };
    $("follow").addEventListener("change", () => {
      if ($("follow").checked) follow();
    });
    source.onmessage = (e) => {
      add(e.data.split("\n").filter((line) => line).map((line) => JSON.parse(line)));
      arrived = { t: records.length ? records[records.length - 1].t : 0, at: performance.now() };
      follow();
    };
    const ticking = setInterval(() => {
      if (liveState === "ended") return clearInterval(ticking);
      if (liveState !== "running" || !records.length) return;
      end = Math.max(end, arrived.t + (performance.now() - arrived.at) * 1e6);
      follow();
    }, 250);
    source.addEventListener("end", () => {
      liveState = "ended";
      source.close();
      // The run's end is its last record, not the page's guess.
      if (records.length) end = records[records.length - 1].t;
      follow();
    });
    source.onerror = () => {
      if (liveState !== "ended") liveState = "disconnected";
      schedule();
    };
  } else {
    $("follow-label").hidden = true;
  }
  if (location.hash.includes("bench")) bench();

  // `#bench`: the figures docs/view.md quotes, written into the page.
  function bench() {
    const figures = { records: records.length, parseMs: stats.parseMs, indexMs: stats.indexMs, firstDrawMs: stats.firstDrawMs };
    const time = (f, n) => {
      const s = performance.now();
      for (let k = 0; k < n; k++) f(k);
      return (performance.now() - s) / n;
    };
    fit();
    figures.drawWholeRunMs = time(() => draw(), 10);
    figures.itemsDrawnWholeRun = stats.lastDrawItems;
    v0 = end / 2;
    v1 = v0 + end / 1000;
    figures.drawZoomedMs = time(() => draw(), 10);
    figures.sliderMoveMs = time((k) => setCursor(((k * 7919) % 100) / 100 * end, true), 20);
    const out = document.createElement("pre");
    out.id = "bench";
    out.textContent = JSON.stringify(figures);
    document.body.appendChild(out);
  }
})();
