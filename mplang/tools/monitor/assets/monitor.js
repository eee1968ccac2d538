// mpc monitor: the page's half. State arrives over the WebSocket /ws (one message per poll
// of the device); writes go to the POST endpoints with the session's token (which the
// server put in the page's <meta name="mpc-token">) in X-MPC-Token; the server refuses
// them (403) unless it was started with --allow-write. Nothing here loads from the network.
"use strict";

const LAMPS = [["limit_plus", true], ["limit_minus", true], ["near_home", false],
  ["home", false], ["index", false], ["alarm", true], ["emg", true], ["inpos", false]];
const PATH_LIMIT = 100000;  // points kept, as the server keeps (a long watch stays bounded)
const path = [];  // [x, y, z] logic positions
let pathEnd = 0;  // the absolute index after the last point received
let drawPending = false;
let names = "";  // the variable names the table was built for
const TOKEN = document.querySelector("meta[name=mpc-token]").content;

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
  text("run-state", runState(s));
  text("state", `(device state ${s.state.name}, input 100 = ${s.state.value})`);
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

// What the controller is doing, in words: the program that runs (holding 8; input 24 when
// what runs now is another, an ISR above it), a download, an emergency stop, or nothing.
function runState(s) {
  const run = s.running;
  if (s.emergency) return "emergency stop: nothing may run";
  if (s.state.name !== "ready") return `${s.state.name} in progress`;
  if (run.mp || run.top) {
    const what = run.program || (run.mp ? `MP${run.mp}` : `ISR${run.top}`);
    const now = run.mp && run.top && run.top !== run.mp ? ` (now at ${run.top})` : "";
    return `running ${what}${now}`;
  }
  return "idle: no program runs";
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
    const label = document.createElement("span");
    label.className = "label";
    label.textContent = `DI${g + 8}`;
    line.append(label);
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

// A "nice" tick step (1, 2 or 5 times a power of ten, at least 1 pulse) for about `count`
// ticks over `span` pulses.
function tickStep(span, count) {
  const raw = Math.max(1, span / count);
  const power = Math.pow(10, Math.floor(Math.log10(raw)));
  for (const m of [1, 2, 5, 10]) if (m * power >= raw) return m * power;
  return 10 * power;
}

function range(values, empty) {
  if (values.length === 0) return empty;
  let lo = values[0], hi = values[0];
  for (const v of values) { if (v < lo) lo = v; if (v > hi) hi = v; }
  return [lo, hi];
}

// Ticks from `lo` by `step`, `n` steps: the values, and the scale they span.
function ticks(lo, step, n) {
  return Array.from({ length: n + 1 }, (_, i) => lo + i * step);
}

const PLOT = { left: 64, right: 14, top: 12, bottom: 40 };  // room for tick labels and titles
const MIN_SPAN = 100;  // pulses: a path standing still is a point on a readable scale

// Axes with ticks, grid and titles on `canvas` for the data ranges `xs`/`ys` (ticks in data
// units); maps data to pixels. The ticks and titles are also the canvas's data-* attributes.
function axes(canvas, xs, ys, xTitle, yTitle) {
  const ctx = canvas.getContext("2d");
  const w = canvas.width - PLOT.left - PLOT.right, h = canvas.height - PLOT.top - PLOT.bottom;
  const [x0, x1] = [xs[0], xs[xs.length - 1]], [y0, y1] = [ys[0], ys[ys.length - 1]];
  const px = (x) => PLOT.left + (x - x0) / (x1 - x0) * w;
  const py = (y) => PLOT.top + h - (y - y0) / (y1 - y0) * h;
  ctx.font = "11px system-ui, sans-serif";
  ctx.lineWidth = 1;
  ctx.strokeStyle = "#e3e6ea";
  ctx.fillStyle = "#444";
  ctx.textAlign = "center";
  ctx.textBaseline = "top";
  xs.forEach((x, i) => {
    ctx.beginPath(); ctx.moveTo(px(x), PLOT.top); ctx.lineTo(px(x), PLOT.top + h); ctx.stroke();
    if (i % Math.ceil(xs.length / 6) === 0 || i === xs.length - 1) {
      ctx.fillText(String(x), px(x), PLOT.top + h + 4);
    }
  });
  ctx.textAlign = "right";
  ctx.textBaseline = "middle";
  ys.forEach((y) => {
    ctx.beginPath(); ctx.moveTo(PLOT.left, py(y)); ctx.lineTo(PLOT.left + w, py(y)); ctx.stroke();
    ctx.fillText(String(y), PLOT.left - 4, py(y));
  });
  ctx.strokeStyle = "#667";
  ctx.strokeRect(PLOT.left, PLOT.top, w, h);
  ctx.textAlign = "center";
  ctx.textBaseline = "bottom";
  ctx.fillText(xTitle, PLOT.left + w / 2, canvas.height - 2);
  ctx.save();
  ctx.translate(12, PLOT.top + h / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textBaseline = "middle";
  ctx.fillText(yTitle, 0, 0);
  ctx.restore();
  Object.assign(canvas.dataset, { xTitle, yTitle, xTicks: xs.join(","), yTicks: ys.join(",") });
  return [px, py];
}

function line(ctx, points, color) {
  ctx.strokeStyle = color;
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  points.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
  ctx.stroke();
}

// X-Y at one scale for both axes (a square stays square), in pulses; the last point red.
function drawXY() {
  const xy = $("xy"), ctx = xy.getContext("2d");
  ctx.clearRect(0, 0, xy.width, xy.height);
  const [x0, x1] = range(path.map((p) => p[0]), [0, 1000]);
  const [y0, y1] = range(path.map((p) => p[1]), [0, 1000]);
  const step = tickStep(Math.max(MIN_SPAN, x1 - x0, y1 - y0), 5);
  const xlo = Math.floor(x0 / step) * step, ylo = Math.floor(y0 / step) * step;
  const n = Math.max(5, Math.ceil((x1 - xlo) / step), Math.ceil((y1 - ylo) / step));
  const [px, py] = axes(xy, ticks(xlo, step, n), ticks(ylo, step, n), "X (pulses)",
    "Y (pulses)");
  if (path.length === 0) return;
  line(ctx, path.map((p) => [px(p[0]), py(p[1])]), "#1f6feb");
  const last = path[path.length - 1];
  ctx.fillStyle = "#c0392b";
  ctx.beginPath();
  ctx.arc(px(last[0]), py(last[1]), 4, 0, 2 * Math.PI);
  ctx.fill();
}

// Z (pulses) against the path point's number, counted from the first point drawn.
function drawZ() {
  const z = $("z"), ctx = z.getContext("2d");
  ctx.clearRect(0, 0, z.width, z.height);
  const [z0, z1] = range(path.map((p) => p[2]), [0, 1000]);
  const zStep = tickStep(Math.max(MIN_SPAN, z1 - z0), 4), zlo = Math.floor(z0 / zStep) * zStep;
  const iStep = tickStep(Math.max(1, path.length - 1), 5);
  const [px, py] = axes(z, ticks(0, iStep, Math.max(1, Math.ceil((path.length - 1) / iStep))),
    ticks(zlo, zStep, Math.max(4, Math.ceil((z1 - zlo) / zStep))), "path point",
    "Z (pulses)");
  line(ctx, path.map((p, i) => [px(i), py(p[2])]), "#8e44ad");
}

function draw() {
  drawPending = false;
  for (const id of ["xy", "z"]) $(id).dataset.points = String(path.length);
  drawXY();
  drawZ();
}

async function write(endpoint, body) {
  const out = $("write-result");
  try {
    const answer = await fetch("/api/" + endpoint, {
      method: "POST", headers: { "Content-Type": "application/json", "X-MPC-Token": TOKEN },
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
draw();  // the empty axes, until the first points arrive
connect();
