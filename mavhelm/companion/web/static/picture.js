// The operator's picture: draws the frames mavhelm's web view pushes over /ws on a plain SVG
// map (metres east/north of the mission origin; no tiles, so it works with no internet).
"use strict";
const NS = "http://www.w3.org/2000/svg";
const COLOURS = { nav: "#ffffff", gps: "#5f5", autopilot: "#fa3", truth: "#f4f", ekf: "#7af" };
const $ = (id) => document.getElementById(id);
let mission = { shapes: [], beacons: [], remote_flags: [] };
let track = [];
let last = null;
let view = { cx: 0, cy: 0, scale: 2 };   // pixels per metre
let follow = true;
window.mavhelmFrames = 0;   // frames drawn (tests read it)

function el(tag, attrs, parent) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
}
function clear(node) { while (node.firstChild) node.removeChild(node.firstChild); }
function text(id, value) { $(id).textContent = value; }
function sx(x) { return x; }
function sy(y) { return -y; }   // north up

function extent() {
  const pts = [];
  for (const s of mission.shapes) {
    if (s.points) pts.push(...s.points);
    if (s.p) { pts.push([s.p[0] - s.r, s.p[1] - s.r], [s.p[0] + s.r, s.p[1] + s.r]); }
    if (s.min) pts.push(s.min, s.max);
  }
  for (const b of mission.beacons) pts.push(b.p);
  for (const p of track) pts.push(p);
  if (last) for (const p of Object.values(last.poses)) pts.push([p.x, p.y]);
  if (!pts.length) pts.push([0, 0]);
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  return [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)];
}

function fit() {
  const svg = $("map"), w = svg.clientWidth || 800, h = svg.clientHeight || 600;
  const [x0, y0, x1, y1] = extent();
  const span = Math.max(x1 - x0, y1 - y0, 20) * 1.15;
  view.scale = Math.min(w, h) / span;
  view.cx = (x0 + x1) / 2; view.cy = (y0 + y1) / 2;
  place();
}

function place() {
  const svg = $("map"), w = svg.clientWidth || 800, h = svg.clientHeight || 600;
  $("view").setAttribute("transform",
    `translate(${w / 2},${h / 2}) scale(${view.scale}) translate(${-view.cx},${view.cy})`);
  drawGrid(w, h);
}

function niceStep(metres) {
  const p = Math.pow(10, Math.floor(Math.log10(metres)));
  for (const m of [1, 2, 5, 10]) if (m * p >= metres) return m * p;
  return 10 * p;
}

function drawGrid(w, h) {
  const g = $("grid"); clear(g);
  const step = niceStep(80 / view.scale);
  const halfW = w / 2 / view.scale, halfH = h / 2 / view.scale;
  const xa = Math.floor((view.cx - halfW) / step) * step, xb = view.cx + halfW;
  const ya = Math.floor((view.cy - halfH) / step) * step, yb = view.cy + halfH;
  const stroke = 1 / view.scale;
  for (let x = xa; x <= xb; x += step) {
    el("line", { x1: sx(x), x2: sx(x), y1: sy(ya), y2: sy(yb), "stroke-width": stroke,
      class: Math.abs(x) < step / 2 ? "axis" : "" }, g);
  }
  for (let y = ya; y <= yb; y += step) {
    el("line", { x1: sx(xa), x2: sx(xb), y1: sy(y), y2: sy(y), "stroke-width": stroke,
      class: Math.abs(y) < step / 2 ? "axis" : "" }, g);
  }
  const s = $("scale"); clear(s);
  const px = step * view.scale;
  el("rect", { x: 14, y: h - 30, width: px, height: 5, fill: "#7a9db3" }, s);
  el("text", { x: 14, y: h - 36 }, s).textContent = `${step} m (grid)`;
  el("text", { x: w - 140, y: h - 14 }, s).textContent = "x east, y north of origin";
}

function drawMission() {
  const g = $("mission"); clear(g);
  for (const s of mission.shapes) {
    const title = `${s.task} (${s.kind})`;
    let node;
    if (s.kind === "line") {
      node = el("polyline", { class: "shape",
        points: s.points.map((p) => `${sx(p[0])},${sy(p[1])}`).join(" ") }, g);
      for (const p of s.points) el("circle", { cx: sx(p[0]), cy: sy(p[1]), r: 3 / view.scale, class: "shape" }, g);
    } else if (s.kind === "point" || s.kind === "circle") {
      node = el("circle", { class: "shape", cx: sx(s.p[0]), cy: sy(s.p[1]), r: Math.max(s.r, 0.5) }, g);
    } else if (s.kind === "box") {
      node = el("rect", { class: "shape box", x: sx(s.min[0]), y: sy(s.max[1]),
        width: s.max[0] - s.min[0], height: s.max[1] - s.min[1] }, g);
    }
    if (node) el("title", {}, node).textContent = title;
  }
  const b = $("beacons"); clear(b);
  for (const beacon of mission.beacons) {
    el("rect", { class: "beacon", x: beacon.p[0] - 2, y: -beacon.p[1] - 2, width: 4, height: 4 }, b);
  }
  const flags = $("flagbuttons"); clear(flags);
  mission.remote_flags.forEach((name, i) => {
    const button = document.createElement("button");
    button.textContent = `flag ${name}`;
    button.onclick = () => act("flag", { index: i + 1 });
    flags.appendChild(button);
  });
}

function drawTrack() {
  $("track").setAttribute("points", track.map((p) => `${sx(p[0])},${sy(p[1])}`).join(" "));
}

function drawVehicle(g, label, pose) {
  const size = 14 / view.scale;
  const heading = pose.heading === undefined ? 0 : pose.heading;
  const marker = el("g", { id: `vehicle-${label}`, class: "vehicle", "data-x": pose.x, "data-y": pose.y,
    transform: `translate(${sx(pose.x)},${sy(pose.y)}) rotate(${heading})` }, g);
  if (pose.heading === undefined) {
    el("circle", { r: size / 3, fill: COLOURS[label] }, marker);
  } else {
    el("polygon", { points: `0,${-size} ${size / 2},${size / 2} 0,${size / 4} ${-size / 2},${size / 2}`,
      fill: COLOURS[label], opacity: label === "nav" ? 1 : 0.7 }, marker);
  }
  el("title", {}, marker).textContent = `${label} ${pose.x}, ${pose.y}`;
}

function drawFrame(f) {
  const g = $("vehicles"); clear(g);
  for (const label of ["truth", "autopilot", "gps", "ekf", "nav"]) {
    if (f.poses[label]) drawVehicle(g, label, f.poses[label]);
  }
  const e = $("ellipse"); clear(e);
  const ekf = f.poses.ekf;
  if (ekf && ekf.sigma_x !== undefined) {
    el("ellipse", { class: "ellipse", cx: sx(ekf.x), cy: sy(ekf.y), rx: 2 * ekf.sigma_x, ry: 2 * ekf.sigma_y }, e);
  }
  const b = $("beacons");
  for (const node of b.querySelectorAll(".range")) node.remove();
  for (const beacon of mission.beacons) {
    const r = f.ranges[beacon.name];
    if (r !== undefined) el("circle", { class: "range", cx: beacon.p[0], cy: -beacon.p[1], r }, b);
  }
  const goal = $("goal"); clear(goal);
  if (f.goal) {
    if (f.goal.kind === "line") {
      el("polyline", { class: "goal", points: f.goal.points.map((p) => `${sx(p[0])},${sy(p[1])}`).join(" ") }, goal);
    } else {
      el("circle", { class: "goal", cx: sx(f.goal.p[0]), cy: sy(f.goal.p[1]), r: Math.max(f.goal.r, 0.5) }, goal);
    }
  }
  drawPanels(f);
}

function drawPanels(f) {
  const s = f.status;
  const helm = $("helm");
  helm.textContent = s.online ? "helm ONLINE" : "helm offline";
  helm.className = "state " + (s.online ? "online" : "offline");
  text("why", s.status ? s.status : "(no helm state yet)");
  text("mode", `mode ${s.mode || "?"}`);
  text("armed", s.armed === null ? "?" : (s.armed ? "ARMED" : "disarmed"));
  const link = $("link");
  link.textContent = s.link_up ? `link up (${f.link.connect})` : `link DOWN (${f.link.connect})`;
  link.className = s.link_up ? "good" : "bad";
  // the vehicle's wall clock (UTC), or seconds since start on a simulated clock
  text("clock", f.t > 1e9 ? new Date(f.t * 1000).toISOString().slice(11, 21) + " UTC"
    : `t+${f.t.toFixed(1)} s`);
  text("steering", s.owner ? `${s.owner} steers${s.goal ? ": " + s.goal : ""}` : "nobody steers");
  const body = $("tasks").tBodies[0]; clear(body);
  for (const t of f.running) {
    const row = body.insertRow();
    row.className = "task";
    row.dataset.name = t.name;
    for (const v of [t.name, t.type, t.priority, t.left === null ? "—" : `${t.left.toFixed(0)} s`]) {
      row.insertCell().textContent = v;
    }
  }
  text("ended", s.mission_ended ? `MISSION ENDED (${s.mission_ended})` +
    (s.handed_back ? `, handed back in ${s.handed_back}` : "") : "");
  text("flags", Object.entries(f.flags).map(([k, v]) => `${k}=${v}`).join("  ") || "(none posted)");
  const src = $("sources").tBodies[0]; clear(src);
  for (const [k, v] of Object.entries(s.nav_sources)) {
    const row = src.insertRow();
    row.insertCell().textContent = `NAV_${k}`;
    const cell = row.insertCell(); cell.textContent = v;
    if (v === "NONE") cell.className = "bad";
  }
  text("navnote", [s.nav_failure ? `NAVIGATION FAILURE: ${s.nav_failure}` : "",
    s.nav_warning ? `last: ${s.nav_warning}` : ""].filter(Boolean).join(" · "));
  const legend = $("legend"); clear(legend);
  for (const label of Object.keys(f.poses)) {
    const span = document.createElement("span");
    span.style.color = COLOURS[label]; span.textContent = `■ ${label}`;
    legend.appendChild(span);
  }
  const alerts = $("alerts"); clear(alerts);
  for (const a of f.alerts) { const li = document.createElement("li"); li.textContent = a; alerts.appendChild(li); }
  text("webstats", `frames dropped ${f.web.dropped}; ` +
    `packets ${f.link.packets} (bad ${f.link.bad_packets})`);
}

// `mavhelm view --web`: every boat heard, a marker each and a row each
function drawFleet(f) {
  const g = $("vehicles"); clear(g);
  const rows = f.boats.filter((b) => b.x !== null && b.y !== null);
  for (const b of rows) {
    drawVehicle(g, "nav", { x: b.x, y: b.y, heading: b.heading === null ? undefined : b.heading });
    const marker = g.lastChild;
    marker.id = `vehicle-${b.sysid}`;
    el("text", { class: "label", x: 10 / view.scale, y: 0, style: `font-size:${13 / view.scale}px`,
      transform: `rotate(${-(b.heading || 0)})` }, marker).textContent = `${b.sysid}`;
  }
  if (rows.length) {
    track = rows.map((b) => [b.x, b.y]);
    const [x0, y0, x1, y1] = extent();
    const w = $("map").clientWidth, h = $("map").clientHeight;
    if ((x1 - x0) * view.scale > w || (y1 - y0) * view.scale > h || !last) fit();
    track = [];
  }
  last = { poses: {} };
  const helm = $("helm");
  helm.textContent = `${f.boats.length} vehicles`; helm.className = "state online";
  text("why", ""); text("mode", ""); text("armed", ""); text("link", "");
  text("clock", new Date(f.t * 1000).toISOString().slice(11, 19) + " UTC");
  text("steering", "");
  const head = $("tasks").tHead.rows[0];
  head.innerHTML = "<th>sys</th><th>mode</th><th>helm</th><th>steering</th>";
  const body = $("tasks").tBodies[0]; clear(body);
  for (const b of f.boats) {
    const row = body.insertRow();
    row.className = "boat"; row.dataset.sysid = b.sysid;
    const helmText = b.online === null ? "?" : (b.online ? "ONLINE" : "offline");
    for (const v of [b.sysid, `${b.mode || "?"}${b.armed ? " armed" : ""}`, helmText,
      b.steering + (b.silent ? " (silent)" : "")]) row.insertCell().textContent = v;
  }
  window.mavhelmFrames += 1;
}

async function act(name, body) {
  const token = $("token").value.trim();
  const headers = { "Content-Type": "application/json" };
  if (token) headers["X-Mavhelm-Token"] = token;
  const r = await fetch(`/api/control/${name}`, { method: "POST", headers, body: JSON.stringify(body || {}) });
  const answer = await r.json().catch(() => ({}));
  text("controlnote", r.ok ? `sent: ${answer.queued}` : `refused (${r.status}): ${answer.error}`);
}

function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  ws.onopen = () => { const c = $("conn"); c.textContent = "live"; c.className = "good"; };
  ws.onclose = () => {
    const c = $("conn"); c.textContent = "disconnected: retrying"; c.className = "bad";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (event) => {
    const f = JSON.parse(event.data);
    if (f.type === "hello") {
      if (f.mission && f.mission.shapes) mission = f.mission;
      track = f.track || [];
      $("control").hidden = !f.control;
      fit(); drawMission(); drawTrack();
      return;
    }
    if (f.type === "fleet") { drawFleet(f); return; }
    if (f.mission) { mission = f.mission; track = []; fit(); drawMission(); }
    if (f.track.length) { track.push(...f.track); if (track.length > 5000) track.splice(0, track.length - 5000); drawTrack(); }
    last = f;
    drawFrame(f);
    window.mavhelmFrames += 1;
    if (follow && f.poses.nav) {
      const svg = $("map"), w = svg.clientWidth, h = svg.clientHeight;
      const dx = (f.poses.nav.x - view.cx) * view.scale, dy = (f.poses.nav.y - view.cy) * view.scale;
      if (Math.abs(dx) > w * 0.45 || Math.abs(dy) > h * 0.45) { fit(); drawMission(); }
    }
  };
}

function init() {
  const m = /token=([^&]+)/.exec(location.hash);
  if (m) $("token").value = decodeURIComponent(m[1]);
  for (const name of ["allstop", "handback", "restart"]) $(name).onclick = () => act(name);
  const svg = $("map");
  svg.addEventListener("wheel", (e) => {
    e.preventDefault(); follow = false;
    view.scale *= e.deltaY < 0 ? 1.2 : 1 / 1.2; place(); drawMission();
  }, { passive: false });
  svg.addEventListener("dblclick", () => { follow = true; fit(); drawMission(); });
  window.addEventListener("resize", () => { place(); });
  connect();
}
init();
