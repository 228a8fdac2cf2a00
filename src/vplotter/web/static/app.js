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

function show(st) {
  status = st;
  const state = stateOf(st);
  const s = field("state");
  s.textContent = state;
  s.className = `state ${state}`;
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
      say(`drawing ${file} (pid ${r.pid})`);
    } else if (a === "resume") {
      const r = await call("POST", "/api/draw", { resume: true });
      say(`resumed (pid ${r.pid})`);
    } else if (a === "continue") {
      const r = await call("POST", "/api/continue");
      say(r.message);
    } else if (a === "stop") {
      say("stopping…");
      const r = await call("POST", "/api/stop");
      say(r.message);
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
listen();
