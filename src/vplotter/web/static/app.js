// The page: everything through the JSON API (/api), live status from /api/events.
"use strict";

const $ = (sel, root = document) => root.querySelector(sel);
const $$ = (sel, root = document) => Array.from(root.querySelectorAll(sel));
const field = (name) => $(`[data-field="${name}"]`);

function token() {
  const m = document.cookie.match(/(?:^|;\s*)vplotter_token=([^;]+)/);
  return m ? decodeURIComponent(m[1]) : null;
}

function headers(extra = {}) {
  const h = { "X-Vplotter": "1", ...extra };
  const t = token();
  if (t) h.Authorization = `Bearer ${t}`;
  return h;
}

async function call(method, path, body) {
  const opts = { method, headers: headers() };
  if (body instanceof FormData) opts.body = body;
  else if (body !== undefined) {
    opts.body = JSON.stringify(body);
    opts.headers["Content-Type"] = "application/json";
  }
  const r = await fetch(path, opts);
  let data = null;
  try { data = await r.json(); } catch (e) { data = null; }
  if (!r.ok) {
    const err = new Error((data && data.error) || `${r.status} ${r.statusText}`);
    err.need = data && data.need;
    throw err;
  }
  return data;
}

function say(text) { field("message").textContent = text || ""; }

// an error for a person: what to do when the page knows (the position, the backend)
function explain(e) {
  $("#position").classList.toggle("need", e.need === "position");
  if (e.need === "position") {
    say(`${e.message}.`);
    $("#position").scrollIntoView({ block: "nearest" });
  } else if (e.need === "backend") {
    say("The plotter's GPIO backend cannot start here, so nothing moved: " + e.message +
        ". To try the page on a computer without a plotter, set [gpio] backend = \"fake\" " +
        "and realtime = true in config.toml (docs/web.md).");
  } else {
    say(e.message);
  }
}

function clock(s) {
  if (s === null || s === undefined) return "–";
  s = Math.round(s);
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
  const two = (v) => String(v).padStart(2, "0");
  return h ? `${h}:${two(m)}:${two(sec)}` : `${m}:${two(sec)}`;
}

let status = null;
let setup = null;
let files = [];           // GET /api/files
let selected = null;      // the name of the file whose options, notes and preview are shown
let pending = Promise.resolve();   // options being estimated: draw and preview wait for them

let jobs = [];            // GET /api/queue: the jobs

// the stopped drawing is the queue's first job: resuming it is running the queue
const queueStopped = () => !!(jobs.length && jobs[0].stopped && status && status.resume &&
                              status.resume.file.endsWith(`/${jobs[0].id}/${jobs[0].name}`));

// ------------------------------------------------------------------ queue and history
function el(tag, cls, text) {
  const e = document.createElement(tag);
  if (cls) e.className = cls;
  if (text !== undefined) e.textContent = text;
  return e;
}

function renderQueue(q) {
  jobs = q.jobs;
  field("queue").replaceChildren(...jobs.map((j, k) => {
    const li = el("li");
    li.dataset.job = j.id;
    const left = j.copies - j.done;
    const copies = j.copies > 1 ? `, copy ${j.done + 1} of ${j.copies}` : "";
    const opts = j.options.length ? ` ${j.options.join(" ")}` : "";
    li.append(el("span", "name", `${j.name}${opts}`),
              el("span", "est", ` ${clock(j.left_s)}${copies}` +
                 (left > 1 ? ` (${left} copies left)` : "")));
    if (j.stopped) li.append(el("div", "stopped", "stopped part-way: Run goes on from there"));
    const row = el("div", "row");
    const mk = (action, label, off) => {
      const b = el("button", "", label);
      b.dataset.action = action;
      b.dataset.job = j.id;
      b.disabled = off;
      return b;
    };
    row.append(mk("queue-up", "▲ earlier", k === 0),
               mk("queue-down", "▼ later", k === jobs.length - 1),
               mk("queue-remove", "Remove", false));
    li.append(row);
    return li;
  }));
  field("queue-total").textContent = jobs.length
    ? `${jobs.length} drawing${jobs.length > 1 ? "s" : ""}, ${clock(q.total_s)} in all` : "empty";
  if (status) show(status);
}

function historyLine(p) {
  const t = (s) => new Date(s * 1000);
  const two = (v) => String(v).padStart(2, "0");
  const hm = (d) => `${two(d.getHours())}:${two(d.getMinutes())}`;
  const start = t(p.start);
  const day = `${start.getFullYear()}-${two(start.getMonth() + 1)}-${two(start.getDate())}`;
  const when = `${day} ${hm(start)}${p.end ? "–" + hm(t(p.end)) : ""}`;
  const copy = p.copy ? ` (${p.copy})` : "";
  const took = p.actual_s !== null ? `, took ${clock(p.actual_s)}` : "";
  const pens = p.pens.length ? `, pens ${p.pens.join(", ")}` : "";
  return [`${when} ${p.file}${copy}: `, p.result + (p.error ? `: ${p.error}` : ""),
          `; planned ${clock(p.estimate_s)}${took}, ${p.drawn_m.toFixed(2)} m drawn${pens}`];
}

function renderHistory(plots) {
  field("history").replaceChildren(...plots.slice(-20).reverse().map((p) => {
    const [head, result, tail] = historyLine(p);
    const li = el("li");
    li.append(head, el("b", p.result.split(" ")[0], result), tail);
    return li;
  }));
  if (!plots.length) field("history").replaceChildren(el("li", "", "no plots yet"));
  const last = plots[plots.length - 1];
  if (plan && last && last.result === "done" && last.path === plan.file &&
      status && !status.drawing) grow(plan.n, frame());      // ended: all of it is drawn
}

async function refreshQueue() {
  try {
    const [q, h] = await Promise.all([call("GET", "/api/queue"), call("GET", "/api/history")]);
    renderQueue(q);
    renderHistory(h);
  } catch (e) {
    say(e.message);
  }
}

async function queueAct(a, button) {
  const id = button.dataset.job;
  if (a === "queue-add") {
    const file = field("queue-file").value;
    if (!file) { say("upload a drawing first, then add it to the queue"); return; }
    await pending;
    say(`checking ${file}…`);
    const r = await call("POST", "/api/queue", { file,
                                                 copies: Number(field("queue-copies").value) });
    say(r.message);
  } else if (a === "queue-up" || a === "queue-down") {
    const k = jobs.findIndex((j) => String(j.id) === id);
    renderQueue(await call("POST", `/api/queue/${id}/move`,
                           { position: a === "queue-up" ? k : k + 2 }));
    return;
  } else if (a === "queue-remove") {
    renderQueue(await call("DELETE", `/api/queue/${id}`));
    return;
  } else if (a === "queue-run") {
    await call("POST", "/api/queue/run");
    say("drawing the queue");
  }
  await refreshQueue();
}

// what changed since the last status: the queue and history when a drawing starts or ends
function changed(before, st) {
  const key = (x) => x ? [!!x.busy, x.drawing && x.drawing.file, x.drawing && x.drawing.state,
                          !!x.resume].join("|") : "";
  if (before && key(before) !== key(st)) refreshQueue();
  follow(st.drawing);
}

// ------------------------------------------------------------------ the drawing as it grows
let plan = null;          // the running drawing's path (GET /api/now/paths), and how far
let planKey = null;

async function follow(d) {
  if (!d) return;
  const key = `${d.file}\n${d.command}`;
  if (key !== planKey && !d.command.includes(" queue run")) {
    planKey = key;
    try {
      const p = await call("GET", "/api/now/paths");
      setPlan(p);
    } catch (e) {
      plan = null;
      field("live-box").hidden = true;
    }
  }
  if (plan && key === planKey) grow(d.line);
}

function setPlan(p) {
  const n = p.x.length;
  const cum = new Float64Array(n + 1);      // pen-down length up to each point (mm)
  let px = p.start[0], py = p.start[1], mono = true;
  for (let i = 0; i < n; i++) {
    const dl = Math.hypot(p.x[i] - px, p.y[i] - py);
    cum[i + 1] = cum[i] + (p.down[i] ? dl : 0);
    px = p.x[i]; py = p.y[i];
    if (i && p.line[i] < p.line[i - 1]) mono = false;
  }
  // the drawing's own box (with where the pen starts), a margin around it
  let x0 = p.start[0], x1 = p.start[0], y0 = p.start[1], y1 = p.start[1];
  for (let i = 0; i < n; i++) {
    x0 = Math.min(x0, p.x[i]); x1 = Math.max(x1, p.x[i]);
    y0 = Math.min(y0, p.y[i]); y1 = Math.max(y1, p.y[i]);
  }
  const pad = Math.max(2, 0.06 * Math.max(x1 - x0, y1 - y0));
  plan = { ...p, n, cum, mono, box: [x0 - pad, y0 - pad, x1 + pad, y1 + pad], drawnTo: 0 };
  field("live-box").hidden = false;
  paint(0);
}

// the points drawn once the record `line` is being drawn: those of the records before it
function reached(line) {
  const L = plan.line;
  if (!plan.mono) { const k = L.findIndex((v) => v >= line); return k < 0 ? plan.n : k; }
  let lo = 0, hi = plan.n;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (L[mid] < line) lo = mid + 1; else hi = mid; }
  return lo;
}

function frame() {
  const c = field("live");
  const [x0, y0, x1, y1] = plan.box;
  const ratio = window.devicePixelRatio || 1;
  const w = Math.max(200, c.clientWidth || 380) * ratio;
  const m = 0.03 * w;
  const scale = (w - 2 * m) / Math.max(x1 - x0, 1e-6);
  const h = Math.min(0.7 * (window.innerHeight || 900) * ratio, (y1 - y0) * scale + 2 * m);
  const sc = Math.min(scale, (h - 2 * m) / Math.max(y1 - y0, 1e-6));
  const ox = (w - (x1 - x0) * sc) / 2;        // centred across
  if (c.width !== Math.round(w) || c.height !== Math.round(h)) {
    c.width = Math.round(w);
    c.height = Math.round(h);
  }
  return { ctx: c.getContext("2d"), ratio,
           X: (x) => ox + (x - x0) * sc, Y: (y) => m + (y1 - y) * sc };
}

function strokes(f, from, to, down, colour, width, dash) {
  const { ctx, X, Y } = f;
  ctx.beginPath();
  ctx.strokeStyle = colour;
  ctx.lineWidth = width * f.ratio;
  ctx.setLineDash(dash ? dash.map((v) => v * f.ratio) : []);
  let open = false;
  for (let i = from; i < to; i++) {
    if (!!plan.down[i] !== down) { open = false; continue; }
    const px = i ? plan.x[i - 1] : plan.start[0], py = i ? plan.y[i - 1] : plan.start[1];
    if (!open) { ctx.moveTo(X(px), Y(py)); open = true; }
    ctx.lineTo(X(plan.x[i]), Y(plan.y[i]));
  }
  ctx.stroke();
}

// the whole plan faint, the part drawn (up to point k) dark, pen-up travel fainter still
function paint(k) {
  const f = frame();
  const { ctx, X, Y } = f;
  const pg = plan.page;
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = "#e4e4e0";
  ctx.fillRect(0, 0, ctx.canvas.width, ctx.canvas.height);
  ctx.fillStyle = "#fff";
  ctx.fillRect(X(pg.x_min_mm), Y(pg.y_max_mm), X(pg.x_max_mm) - X(pg.x_min_mm),
               Y(pg.y_min_mm) - Y(pg.y_max_mm));
  strokes(f, 0, plan.n, true, "#c9ced6", 1);
  strokes(f, 0, plan.n, false, "rgba(90, 120, 170, 0.18)", 0.7, [3, 3]);
  plan.drawnTo = 0;
  grow(k, f);
}

function grow(line, f) {
  const k = f ? line : reached(line);
  if (k < plan.drawnTo) { paint(k); return; }
  if (k > plan.drawnTo) {
    f = f || frame();
    strokes(f, plan.drawnTo, k, false, "rgba(40, 80, 150, 0.35)", 0.8, [3, 3]);
    strokes(f, plan.drawnTo, k, true, "#1b1b1b", 1.6);
    plan.drawnTo = k;
  }
  const c = field("live");
  c.dataset.drawn = String(k);
  c.dataset.points = String(plan.n);
  field("drawn").textContent = `${(plan.cum[k] / 1000).toFixed(2)} of ` +
    `${(plan.cum[plan.n] / 1000).toFixed(2)} m drawn`;
}

function stateOf(st) {
  if (st.drawing) return st.drawing.state || "drawing";
  if (st.busy) return "busy";
  if (st.resume) return "paused";
  return "idle";
}

function showPrompt(waiting) {
  const box = field("prompt");
  box.hidden = !waiting;
  if (!waiting) return;
  field("prompt-text").textContent = waiting.prompt || "the draw waits";
  field("pen-name").textContent = waiting.pen ? `pen: ${waiting.pen}` : "";
  const sw = field("swatch");
  sw.hidden = !waiting.colour;
  sw.style.background = waiting.colour || "transparent";
  sw.title = waiting.colour || "";
}

// what the plotter is doing, in a person's words (no process ids)
function sentence(st) {
  const d = st.drawing;
  const name = (path) => (path || "").split("/").pop();
  if (d && d.waiting) return `Waiting for you: ${d.waiting.prompt}. Press Continue when done.`;
  if (d) return `Drawing ${name(d.file)}: ${d.percent.toFixed(0)} % done, ` +
    `${clock(d.remaining_s)} left (finishes at ${d.finish}).`;
  if (st.busy) {
    const what = (st.busy.command || "").replace(/^vplotter /, "");
    return what.startsWith("queue") ? "Drawing the queue: getting the next drawing ready."
      : `Busy: ${what || "the plotter is moving"}.`;
  }
  if (st.resume) return `Stopped part-way through ${name(st.resume.file)}` +
    (queueStopped() ? " (the queue's first drawing)" : "") +
    ": Resume goes on from where it stopped.";
  if (!st.calibrated) return "Ready, but the pen's position is unknown: set it under Position.";
  if (st.last_stop === "unclean") return "The last stop was not clean (a crash or power " +
    "cut): check where the pen is and set the position.";
  return jobs.length ? `Ready. ${jobs.length} drawing${jobs.length > 1 ? "s" : ""} in the ` +
    "queue." : "Ready.";
}

function show(st) {
  const before = status;
  status = st;
  const state = stateOf(st);
  const s = field("state");
  s.textContent = state;
  s.className = `state ${state}`;
  field("said").textContent = sentence(st);
  changed(before, st);
  const d = st.drawing;
  const pct = d ? d.percent : 0;
  field("percent").textContent = pct.toFixed(1);
  field("bar").value = pct;
  const waiting = d && d.waiting;
  field("file").textContent = waiting ? `${d.file.split("/").pop()}: ${waiting.prompt}`
    : d ? d.file.split("/").pop()
    : st.resume ? `${st.resume.file.split("/").pop()} stopped at line ${st.resume.line}` : "";
  field("line").textContent = d ? d.line : "–";
  field("elapsed").textContent = d ? clock(d.elapsed_s) : "–";
  field("left").textContent = d ? clock(d.remaining_s) : "–";
  field("finish").textContent = d ? d.finish : "–";
  field("where").textContent = st.calibrated
    ? `pen ${st.pen} at X${st.x_mm.toFixed(1)} Y${st.y_mm.toFixed(1)}`
      + (st.last_stop === "unclean" ? " (last stop unclean: check and set the position)" : "")
    : "position unknown: set it under Position";
  if (st.calibrated) $("#position").classList.remove("need");
  showPrompt(waiting);
  const busy = !!st.busy;
  $$('[data-action="draw"], [data-action="pen-up"], [data-action="pen-down"], ' +
     '[data-action="jog"], [data-action="set-position"], [data-action="home"], ' +
     '[data-action="pen-try"]').forEach((b) => { b.disabled = busy; });
  $('[data-action="stop"]').disabled = !busy;
  $('[data-action="resume"]').disabled = busy || !st.resume;
  $('[data-action="continue"]').disabled = !waiting;
  $('[data-action="queue-run"]').disabled = busy || !jobs.length;
}

// ------------------------------------------------------------------ options
function readOptions(takes) {
  const out = {};
  $$("[data-option]").forEach((el) => {
    const name = el.dataset.option;
    if (takes && !takes.includes(name)) return;
    if (el.type === "checkbox") { if (el.checked) out[name] = true; }
    else if (el.value.trim() !== "") out[name] = el.type === "number" ? Number(el.value) : el.value.trim();
  });
  return out;
}

function fillOptions(f) {
  const opts = f ? f.options : {};
  $$("[data-option]").forEach((el) => {
    const v = opts[el.dataset.option];
    if (el.type === "checkbox") el.checked = !!v;
    else el.value = v === undefined ? "" : v;
  });
  $$("[data-takes]").forEach((el) => { el.hidden = !!f && !f.takes.includes(el.dataset.takes); });
  field("options-for").textContent = f ? `Options for ${f.name}` : "Options for the next upload";
  field("estimate").textContent = f && f.estimate_s !== null
    ? `plot time ${clock(f.estimate_s)}` : "";
  const lines = (ul, texts) => ul.replaceChildren(...texts.map((text) => {
    const li = document.createElement("li");
    li.textContent = text;
    return li;
  }));
  lines(field("advice"), f ? f.advice : []);      // advice for the person: always shown
  lines(field("notes"), f ? f.notes : []);        // what the budget chose: on a tap
  field("notes-box").hidden = !f || !f.notes.length;
  field("notes-count").textContent = f && f.notes.length
    ? `${f.notes.length} note${f.notes.length > 1 ? "s" : ""} on how it is drawn` : "";
}

function select(name) {
  const f = files.find((x) => x.name === name) || null;
  if (selected !== (f && f.name)) {
    const img = field("preview");
    img.hidden = true;
    img.removeAttribute("src");
  }
  selected = f ? f.name : null;
  const panel = field("panel");
  const li = f && $(`li[data-name="${CSS.escape(f.name)}"]`);
  if (li) li.append(panel);
  else $('[data-action="upload"]').closest("label").after(panel);
  $$("li[data-name]").forEach((x) => x.classList.toggle("selected", x.dataset.name === selected));
  fillOptions(f);
}

let asked = 0;            // options asked for: only the answer to the last one shows

async function optionsChanged() {
  if (!selected) return;
  const f = files.find((x) => x.name === selected);
  const name = selected;
  const mine = ++asked;
  field("estimate").textContent = "estimating…";
  pending = (async () => {
    try {
      const r = await call("POST", `/api/files/${encodeURIComponent(name)}/options`,
                           readOptions(f.takes));
      files = files.map((x) => (x.name === name ? r : x));
      renderEstimates();
      if (mine !== asked) return;
      if (selected === name) fillOptions(r);
      say(`${name}: plot time ${clock(r.estimate_s)}`);
    } catch (e) {
      if (mine !== asked) return;
      field("estimate").textContent = "";
      say(e.message);
    }
  })();
  await pending;
}

// ------------------------------------------------------------------ files
function renderEstimates() {
  files.forEach((f) => {
    const est = $(`li[data-name="${CSS.escape(f.name)}"] .est`);
    if (est) est.textContent = f.estimate_s === null ? "" : clock(f.estimate_s);
  });
}

async function refreshFiles(choose) {
  const list = field("files");
  files = await call("GET", "/api/files");
  const panel = field("panel");
  $('[data-action="upload"]').closest("label").after(panel);   // out of the list first
  list.replaceChildren(...files.map((f) => {
    const li = document.createElement("li");
    li.dataset.name = f.name;
    const name = document.createElement("button");
    name.className = "name";
    name.dataset.action = "select";
    name.dataset.file = f.name;
    name.textContent = f.name;
    const est = document.createElement("span");
    est.className = "est";
    const mk = (action, label) => {
      const b = document.createElement("button");
      b.dataset.action = action;
      b.dataset.file = f.name;
      b.textContent = label;
      return b;
    };
    const row = document.createElement("div");
    row.className = "row";
    row.append(mk("draw", "Draw"), mk("preview", "Preview"), mk("delete", "Delete"));
    li.append(name, est, row);
    return li;
  }));
  renderEstimates();
  const qf = field("queue-file");
  const keep = qf.value;
  qf.replaceChildren(...files.map((f) => {
    const o = document.createElement("option");
    o.value = f.name;
    o.textContent = f.name;
    return o;
  }));
  if (files.some((f) => f.name === keep)) qf.value = keep;
  select(choose !== undefined ? choose : selected);
  if (status) show(status);
}

async function preview(file) {
  select(file);
  await pending;
  const img = field("preview");
  const spin = field("spinner");
  img.hidden = true;
  spin.hidden = false;
  try {
    const r = await fetch(`/api/files/${encodeURIComponent(file)}/preview.png?t=${Date.now()}`,
                          { headers: headers() });
    if (!r.ok) {
      let data = null;
      try { data = await r.json(); } catch (e) { data = null; }
      throw new Error((data && data.error) || `no preview: ${r.status}`);
    }
    const url = URL.createObjectURL(await r.blob());
    if (selected !== file) return;
    img.onload = () => URL.revokeObjectURL(url);
    img.src = url;
    img.alt = `preview of ${file}`;
    img.hidden = false;
  } finally {
    spin.hidden = true;
  }
}

// ------------------------------------------------------------------ actions
async function act(button) {
  const a = button.dataset.action;
  const file = button.dataset.file;
  say("");
  try {
    if (a === "select") {
      select(selected === file ? null : file);     // again: back to the next upload's
      return;
    } else if (a === "draw") {
      select(file);
      await pending;
      say(`validating ${file}…`);
      const r = await call("POST", "/api/draw", { file, resume: false });
      say(`drawing ${file}`);
    } else if (a === "resume" && queueStopped()) {      // a queue job: the queue goes on
      await call("POST", "/api/queue/run");
      say("going on with the queue");
    } else if (a === "resume") {
      await call("POST", "/api/draw", { resume: true });
      say("going on with the stopped drawing");
    } else if (a === "continue") {
      const r = await call("POST", "/api/continue");
      say(r.message.replace(/^continuing pid \d+/, "going on"));
    } else if (a === "stop") {
      say("stopping…");
      const r = await call("POST", "/api/stop");
      say(r.message.replace(/^stopped pid \d+ \([^)]*\)/, "stopped"));
    } else if (a === "pen-up" || a === "pen-down") {
      await call("POST", "/api/pen", { state: a === "pen-up" ? "up" : "down" });
    } else if (a === "pen-try" || a === "pen-save") {
      const widths = { up_us: Number(field("up-us").value),
                       down_us: Number(field("down-us").value) };
      say(a === "pen-try" ? "pen down, then up…" : "");
      const r = a === "pen-try" ? await call("POST", "/api/pen", { state: "cycle", ...widths })
        : await call("POST", "/api/pen/save", widths);
      say(a === "pen-try" ? `tried up ${widths.up_us} µs, down ${widths.down_us} µs`
        : r.message);
    } else if (a === "set-position") {
      const r = await call("POST", "/api/position", { x: Number(field("at-x").value),
                                                      y: Number(field("at-y").value) });
      $("#position").classList.remove("need");
      say(r.message);
    } else if (a === "home") {
      say("going home…");
      const r = await call("POST", "/api/home");
      say(r.message);
    } else if (a === "jog") {
      const step = Number(field("step").value);
      await call("POST", "/api/jog", { dx: step * Number(button.dataset.dx),
                                        dy: step * Number(button.dataset.dy) });
    } else if (a === "delete") {
      await call("DELETE", `/api/files/${encodeURIComponent(file)}`);
      await refreshFiles(selected === file ? null : selected);
    } else if (a === "preview") {
      await preview(file);
    } else if (a.startsWith("queue-")) {
      await queueAct(a, button);
    }
  } catch (e) {
    explain(e);
  }
  poll();
}

async function upload(input) {
  const f = input.files[0];
  if (!f) return;
  if (f.size > 50 * 1024 * 1024) { say(`${f.name}: larger than 50 MB`); input.value = ""; return; }
  const form = new FormData();
  form.append("file", f);
  form.append("options", JSON.stringify(readOptions(null)));   // the kind's are kept
  say(`uploading ${f.name}…`);
  try {
    const r = await call("POST", "/api/files", form);
    await refreshFiles(r.name);
    say(`${r.name}: plot time ${clock(r.estimate_s)}`);
  } catch (e) {
    say(e.message);
  }
  input.value = "";
}

async function loadSetup() {
  setup = await call("GET", "/api/setup");
  for (const [name, values] of Object.entries(setup.choices || {})) {
    const sel = $(`select[data-option="${name}"]`);
    if (!sel) continue;
    sel.append(...values.map((v) => {
      const o = document.createElement("option");
      o.value = v;
      o.textContent = v;
      return o;
    }));
  }
  const servo = setup.pen.kind === "servo";
  field("tune").hidden = !servo;
  if (servo) {
    field("up-us").value = setup.pen.up_us;
    field("down-us").value = setup.pen.down_us;
  }
}

async function poll() {
  try { show(await call("GET", "/api/status")); } catch (e) { say(e.message); }
}

function listen() {
  const es = new EventSource("/api/events");
  es.onmessage = (ev) => show(JSON.parse(ev.data));
  es.onerror = () => { es.close(); setTimeout(listen, 3000); };
}

document.addEventListener("click", (ev) => {
  const b = ev.target.closest("button[data-action]");
  if (b && !b.disabled) act(b);
});
$('[data-action="upload"]').addEventListener("change", (ev) => upload(ev.target));
$$("[data-option]").forEach((el) => el.addEventListener("change", optionsChanged));
poll();
loadSetup().then(() => refreshFiles()).catch((e) => say(e.message));
refreshQueue();
listen();
window.addEventListener("resize", () => { if (plan) paint(plan.drawnTo); });
