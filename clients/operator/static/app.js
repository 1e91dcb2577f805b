// The operator page: one WebSocket brings the rig's state (JSON) and live frames
// (binary: 4-byte header length, JSON header, JPEG). Each frame is acknowledged once
// drawn, so the server never sends faster than this page can show: latest wins.
"use strict";

const $ = (id) => document.getElementById(id);
const latencies = [];           // daemon publish -> drawn on this page, ms
let frames = 0;
let shown = null;               // header of the frame on the canvas (its pose, for clicks)
let state = null;
let station = "";               // the station whose mosaic is shown
let socket = null;

window.cyborgStats = () => {
  const sorted = [...latencies].sort((a, b) => a - b);
  const q = (p) => sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))] : null;
  return { frames, samples: sorted.length, p50: q(0.5), p99: q(0.99), last: shown };
};
window.cyborgState = () => state && state.result;
window.cyborgResetStats = () => { latencies.length = 0; frames = 0; };

function connect() {
  socket = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  socket.binaryType = "arraybuffer";
  socket.onmessage = (ev) => (typeof ev.data === "string" ? onState(JSON.parse(ev.data)) : onFrame(ev.data));
  socket.onclose = async () => {
    // A console restarted with a new secret refuses the old cookie: say so plainly.
    const page = await fetch("/", { method: "HEAD" }).catch(() => null);
    $("alive").textContent = page && page.status === 401 ? "signed out: open the URL the operator printed" : "console lost its server";
    $("alive").className = "down";
    setTimeout(connect, 1000);
  };
}

async function onFrame(buffer) {
  const n = new DataView(buffer).getUint32(0);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, n)));
  try {
    const bitmap = await createImageBitmap(new Blob([new Uint8Array(buffer, 4 + n)], { type: "image/jpeg" }));
    const canvas = $("live");
    if (canvas.width !== bitmap.width) { canvas.width = bitmap.width; canvas.height = bitmap.height; }
    canvas.getContext("2d").drawImage(bitmap, 0, 0);
    bitmap.close();
    shown = header;
    frames += 1;
    latencies.push(Date.now() - header.ts_ms);
    if (latencies.length > 5000) latencies.splice(0, latencies.length - 5000);
    if (frames % 10 === 0) {
      const s = window.cyborgStats();
      $("stats").textContent = `frame ${header.seq}: latency p50 ${s.p50.toFixed(1)} ms, p99 ${s.p99.toFixed(1)} ms`;
    }
  } finally {
    socket.send(JSON.stringify({ type: "ack", seq: header.seq }));
  }
}

// 24-hour HH:MM:SS, as the keypad shows it, whatever the browser's locale.
const clock = (seconds) => {
  const t = new Date(seconds * 1000);
  return [t.getHours(), t.getMinutes(), t.getSeconds()].map((n) => String(n).padStart(2, "0")).join(":");
};
const fmt = (x, d = 2) => (x === null || x === undefined ? "?" : (x >= 0 ? "+" : "") + x.toFixed(d));

function onState(s) {
  state = s;
  $("rig").textContent = `rig ${s.rig}`;
  $("alive").textContent = s.alive ? "● up" : s.alive === false ? "○ DOWN" : "○ not seen yet";
  $("alive").className = s.alive ? "up" : "down";
  const holder = s.ptu ? s.ptu.controller : s.status ? s.status.controller : "";
  $("control").textContent = `control: ${holder === s.me ? "you" : holder || "nobody"}`;
  $("pose").textContent = s.ptu ? `PTU pan ${fmt(s.ptu.pan)}° tilt ${fmt(s.ptu.tilt)}° ${s.ptu.moving ? "moving" : "still"}` : "PTU ?";
  $("state").textContent = s.status ? `${s.status.state} ${s.status.station || ""} ${s.status.station ? s.status.distance_m + " m" : ""}` : "state ?";
  // Left at "rig's", the next station takes the aim the rig names (protocol 2.5).
  $("aim").options[0].textContent = s.status && s.status.aim ? `aim: rig's (${s.status.aim})` : "aim: rig's";
  showProgress(s.progress, s.result);
  showResult(s.result, s.chips);
  $("log").replaceChildren(...s.log.map((e) => {
    const li = document.createElement("li");
    li.className = e.level;
    li.textContent = `${clock(e.at)} ${e.text}`;
    return li;
  }));
  $("log").scrollTop = $("log").scrollHeight;
}

function showProgress(p, r) {
  if (!p) {  // opened while a station's points wait, or before any survey
    $("progresstext").textContent = r ? `points of ${r.station} await a choice` : "no survey yet";
    return;
  }
  const part = p.total ? p.done / p.total : 0;
  const fraction = { tiles: 0.6 * part, analysis: 0.6, chips: 0.8 + 0.2 * part, done: 1 }[p.stage] ?? 0;
  $("progress").value = fraction;
  const count = p.total && (p.stage === "tiles" || p.stage === "chips") ? ` ${p.done}/${p.total}` : "";
  const eta = p.eta !== null && p.eta !== undefined ? `, ETA ${p.eta.toFixed(0)} s` : "";
  $("progresstext").textContent = `${p.station}: ${p.stage}${count}${eta}`;
}

function showResult(r, chips) {
  if (!r) {  // nothing awaits a choice (chosen, or the rig restarted): no stale points
    $("station").textContent = "Interest points";
    $("points").tBodies[0].replaceChildren();
    $("chips").replaceChildren();
    return;
  }
  const [session, name] = r.station.split("/");
  $("station").textContent = `Interest points of ${r.station}` + (r.aim ? ` (aim ${r.aim})` : "");
  $("points").tBodies[0].replaceChildren(...r.points.map((p) => {
    const tr = document.createElement("tr");
    tr.innerHTML = `<td>${p.rank}</td><td>${p.score.toFixed(2)}</td><td>${fmt(p.pan)}</td><td>${fmt(p.tilt)}</td><td class="why"></td>`;
    tr.querySelector(".why").textContent = p.why;
    const td = document.createElement("td");
    // A point not told from the view's background (protocol 2.4) cannot be chosen.
    if (p.target === false) {
      tr.className = "notarget";
      td.append("no further target ");
    } else {
      td.append(button(`Choose ${p.rank}`, () => send("target/choose", { station: r.station, rank: p.rank })));
    }
    td.append(button("Look", () => send("ptu/goto", { pan: p.pan, tilt: p.tilt })));
    tr.append(td);
    return tr;
  }));
  $("chips").replaceChildren(...chips.filter((c) => c.station === r.station).map((c) => {
    const img = document.createElement("img");
    img.src = `/archive/${session}/${name}/${c.product}`;
    img.title = `chip #${c.rank} at pan ${fmt(c.pan)}, tilt ${fmt(c.tilt)}`;
    return img;
  }));
  if (station !== r.station) { station = r.station; showLayer(); }
}

function showLayer() {
  if (!station) return;
  const [session, name] = station.split("/");
  $("mosaic").src = `/archive/${session}/${name}/${$("layer").value}`;
}

function button(text, onclick) {
  const b = document.createElement("button");
  b.textContent = text;
  b.onclick = onclick;
  return b;
}

async function send(command, body = {}) {
  const reply = await fetch(`/api/${command}`, { method: "POST", body: JSON.stringify(body), headers: { "content-type": "application/json" } })
    .then((r) => r.json()).catch((e) => ({ ok: false, detail: `console unreachable: ${e}` }));
  $("reply").textContent = `${command}: ${reply.ok ? "" : reply.result + ": "}${reply.detail || reply.error || ""}`;
  $("reply").className = reply.ok ? "ok" : "refused";
  return reply;
}

// The aims of study come from the protocol (GET /api/aims): a kind sought first, and kinds
// set aside, each explained where the operator points at it.
async function listAims() {
  const aims = await fetch("/api/aims").then((r) => r.json()).catch(() => ({ kinds: {}, exclusions: {} }));
  $("aim").append(...Object.entries(aims.kinds).map(([name, meaning]) => {
    const o = document.createElement("option");
    o.value = name;
    o.textContent = `aim: ${name}`;
    o.title = meaning;
    return o;
  }));
  $("aside").replaceChildren(...Object.entries(aims.exclusions).map(([name, meaning]) => {
    const label = document.createElement("label");
    label.title = meaning;
    const box = document.createElement("input");
    box.type = "checkbox";
    box.value = name;
    label.append(box, ` ${name}`);
    return label;
  }));
}

// The aim sent with a survey start: none chosen leaves it to the rig; the rig checks it.
function chosenAim() {
  const aside = [...document.querySelectorAll("#aside input:checked")].map((b) => b.value);
  if (!$("aim").value && !aside.length) return null;
  return [$("aim").value || "any", ...aside].join("+");
}

// The commands the console takes come from the protocol's registry (GET /api/commands:
// {verb: {moves, read_only}}); a button whose command moves the head says it needs control.
async function describeCommands() {
  const commands = await fetch("/api/commands").then((r) => r.json()).catch(() => ({}));
  for (const b of document.querySelectorAll("button[data-verb]")) {
    if (commands[b.dataset.verb] && commands[b.dataset.verb].moves) b.title = b.title ? `${b.title} (needs control)` : "needs control";
  }
}

function fraction(ev, el) {
  const rect = el.getBoundingClientRect();
  return { u: Math.min(1, Math.max(0, (ev.clientX - rect.left) / rect.width)),
           v: Math.min(1, Math.max(0, (ev.clientY - rect.top) / rect.height)) };
}

async function browse(session) {
  const listing = await fetch(session ? `/api/archive/${session}` : "/api/archive").then((r) => r.json());
  const target = session ? $("products") : $("sessions");
  // The session's report first: the page a geologist reads; the raw products after it.
  const items = [...(listing.items || [])].sort((a, b) => (b === "report.html") - (a === "report.html"));
  target.replaceChildren(...items.map((item) => {
    const li = document.createElement("li");
    const a = document.createElement("a");
    a.textContent = item;
    if (session) { a.href = `/archive/${session}/${item}`; a.target = "_blank"; }
    else { a.href = "#"; a.onclick = (e) => { e.preventDefault(); browse(item); }; }
    li.append(a);
    return li;
  }));
}

window.addEventListener("DOMContentLoaded", () => {
  // A plain button sends the command its data-verb names; the registry says which need control.
  for (const b of document.querySelectorAll("button[data-verb]")) b.onclick = () => send(b.dataset.verb);
  describeCommands();
  listAims();
  // A station's own settings (protocol 2.2), NAME=VALUE separated by spaces; none typed: the
  // rig's configured ones. The rig checks them, and says why it refuses.
  $("survey").onclick = () => {
    const settings = $("settings").value.split(/\s+/).filter(Boolean);
    const aim = chosenAim();
    send("survey/start", { ...(settings.length ? { settings } : {}), ...(aim ? { aim } : {}) });
  };
  $("choose0").onclick = () => state && state.result && send("target/choose", { station: state.result.station, rank: 0 });
  $("layer").onchange = showLayer;
  $("view").onchange = () => send("view", $("view").value ? JSON.parse($("view").value) : {});
  $("refresh").onclick = () => browse("");
  $("live").addEventListener("click", (ev) => {
    window.cyborgClickAt = Date.now();
    if (shown) send("ptu/look", { ...fraction(ev, $("live")), pan: shown.pan, tilt: shown.tilt });
  });
  $("mosaic").addEventListener("click", (ev) => {
    window.cyborgClickAt = Date.now();
    if (station) send("ptu/look", { ...fraction(ev, $("mosaic")), station });
  });
  connect();
  browse("");
});
