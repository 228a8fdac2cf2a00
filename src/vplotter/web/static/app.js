// The page: everything through the JSON API (/api), live status from /api/events.
"use strict";

const $ = (sel, root = document) => root.querySelector(sel);
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
  if (!r.ok) throw new Error((data && data.error) || `${r.status} ${r.statusText}`);
  return data;
}

function say(text) { field("message").textContent = text || ""; }

function clock(s) {
  if (s === null || s === undefined) return "–";
  s = Math.round(s);
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
  const two = (v) => String(v).padStart(2, "0");
  return h ? `${h}:${two(m)}:${two(sec)}` : `${m}:${two(sec)}`;
}

let status = null;

function stateOf(st) {
  if (st.drawing) return st.drawing.state || "drawing";
  if (st.busy) return "busy";
  if (st.resume) return "paused";
  return "idle";
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
      + (st.last_stop === "unclean" ? " (last stop unclean: check and calibrate)" : "")
    : "position unknown: run vplotter calibrate --at X Y";
  const busy = !!st.busy;
  document.querySelectorAll('[data-action="draw"], [data-action="pen-up"], [data-action="pen-down"], [data-action="jog"]')
    .forEach((b) => { b.disabled = busy; });
  $('[data-action="stop"]').disabled = !busy;
  $('[data-action="resume"]').disabled = busy || !st.resume;
  $('[data-action="continue"]').disabled = !waiting;
}

async function refreshFiles() {
  const list = field("files");
  const files = await call("GET", "/api/files");
  list.replaceChildren(...files.map((f) => {
    const li = document.createElement("li");
    const name = document.createElement("span");
    name.className = "name";
    name.textContent = f.name;
    const est = document.createElement("span");
    est.className = "est";
    est.textContent = f.estimate_s === null ? "" : clock(f.estimate_s);
    const mk = (action, label) => {
      const b = document.createElement("button");
      b.dataset.action = action;
      b.dataset.file = f.name;
      b.textContent = label;
      return b;
    };
    li.append(name, est, mk("draw", "Draw"), mk("preview", "Preview"), mk("delete", "Delete"));
    return li;
  }));
  if (status) show(status);
}

async function act(button) {
  const a = button.dataset.action;
  const file = button.dataset.file;
  say("");
  try {
    if (a === "draw") {
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
    } else if (a === "jog") {
      const step = Number(field("step").value);
      await call("POST", "/api/jog", { dx: step * Number(button.dataset.dx),
                                        dy: step * Number(button.dataset.dy) });
    } else if (a === "delete") {
      await call("DELETE", `/api/files/${encodeURIComponent(file)}`);
      await refreshFiles();
    } else if (a === "preview") {
      const img = field("preview");
      img.hidden = false;
      img.alt = `preview of ${file}`;
      img.src = `/api/files/${encodeURIComponent(file)}/preview.png?t=${Date.now()}`;
    }
  } catch (e) {
    say(e.message);
  }
  poll();
}

async function upload(input) {
  const f = input.files[0];
  if (!f) return;
  if (f.size > 50 * 1024 * 1024) { say(`${f.name}: larger than 50 MB`); input.value = ""; return; }
  const form = new FormData();
  form.append("file", f);
  say(`uploading ${f.name}…`);
  try {
    const r = await call("POST", "/api/files", form);
    say(`${r.name}: plot time ${clock(r.estimate_s)}`);
    await refreshFiles();
  } catch (e) {
    say(e.message);
  }
  input.value = "";
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
field("preview").addEventListener("error", () => say("no preview for this file"));
poll();
refreshFiles().catch((e) => say(e.message));
listen();
