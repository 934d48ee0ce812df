// The dashboard's script: reads /api/state once, then follows /api/events
// (server-sent events) and redraws. Charts are inline SVG drawn here: no
// library, nothing fetched from elsewhere.
"use strict";

const state = { run: {}, rows: [], status: {}, eval: null, replay: null };

// 1234 -> "1234", 20000 -> "20k", 2000000 -> "2M", 0.25 -> "0.25" (as the PNG figures).
function tick(v) {
  const short = (x) => {
    let s = (x + 0).toFixed(2);
    if (s.includes(".")) s = s.replace(/0+$/, "").replace(/\.$/, "");
    return s === "-0" ? "0" : s;
  };
  const a = Math.abs(v);
  if (a >= 1e6) return short(v / 1e6) + "M";
  if (a >= 1e4) return short(v / 1e3) + "k";
  return short(v);
}

function pct(v) { return v == null || isNaN(v) ? "–" : tick(100 * v) + "%"; }
function num(v) { return v == null || isNaN(v) ? "–" : tick(v); }

// Round ticks (1, 2, 5 × 10^k) covering [lo, hi].
function ticks(lo, hi, n) {
  if (!(hi > lo)) { hi = lo + 1; }
  const raw = (hi - lo) / n;
  const mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= raw);
  const out = [];
  for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) out.push(t);
  return out;
}

const SVG = "http://www.w3.org/2000/svg";
function el(name, attrs, text) {
  const e = document.createElementNS(SVG, name);
  for (const k in attrs) e.setAttribute(k, attrs[k]);
  if (text != null) e.textContent = text;
  return e;
}

// A line chart of (env_steps, f(row)) into the <svg> with id `id`.
function chart(id, f, colour, yFixed) {
  const svg = document.getElementById(id);
  const W = svg.clientWidth || 600, H = svg.clientHeight || 220;
  const m = { l: 48, r: 24, t: 8, b: 26 };
  svg.setAttribute("viewBox", `0 0 ${W} ${H}`);
  while (svg.firstChild) svg.removeChild(svg.firstChild);
  const pts = state.rows.map((r) => [r.env_steps, f(r)]).filter((p) => p[1] != null && isFinite(p[1]));
  const budget = state.run.steps || 0;
  let x1 = Math.max(budget, ...pts.map((p) => p[0]), 1);
  let y0 = yFixed ? yFixed[0] : Math.min(...pts.map((p) => p[1]));
  let y1 = yFixed ? yFixed[1] : Math.max(...pts.map((p) => p[1]));
  if (!isFinite(y0) || !isFinite(y1)) { y0 = 0; y1 = 1; }
  if (y1 - y0 < 1e-9) { y0 -= 0.5; y1 += 0.5; }
  if (!yFixed) { const pad = (y1 - y0) * 0.05; y0 -= pad; y1 += pad; }
  const X = (x) => m.l + (x / x1) * (W - m.l - m.r);
  const Y = (y) => H - m.b - ((y - y0) / (y1 - y0)) * (H - m.t - m.b);
  for (const t of ticks(y0, y1, 5)) {
    svg.appendChild(el("line", { x1: m.l, x2: W - m.r, y1: Y(t), y2: Y(t), stroke: "#e3e3e6" }));
    svg.appendChild(el("text", { x: m.l - 6, y: Y(t) + 4, "text-anchor": "end", "font-size": 11, fill: "#6b6b70" }, tick(t)));
  }
  for (const t of ticks(0, x1, 5)) {
    svg.appendChild(el("text", { x: X(t), y: H - 8, "text-anchor": "middle", "font-size": 11, fill: "#6b6b70" }, tick(t)));
  }
  svg.appendChild(el("line", { x1: m.l, x2: W - m.r, y1: H - m.b, y2: H - m.b, stroke: "#b0b0b5" }));
  if (pts.length === 0) {
    svg.appendChild(el("text", { x: W / 2, y: H / 2, "text-anchor": "middle", fill: "#6b6b70" }, "no episode finished yet"));
    return;
  }
  const d = pts.map((p, i) => (i ? "L" : "M") + X(p[0]).toFixed(1) + "," + Y(p[1]).toFixed(1)).join(" ");
  svg.appendChild(el("path", { d, fill: "none", stroke: colour, "stroke-width": 2 }));
  const last = pts[pts.length - 1];
  svg.appendChild(el("circle", { cx: X(last[0]), cy: Y(last[1]), r: 3.5, fill: colour }));
}

function numbers() {
  const r = state.rows[state.rows.length - 1] || {};
  const s = state.status || {};
  const budget = state.run.steps;
  const eta = r.steps_per_s > 0 && budget > r.env_steps ? (budget - r.env_steps) / r.steps_per_s : null;
  const clock = (t) => t == null ? "–" : t < 60 ? Math.round(t) + " s" : t < 3600 ? Math.floor(t / 60) + " min " + Math.round(t % 60) + " s" : Math.floor(t / 3600) + " h " + Math.round((t % 3600) / 60) + " min";
  const cells = [
    [budget ? "env steps of " + tick(budget) : "env steps", num(r.env_steps)],
    ["steps/s", num(r.steps_per_s == null ? null : Math.round(r.steps_per_s))],
    ["success", pct(r.success_rate)],
    ["return", r.episode_return_mean == null ? "–" : r.episode_return_mean.toFixed(2)],
    ["episodes", num(r.episodes)],
    ["updates", num(r.update)],
    ["actors", num(s.connected_actors)],
    ["ETA", clock(eta)],
  ];
  const box = document.getElementById("numbers");
  box.innerHTML = "";
  for (const [k, v] of cells) {
    const d = document.createElement("div");
    d.className = "num";
    d.innerHTML = "<b></b><span></span>";
    d.firstChild.textContent = v;
    d.lastChild.textContent = k;
    box.appendChild(d);
  }
}

function table(id, rows) {
  const t = document.getElementById(id);
  t.innerHTML = "";
  for (const [k, v] of rows) {
    const tr = document.createElement("tr");
    const a = document.createElement("td"), b = document.createElement("td");
    a.textContent = k; b.textContent = v;
    tr.appendChild(a); tr.appendChild(b); t.appendChild(tr);
  }
}

function status() {
  const s = state.status || {};
  const rows = [["connected actors", num(s.connected_actors)], ["queue depth", num(s.queue_depth)]];
  for (const k in s.fragments || {}) rows.push(["fragments " + k.replace(/_/g, " "), num(s.fragments[k])]);
  table("t-fragments", rows);
}

function evaluation() {
  const e = state.eval;
  if (!e || !e.episodes) return;
  table("t-eval", [
    ["checkpoint", e.checkpoint || "–"],
    ["map, agents", `${e.map}, ${e.agents}`],
    ["episodes (seed)", `${e.episodes} (${e.seed})`],
    ["success", pct(e.success_rate)],
    ["timesteps median", num(e.timesteps_median)],
    ["episodes with a deadlock", pct(e.deadlock_episode_rate)],
    ["failures ending jammed", num(e.failures_ending_jammed)],
  ]);
}

function replay() {
  const r = state.replay;
  if (!r) return;
  document.getElementById("replay-caption").textContent = r.caption;
  if (shownReplay === r.version) return;
  shownReplay = r.version;
  // Fetched, then shown from memory: one request per new replay.
  fetch("/api/replay.gif?v=" + r.version, { cache: "no-store" })
    .then((res) => res.blob())
    .then((blob) => {
      const img = document.getElementById("replay-img");
      if (img.src.startsWith("blob:")) URL.revokeObjectURL(img.src);
      img.src = URL.createObjectURL(blob);
      img.alt = r.caption;
      img.hidden = false;
    });
}
let shownReplay = null;

function run() {
  const r = state.run || {};
  if (!r.algo) return;
  document.getElementById("run").textContent =
    `${r.algo} ${r.mode} on ${r.map}, ${r.agents} agents, seed ${r.seed}, ${tick(r.steps)} env steps`;
}

function redraw() {
  run(); numbers(); status(); evaluation(); replay();
  chart("c-success", (r) => r.success_rate == null ? null : 100 * r.success_rate, "#2c8c3c", [0, 100]);
  chart("c-return", (r) => r.episode_return_mean, "#1f77b4");
  chart("c-length", (r) => r.episode_len_mean, "#ff7f0e");
  chart("c-rate", (r) => r.steps_per_s, "#9467bd");
}

let pending = false;
function soon() {
  if (pending) return;
  pending = true;
  requestAnimationFrame(() => { pending = false; redraw(); });
}

async function load() {
  const res = await fetch("/api/state", { cache: "no-store" });
  Object.assign(state, await res.json());
  soon();
}

function follow() {
  const live = document.getElementById("live");
  const es = new EventSource("/api/events");
  es.addEventListener("hello", () => { live.className = "on"; live.textContent = "live"; load(); });
  es.addEventListener("run", (e) => { state.run = JSON.parse(e.data); soon(); });
  es.addEventListener("row", (e) => {
    const row = JSON.parse(e.data);
    const last = state.rows[state.rows.length - 1];
    // A row that came with the snapshot already.
    if (!last || row.update > last.update) state.rows.push(row);
    soon();
  });
  es.addEventListener("status", (e) => { state.status = JSON.parse(e.data); soon(); });
  es.addEventListener("eval", (e) => { state.eval = JSON.parse(e.data); soon(); });
  es.addEventListener("replay", (e) => { state.replay = JSON.parse(e.data); soon(); });
  es.addEventListener("resync", load);
  es.onerror = () => { live.className = "off"; live.textContent = "disconnected (run over?)"; };
}

window.addEventListener("resize", soon);
load();
follow();
