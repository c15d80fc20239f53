// pendulum-atlas explore: the page. Plain JavaScript and canvas, no build step and no network
// beyond this server. Colours come from the server (the PNG heat maps' own rule).
"use strict";

const $ = (id) => document.getElementById(id);
const state = { map: null, field: null, cellCache: new Map(), selected: null, poll: null, job: null };
const M = { left: 78, right: 118, top: 30, bottom: 56 };  // heat-map margins (px)

async function api(url, opts) {
  const r = await fetch(url, opts);
  const body = await r.json().catch(() => ({ error: `${r.status} ${r.statusText}` }));
  if (!r.ok) throw new Error(body.error || `${r.status} ${r.statusText}`);
  return body;
}

function showError(el, err) {
  el.textContent = String(err.message || err);
  el.hidden = false;
}

function fmt(v, digits = 4) {
  if (v === null || v === undefined || Number.isNaN(v)) return "–";
  if (v === 0) return "0";
  const a = Math.abs(v);
  if (a >= 1e4 || a < 1e-3) return v.toExponential(digits - 1);
  return Number(v.toPrecision(digits)).toString();
}

// ---- the heat map -------------------------------------------------------------------------

function plotArea(canvas) {
  return { x: M.left, y: M.top, w: canvas.width - M.left - M.right, h: canvas.height - M.top - M.bottom };
}

// Canvas rectangle of page cell (ix, iy); iy = 0 is the bottom row.
function cellRect(ix, iy) {
  const f = state.field, a = plotArea($("map"));
  const x0 = Math.round(a.x + ix * a.w / f.nx), x1 = Math.round(a.x + (ix + 1) * a.w / f.nx);
  const y1 = Math.round(a.y + a.h - iy * a.h / f.ny), y0 = Math.round(a.y + a.h - (iy + 1) * a.h / f.ny);
  return { x: x0, y: y0, w: x1 - x0, h: y1 - y0 };
}

function cellAt(px, py) {
  const f = state.field, a = plotArea($("map"));
  if (!f || px < a.x || px >= a.x + a.w || py < a.y || py >= a.y + a.h) return null;
  const ix = Math.min(f.nx - 1, Math.floor((px - a.x) / a.w * f.nx));
  const iy = Math.min(f.ny - 1, Math.floor((a.y + a.h - py) / a.h * f.ny));
  return { ix, iy, k: f.cells[iy * f.nx + ix], at: iy * f.nx + ix };
}

// Ticks come with `at`, where they lie in cells from the first edge (within the cell linearly,
// or in log space on a log axis), as the PNG maps place them: the server computes it with their
// code. Minor ticks (a log axis over a few decades) are positions only, marked shorter.

function drawMap() {
  const c = $("map"), g = c.getContext("2d"), f = state.field, m = state.map;
  const a = plotArea(c);
  g.fillStyle = "#fff";
  g.fillRect(0, 0, c.width, c.height);
  for (let iy = 0; iy < f.ny; iy++) {
    for (let ix = 0; ix < f.nx; ix++) {
      const r = cellRect(ix, iy);
      g.fillStyle = f.colours[iy * f.nx + ix];
      g.fillRect(r.x, r.y, r.w, r.h);
    }
  }
  drawMarks(g);
  drawCurves(g, a);
  if (state.selected !== null) {
    const at = f.cells.indexOf(state.selected);
    if (at >= 0) {
      const r = cellRect(at % f.nx, Math.floor(at / f.nx));
      g.strokeStyle = "#fff"; g.lineWidth = 2;
      g.strokeRect(r.x + 1, r.y + 1, r.w - 2, r.h - 2);
      g.strokeStyle = "#000"; g.lineWidth = 1;
      g.strokeRect(r.x + 0.5, r.y + 0.5, r.w - 1, r.h - 1);
    }
  }
  g.strokeStyle = "#333"; g.lineWidth = 1;
  g.strokeRect(a.x - 0.5, a.y - 0.5, a.w + 1, a.h + 1);
  g.fillStyle = "#222"; g.font = "12px sans-serif";
  const xa = m.axes[0];
  g.textAlign = "center"; g.textBaseline = "top";
  for (const at of xa.minor) g.fillRect(Math.round(a.x + at / f.nx * a.w), a.y + a.h, 1, 2);
  for (const t of xa.ticks) {
    const x = a.x + t.at / f.nx * a.w;
    g.fillRect(Math.round(x), a.y + a.h, 1, 3);
    g.fillText(t.label, x, a.y + a.h + 4);
  }
  g.fillText(xa.label, a.x + a.w / 2, a.y + a.h + 24);
  if (m.axes.length > 1) {
    const ya = m.axes[1];
    g.textAlign = "right"; g.textBaseline = "middle";
    for (const at of ya.minor) g.fillRect(a.x - 2, Math.round(a.y + a.h - at / f.ny * a.h), 2, 1);
    for (const t of ya.ticks) {
      const y = a.y + a.h - t.at / f.ny * a.h;
      g.fillRect(a.x - 3, Math.round(y), 3, 1);
      g.fillText(t.label, a.x - 5, y);
    }
    g.save(); g.translate(16, a.y + a.h / 2); g.rotate(-Math.PI / 2);
    g.textAlign = "center"; g.fillText(ya.label, 0, 0); g.restore();
  }
  let title = f.label;
  const held = f.slice.map((i, d) => `${m.axes[d + 2].key} = ${fmt(m.axes[d + 2].values[i], 4)}`);
  if (held.length) title += `  at ${held.join(", ")}`;
  g.textAlign = "left"; g.textBaseline = "top"; g.font = "bold 13px sans-serif";
  g.fillText(title, a.x, 8);
  drawBar(g, a);
  drawLegend();
}

// The transient stage's marks over the regime and period pictures, as the PNGs draw them:
// a back-hatch where the start decides (nudged copies disagree), a dot where the verdict is
// the orbit after a chaotic transient. Bits as in the server's folder::MARK_*.
const MARK_START_DECIDES = 1, MARK_AFTER_TRANSIENT = 2;
function drawMarks(g) {
  const f = state.field, marks = f.marks || [];
  g.save();
  g.strokeStyle = "rgba(255,255,255,0.8)"; g.fillStyle = "rgba(255,255,255,0.9)"; g.lineWidth = 1;
  marks.forEach((m, at) => {
    if (!m) return;
    const r = cellRect(at % f.nx, Math.floor(at / f.nx));
    if (m & MARK_START_DECIDES) {
      g.save(); g.beginPath(); g.rect(r.x, r.y, r.w, r.h); g.clip(); g.beginPath();
      for (let d = -r.h; d < r.w; d += 5) { g.moveTo(r.x + d, r.y); g.lineTo(r.x + d + r.h, r.y + r.h); }
      g.stroke(); g.restore();
    }
    if (m & MARK_AFTER_TRANSIENT) {
      g.beginPath(); g.arc(r.x + r.w / 2, r.y + r.h / 2, Math.max(1.5, Math.min(r.w, r.h) / 5), 0, 2 * Math.PI); g.fill();
    }
  });
  g.restore();
}

// The orbit stage's bifurcation curves (period doubling, folds, grazing) over the regime and
// period pictures, as the PNGs draw them; the server places each point in cells.
function drawCurves(g, a) {
  const f = state.field, curves = state.map.curves || [];
  if (!["regime", "period"].includes(f.metric) || !curves.length) return;
  g.lineWidth = 3;
  for (const c of curves) {
    const pts = c.points.map(([x, y]) => [a.x + x / f.nx * a.w, a.y + a.h - y / f.ny * a.h]);
    g.strokeStyle = c.colour; g.fillStyle = c.colour;
    if (pts.length === 1) {
      g.beginPath(); g.arc(pts[0][0], pts[0][1], 3, 0, 2 * Math.PI); g.fill();
      continue;
    }
    g.beginPath(); g.moveTo(pts[0][0], pts[0][1]);
    for (const [x, y] of pts.slice(1)) g.lineTo(x, y);
    g.stroke();
  }
  g.lineWidth = 1;
}

function drawBar(g, a) {
  const f = state.field, x = a.x + a.w + 16, w = 18;
  const n = f.bar.length;
  if (n === 0) return;  // categories: named in the legend below the map
  for (let i = 0; i < n; i++) {
    const y0 = a.y + a.h - (i + 1) * a.h / n;
    g.fillStyle = f.bar[i];
    g.fillRect(x, Math.floor(y0), w, Math.ceil(a.h / n) + 1);
  }
  g.strokeStyle = "#333"; g.strokeRect(x - 0.5, a.y - 0.5, w + 1, a.h + 1);
  g.fillStyle = "#222"; g.font = "11px sans-serif"; g.textAlign = "left"; g.textBaseline = "middle";
  const [lo, hi] = f.range;
  for (let i = 0; i <= 4; i++) {
    const v = lo + (hi - lo) * i / 4;
    g.fillText(fmt(v, 3), x + w + 4, a.y + a.h - i * a.h / 4);
  }
}

function drawLegend() {
  const f = state.field, el = $("legend");
  el.innerHTML = "";
  const add = (colour, text) => {
    const s = document.createElement("span"); s.className = "sw"; s.style.background = colour;
    el.append(s, text);
  };
  for (const [colour, name] of f.categories) add(colour, name);
  if (["regime", "period"].includes(f.metric)) {
    const seen = new Set();
    for (const c of state.map.curves || []) {
      if (!seen.has(c.kind)) { seen.add(c.kind); add(c.colour, `${c.kind} (orbit stage)`); }
    }
  }
  const marks = f.marks || [];
  if (marks.some((m) => m & MARK_START_DECIDES)) add("#bbbbbb", "hatched: the start decides (nudged copies disagree)");
  if (marks.some((m) => m & MARK_AFTER_TRANSIENT)) add("#bbbbbb", "dot: periodic after a chaotic transient");
  if (f.status.some((s) => s !== "ok")) add(f.invalid_colour, "failed (diverged, non-finite or escaped)");
  if (f.values.some((v, i) => v === null && f.status[i] === "ok")) {
    add(f.nodata_colour, f.metric === "period" ? "no period found" : "no data");
  }
}

async function loadField() {
  const metric = $("metric").value;
  const slice = [...document.querySelectorAll("#slices select")].map((s) => s.value).join(",");
  state.field = await api(`/api/field?metric=${encodeURIComponent(metric)}&slice=${slice}`);
  drawMap();
  $("map").dataset.metric = metric;
  $("map").dataset.ready = "1";
}

// ---- hover and click --------------------------------------------------------------------

async function cellInfo(k) {
  if (!state.cellCache.has(k)) state.cellCache.set(k, await api(`/api/cell/${k}`));
  return state.cellCache.get(k);
}

async function onHover(ev) {
  const tip = $("tip"), p = cellAt(ev.offsetX, ev.offsetY);
  if (!p) { tip.hidden = true; return; }
  const info = await cellInfo(p.k);
  const lines = info.values.map(([k, v]) => `${k} = ${fmt(v, 6)}`);
  lines.push(`status: ${info.status}`);
  if (info.inferred) lines.push("inferred: filled from its refinement block (run it to compute it)");
  for (const [k, v] of Object.entries(info.columns)) {
    lines.push(`${k}: ${k === "period" && v === null && info.status === "ok" ? "none" : fmt(v)}`);
  }
  tip.textContent = `cell ${p.k}\n` + lines.join("\n");
  tip.style.left = `${ev.offsetX + 14}px`;
  tip.style.top = `${ev.offsetY + 10}px`;
  tip.hidden = false;
}

async function onClick(ev) {
  const p = cellAt(ev.offsetX, ev.offsetY);
  if (p) runCell(p.k).catch((e) => failCell(e));
}

function setCellState(st, text) {
  const el = $("cellState");
  el.dataset.state = st;
  el.textContent = text;
}

function failCell(err) {
  setCellState("failed", "The run failed.");
  $("cellProgress").hidden = true;
  $("cellCancel").hidden = true;
  showError($("cellError"), err);
}

async function runCell(k) {
  if (state.poll) clearTimeout(state.poll);
  state.selected = k;
  drawMap();
  $("cellError").hidden = true;
  $("cellResult").hidden = true;
  const info = await cellInfo(k);
  $("cellTitle").textContent = `Cell ${k}: ` +
    info.values.map(([key, v]) => `${key} = ${fmt(v, 6)}`).join(", ");
  showAttractors(k, info.attractors);
  setCellState("queued", "Queued…");
  const variant = $("variant").value || 0;
  let job = await api(`/api/cell/${k}/run?variant=${variant}`, { method: "POST" });
  const bar = $("cellProgress");
  bar.hidden = false;
  state.job = job.job;
  $("cellCancel").hidden = false;
  while (job.state === "queued" || job.state === "running") {
    if (job.state === "queued") setCellState("queued", `Waiting: ${job.ahead} run(s) ahead.`);
    else setCellState("running", `Integrating… ${Math.round(job.progress * 100)} %`);
    bar.value = job.state === "running" ? job.progress : 0;
    await new Promise((res) => { state.poll = setTimeout(res, 250); });
    if (state.selected !== k || ($("variant").value || 0) !== variant) return;
    job = await api(`/api/job/${job.job}`);
  }
  bar.hidden = true;
  $("cellCancel").hidden = true;
  state.job = null;
  if (job.state === "failed") throw new Error(job.error);
  showCell(job.result);
}

// A map run from several starts per cell: the cell's attractors, each with a button that runs
// the first start that reached it (the variant start + 1).
function showAttractors(k, attractors) {
  const list = $("attractorList");
  list.innerHTML = "";
  $("cellAttractors").hidden = !attractors || attractors.length === 0;
  for (const a of attractors || []) {
    const li = document.createElement("li");
    li.dataset.label = a.label;
    li.append(`${a.name} (label ${a.label}): ${fmt(100 * a.fraction, 3)} % `);
    const b = document.createElement("button");
    b.type = "button";
    b.textContent = `Run start ${a.start + 1}`;
    b.addEventListener("click", () => {
      $("variant").value = String(a.start + 1);
      runCell(k).catch((e) => failCell(e));
    });
    li.append(b);
    list.append(li);
  }
}

// ---- the cell's result --------------------------------------------------------------------

const ROWS = [["K", "K", "0–1 test K"], ["R", "R", "synchronisation R"], ["period", "period", "period (forcing periods)"],
              ["hops", "hops", "hops"], ["line_ratio", "line", "dominant line / f"]];

function showCell(r) {
  const tb = $("cellValues").querySelector("tbody");
  tb.innerHTML = "";
  for (const [simKey, mapKey, label] of ROWS) {
    const tr = document.createElement("tr");
    const th = document.createElement("th"); th.textContent = label; tr.append(th);
    for (const [who, v] of [["sim", r.simulated[simKey]], ["map", r.map[mapKey]], ["rerun", r.rerun[mapKey] ?? r.rerun[simKey]]]) {
      const td = document.createElement("td");
      td.id = `${who}-${simKey}`;
      td.dataset.value = v === null || v === undefined ? "" : String(v);
      // A period of 0 (simulate) or none stored (a map's no-data grey) means none was found.
      const none = simKey === "period" && (v === 0 || (who !== "sim" && v === null && r.status === "ok"));
      td.textContent = none ? "none" : fmt(v);
      tr.append(td);
    }
    tb.append(tr);
  }
  $("runInfo").textContent = (r.variant ? `run as ${r.variant}: ` : "") + `status ${r.status}, N = ${r.segments}, ${r.method}, dt = ${fmt(r.dt_s, 4)} s, ` +
    `${fmt(r.wall_s, 3)} s on this server` + (r.failed_at_s !== null ? `, stopped at t = ${fmt(r.failed_at_s)} s` : "");
  $("download").href = `/api/cell/${r.cell}/scene.toml?variant=${$("variant").value || 0}`;
  $("download").setAttribute("download", `cell_${r.cell}.toml`);
  const isMap = Object.keys(r.map).length > 0;
  for (const el of document.querySelectorAll("#cellValues th:nth-child(3), #cellValues td:nth-child(3)")) el.hidden = !isMap;
  const rerun = Object.keys(r.rerun).length > 0;
  for (const el of document.querySelectorAll("#cellValues th:nth-child(4), #cellValues td:nth-child(4)")) el.hidden = !rerun;
  const n = $("notes"); n.innerHTML = "";
  for (const t of r.notes) { const li = document.createElement("li"); li.textContent = t; n.append(li); }
  const w = $("warnings"); w.innerHTML = "";
  for (const t of r.warnings) { const li = document.createElement("li"); li.textContent = t; w.append(li); }
  $("cellResult").hidden = false;
  lineChart($("chartAlpha"), [{ c: r.alpha, colour: "#1f5fa8" }], "time (s)", "holder angle α (rad)", { shadeTo: r.transient_s });
  lineChart($("chartCart"), [{ c: { x: r.cart.x, y: r.cart.y.map((v) => v * 1e3) }, colour: "#b5531d" }], "time (s)", "cart x0 (mm)", {});
  lineChart($("chartPhase"), [{ c: r.phase, colour: "#1f5fa8", thin: true }], "α (rad)", "α̇ (rad/s)", { title: "phase portrait", padX: true });
  lineChart($("chartStrobe"), [{ c: r.strobe, colour: "#b01c5b", dots: true }], "α (rad)", "α̇ (rad/s)", { title: "stroboscopic section", padX: true });
  lineChart($("chartSpectrum"), [{ c: r.spectrum, colour: "#1f5fa8" }], "frequency (Hz)", "amplitude of α", { logY: true, markX: r.forcing_hz });
  scalogram($("chartScalogram"), r.scalogram);
  setCellState("done", `Done (cell ${r.cell}).`);
}

function extent(vals, log, pad = 0.04) {
  let lo = Infinity, hi = -Infinity;
  for (const v of vals) {
    if (!Number.isFinite(v) || (log && v <= 0)) continue;
    if (v < lo) lo = v;
    if (v > hi) hi = v;
  }
  if (lo === Infinity) return [0, 1];
  if (log) { lo = Math.log10(lo); hi = Math.log10(hi); }
  if (hi === lo) { lo -= 0.5; hi += 0.5; }
  const d = (hi - lo) * pad;
  return [lo - d, hi + d];
}

function frame(g, c, xr, yr, xl, yl, title, logY) {
  const a = { x: 62, y: title ? 22 : 10, w: c.width - 72, h: c.height - (title ? 22 : 10) - 36 };
  g.fillStyle = "#fff"; g.fillRect(0, 0, c.width, c.height);
  g.strokeStyle = "#444"; g.strokeRect(a.x - 0.5, a.y - 0.5, a.w + 1, a.h + 1);
  g.fillStyle = "#222"; g.font = "11px sans-serif";
  g.textAlign = "center"; g.textBaseline = "top";
  for (let i = 0; i <= 4; i++) g.fillText(fmt(xr[0] + (xr[1] - xr[0]) * i / 4, 3), a.x + a.w * i / 4, a.y + a.h + 3);
  g.fillText(xl, a.x + a.w / 2, a.y + a.h + 18);
  g.textAlign = "right"; g.textBaseline = "middle";
  for (let i = 0; i <= 3; i++) {
    const v = yr[0] + (yr[1] - yr[0]) * i / 3;
    g.fillText(fmt(logY ? 10 ** v : v, 3), a.x - 3, a.y + a.h - a.h * i / 3);
  }
  g.save(); g.translate(10, a.y + a.h / 2); g.rotate(-Math.PI / 2); g.textAlign = "center"; g.fillText(yl, 0, 0); g.restore();
  if (title) { g.textAlign = "left"; g.textBaseline = "top"; g.font = "bold 12px sans-serif"; g.fillText(title, a.x, 4); }
  return a;
}

function lineChart(c, series, xl, yl, o) {
  const g = c.getContext("2d");
  const xs = series.flatMap((s) => s.c.x), ys = series.flatMap((s) => s.c.y);
  const xr = extent(xs, false, o.padX ? 0.04 : 0), yr = extent(ys, !!o.logY);
  const a = frame(g, c, xr, yr, xl, yl, o.title, o.logY);
  const X = (v) => a.x + (v - xr[0]) / (xr[1] - xr[0]) * a.w;
  const Y = (v) => a.y + a.h - ((o.logY ? Math.log10(v) : v) - yr[0]) / (yr[1] - yr[0]) * a.h;
  if (o.shadeTo) { g.fillStyle = "rgba(0,0,0,0.06)"; g.fillRect(a.x, a.y, Math.max(0, X(o.shadeTo) - a.x), a.h); }
  if (o.markX) { g.strokeStyle = "#bbb"; g.setLineDash([3, 3]); g.beginPath(); g.moveTo(X(o.markX), a.y); g.lineTo(X(o.markX), a.y + a.h); g.stroke(); g.setLineDash([]); }
  g.save(); g.beginPath(); g.rect(a.x, a.y, a.w, a.h); g.clip();
  for (const s of series) {
    g.strokeStyle = s.colour; g.fillStyle = s.colour; g.lineWidth = s.thin ? 0.6 : 1;
    if (s.dots) {
      for (let i = 0; i < s.c.x.length; i++) { g.fillRect(X(s.c.x[i]) - 1.5, Y(s.c.y[i]) - 1.5, 3, 3); }
    } else {
      g.beginPath();
      let pen = false;
      for (let i = 0; i < s.c.x.length; i++) {
        const y = s.c.y[i];
        if (!Number.isFinite(y) || (o.logY && y <= 0)) { pen = false; continue; }
        if (pen) g.lineTo(X(s.c.x[i]), Y(y)); else g.moveTo(X(s.c.x[i]), Y(y));
        pen = true;
      }
      g.stroke();
    }
  }
  g.restore();
}

function scalogram(c, s) {
  const g = c.getContext("2d");
  if (!s.t_s.length) { g.clearRect(0, 0, c.width, c.height); g.fillText("no wavelet power (run not analysed)", 20, 20); return; }
  const xr = [s.t_s[0], s.t_s[s.t_s.length - 1]];
  const yr = [Math.log10(s.period_s[0]), Math.log10(s.period_s[s.period_s.length - 1])];
  const a = frame(g, c, xr, yr, "time (s)", "period (s)", "scalogram of α (log2 power)", true);
  const bar = state.map.scalogram_bar;
  const nr = s.period_s.length, nc = s.t_s.length;
  for (let i = 0; i < nr; i++) {
    for (let j = 0; j < nc; j++) {
      const t = Math.min(1, Math.max(0, (s.log2_power[i][j] + 16) / 16));
      g.fillStyle = bar[Math.round(t * (bar.length - 1))];
      const x0 = a.x + j * a.w / nc, y0 = a.y + a.h - (i + 1) * a.h / nr;
      g.fillRect(x0, y0, a.w / nc + 1, a.h / nr + 1);
    }
  }
  g.strokeStyle = "#fff"; g.setLineDash([4, 3]); g.beginPath();
  for (let j = 0; j < nc; j++) {
    const p = Math.min(Math.max(Math.log10(Math.max(s.coi_s[j], 1e-300)), yr[0]), yr[1]);
    const x = a.x + (j + 0.5) * a.w / nc, y = a.y + a.h - (p - yr[0]) / (yr[1] - yr[0]) * a.h;
    if (j) g.lineTo(x, y); else g.moveTo(x, y);
  }
  g.stroke(); g.setLineDash([]);
}

// ---- start ------------------------------------------------------------------------------

async function start() {
  const m = await api("/api/map");
  state.map = m;
  if (m.axes.length === 1) $("map").height = 200;  // one row of cells
  const r = m.run;
  $("about").textContent = `${m.kind}: ${m.folder}: ${m.cells} cells, N = ${r.segments}` +
    (r.method ? `, ${r.method}` : "") + (r.backend ? `, ${r.backend} (${r.adapter}), ${r.precision}` : "");
  for (const x of m.metrics) {
    const o = document.createElement("option"); o.value = x.name; o.textContent = `${x.name} — ${x.label}`;
    $("metric").append(o);
  }
  m.axes.slice(2).forEach((axis) => {
    const label = document.createElement("label"), sel = document.createElement("select");
    label.append(`${axis.key} `, sel);
    axis.values.forEach((v, i) => {
      const o = document.createElement("option"); o.value = i; o.textContent = fmt(v, 6); sel.append(o);
    });
    sel.addEventListener("change", () => loadField().catch((e) => showError($("error"), e)));
    $("slices").append(label);
  });
  if (m.variants.length) {
    m.variants.forEach((name, i) => {
      const o = document.createElement("option"); o.value = i; o.textContent = name; $("variant").append(o);
    });
    $("variantName").textContent = { calibrate: "run in case", map: "run from" }[m.kind] || "run at";
    $("variantRow").hidden = false;
    $("variant").addEventListener("change", () => {
      if (state.selected !== null) runCell(state.selected).catch((e) => failCell(e));
    });
  }
  const lim = m.cell_limits;
  $("cellLimits").textContent = `A cell run may take ${fmt(lim.wall_s, 4)} s and ${lim.memory}; ` +
    "a longer run is stopped, a larger one refused (download its scene and run simulate instead).";
  $("cellCancel").addEventListener("click", () => {
    if (state.job !== null) api(`/api/job/${state.job}/cancel`, { method: "POST" }).catch((e) => failCell(e));
  });
  if (m.bifurcation) { $("bifurcation").src = "/files/bifurcation.png"; $("bifurcationFigure").hidden = false; }
  $("metric").addEventListener("change", () => loadField().catch((e) => showError($("error"), e)));
  $("map").addEventListener("mousemove", (e) => onHover(e).catch(() => {}));
  $("map").addEventListener("mouseleave", () => { $("tip").hidden = true; });
  $("map").addEventListener("click", onClick);
  await loadField();
}

window.atlas = { cellRect, cellAt, state, runCell };
start().catch((e) => showError($("error"), e));
