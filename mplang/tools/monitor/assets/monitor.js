// mpc monitor: the page's half. State arrives over the WebSocket /ws (one message per poll
// of the device); writes go to the POST endpoints, which the server refuses (403) unless
// it was started with --allow-write. Nothing here loads from the network.
"use strict";

const LAMPS = [["limit_plus", true], ["limit_minus", true], ["near_home", false],
  ["home", false], ["index", false], ["alarm", true], ["emg", true], ["inpos", false]];
const PATH_LIMIT = 100000;  // points kept, as the server keeps (a long watch stays bounded)
const path = [];  // [x, y, z] logic positions
let pathEnd = 0;  // the absolute index after the last point received
let drawPending = false;
let names = "";  // the variable names the table was built for

function $(id) { return document.getElementById(id); }

function lamp(on, alert, title) {
  const span = document.createElement("span");
  span.className = "lamp" + (on ? " on" : "") + (alert ? " alert" : "");
  span.title = title;
  span.dataset.on = on ? "1" : "0";
  return span;
}

function text(id, value) { $(id).textContent = value; }

function showState(s) {
  document.body.dataset.connected = String(Boolean(s.connected));
  document.body.dataset.seq = String(s.seq);
  document.body.dataset.write = String(Boolean(s.write));
  for (const el of document.querySelectorAll(".write-only")) el.hidden = !s.write;
  text("title", s.title || "");
  text("connection", s.connected ? "connected" : "not connected");
  const banner = $("error");
  banner.hidden = !s.error;
  banner.textContent = s.error || "";
  if (s.device) text("device", s.device);
  if (!s.axes) return;  // never read yet
  const run = s.running;
  text("program", run.program || "nothing");
  text("source", run.source || (run.program ? "(sources not given)" : "-"));
  text("state", `${s.state.name} (input 100 = ${s.state.value})`);
  const e = s.execution_error;
  text("exec-error", e.error ? `0x${e.error.toString(16).padStart(2, "0")} ${e.text}` +
    ` in ${e.isr ? "ISR" + e.isr : "MP" + e.mp} line ${e.line}` +
    (e.source ? ` (${e.source})` : "") : "none");
  $("exec-error").className = e.error ? "error-text" : "";
  text("emergency", s.emergency ? "EMERGENCY STOP" : "off");
  showAxes(s.axes);
  showFrnet(s.frnet_di);
  showVars(s.variables || []);
  const list = $("programs");
  if (list.childElementCount === 0 && s.programs) {
    for (const p of s.programs.filter((x) => x.slot.startsWith("MP"))) {
      const option = document.createElement("option");
      option.value = p.name || p.slot;
      option.label = `${p.slot} ${p.source}`;
      list.append(option);
    }
  }
}

function showAxes(axes) {
  const body = $("axes").tBodies[0];
  body.replaceChildren(...axes.map((a) => {
    const row = document.createElement("tr");
    row.dataset.axis = a.axis;
    for (const [value, cls] of [[a.axis, ""], [a.lp, "num lp"], [a.ep, "num ep"],
      [a.cv, "num cv"], [a.state, "state"]]) {
      const cell = document.createElement("td");
      cell.className = cls;
      cell.textContent = String(value);
      row.append(cell);
    }
    for (const [name, alert] of LAMPS) {
      const cell = document.createElement("td");
      cell.append(lamp(Boolean(a.lamps[name]), alert, `${a.axis} ${name}`));
      row.append(cell);
    }
    return row;
  }));
}

function showFrnet(groups) {
  const box = $("frnet");
  box.replaceChildren(...groups.map((word, g) => {
    const line = document.createElement("div");
    line.className = "group";
    line.append(`DI${g + 8} `);
    for (let bit = 0; bit < 16; bit++) line.append(lamp(Boolean((word >> bit) & 1), false,
      `group ${g + 8} bit ${bit}`));
    return line;
  }));
}

function showVars(vars) {
  $("no-vars").hidden = vars.length > 0;
  const body = $("vars").tBodies[0];
  const key = vars.map((v) => v.name).join(",");
  if (key !== names) {
    names = key;
    body.replaceChildren(...vars.map((v) => {
      const row = document.createElement("tr");
      row.dataset.name = v.name;
      row.innerHTML = "<td></td><td></td><td class='num value'></td>" +
        "<td class='write-only'><input size='8'><button type='button'>set</button></td>";
      row.cells[0].textContent = v.name;
      row.cells[1].textContent = "VAR" + v.var;
      row.querySelector("button").addEventListener("click", () => {
        write("var", { name: v.name, value: row.querySelector("input").value });
      });
      return row;
    }));
  }
  for (const row of body.rows) {
    const v = vars.find((x) => x.name === row.dataset.name);
    if (v) row.querySelector(".value").textContent = String(v.value);
    row.querySelector(".write-only").hidden = document.body.dataset.write !== "true";
  }
}

function addPoints(from, points) {
  if (from > pathEnd) { path.length = 0; }  // the server dropped points we never had
  for (const p of points) path.push(p);
  if (path.length > PATH_LIMIT) path.splice(0, path.length - PATH_LIMIT / 2);  // as the server
  pathEnd = from + points.length;
  if (!drawPending) { drawPending = true; requestAnimationFrame(draw); }
}

function bounds(values) {
  let lo = Math.min(...values), hi = Math.max(...values);
  if (lo === hi) { lo -= 1; hi += 1; }
  return [lo, hi];
}

function draw() {
  drawPending = false;
  for (const id of ["xy", "z"]) $(id).dataset.points = String(path.length);
  const xy = $("xy"), ctx = xy.getContext("2d");
  ctx.clearRect(0, 0, xy.width, xy.height);
  const z = $("z"), zc = z.getContext("2d");
  zc.clearRect(0, 0, z.width, z.height);
  if (path.length === 0) return;
  const [x0, x1] = bounds(path.map((p) => p[0]));
  const [y0, y1] = bounds(path.map((p) => p[1]));
  const span = Math.max(x1 - x0, y1 - y0), pad = 16, size = xy.width - 2 * pad;
  const sx = (x) => pad + (x - x0) / span * size;
  const sy = (y) => xy.height - pad - (y - y0) / span * size;
  ctx.strokeStyle = "#1f6feb";
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  path.forEach((p, i) => (i ? ctx.lineTo(sx(p[0]), sy(p[1])) : ctx.moveTo(sx(p[0]), sy(p[1]))));
  ctx.stroke();
  const last = path[path.length - 1];
  ctx.fillStyle = "#c0392b";
  ctx.beginPath();
  ctx.arc(sx(last[0]), sy(last[1]), 4, 0, 2 * Math.PI);
  ctx.fill();
  const [z0, z1] = bounds(path.map((p) => p[2]));
  const zx = (i) => pad + i / Math.max(1, path.length - 1) * (z.width - 2 * pad);
  const zy = (v) => z.height - pad - (v - z0) / (z1 - z0) * (z.height - 2 * pad);
  zc.strokeStyle = "#8e44ad";
  zc.beginPath();
  path.forEach((p, i) => (i ? zc.lineTo(zx(i), zy(p[2])) : zc.moveTo(zx(i), zy(p[2]))));
  zc.stroke();
}

async function write(endpoint, body) {
  const out = $("write-result");
  try {
    const answer = await fetch("/api/" + endpoint, {
      method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify(body || {}),
    });
    const data = await answer.json();
    out.textContent = answer.ok ? data.done : `refused (${answer.status}): ${data.error}`;
    out.className = answer.ok ? "" : "error-text";
  } catch (err) {
    out.textContent = `not sent: ${err}`;
    out.className = "error-text";
  }
}

function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  ws.onmessage = (event) => {
    const message = JSON.parse(event.data);
    addPoints(message.path_from, message.path);
    showState(message.state);
  };
  ws.onclose = () => {
    document.body.dataset.connected = "false";
    text("connection", "monitor stopped");
    const banner = $("error");
    banner.hidden = false;
    banner.textContent = "the monitor does not answer (mpc monitor stopped?); reconnecting";
    setTimeout(connect, 1000);
  };
}

$("call-form").addEventListener("submit", (event) => {
  event.preventDefault();
  write("call", { program: $("call-program").value });
});
$("stop").addEventListener("click", () => write("stop"));
$("estop").addEventListener("click", () => write("emergency-stop"));
$("clear-estop").addEventListener("click", () => write("clear-emergency"));
$("clear-path").addEventListener("click", () => { path.length = 0; draw(); });
connect();
