// Sidewalk NAVIGATION MONITOR page: draws the model's sections (sent over /ws) on a canvas in world
// coordinates (x east, y north [m]) with pan and zoom. No build step. What is drawn is mirrored in
// window.monitorState for tools and tests.
"use strict";

const S = {};               // the newest value of every section
let dirty = true;           // redraw wanted
const view = { cx: 0, cy: 0, scale: 4, fitted: false, routeFitted: false, moved: false };   // world centre [m], pixels per metre
const $ = (id) => document.getElementById(id);
const canvas = $("map");
const ctx = canvas.getContext("2d");

window.monitorState = {
  connected: false, messages: 0, frames: 0, replay: false, arch: "", simTime: 0,
  vehicle: null, truth: null, route: { count: 0, points: 0 }, segment: { drawn: false },
  units: { count: 0, ids: [] }, perceived: { count: 0 }, plan: { points: 0 }, controllerPath: { points: 0 },
  annotations: { count: 0 }, triggers: { count: 0 }, map: { features: 0 }, modules: [], mission: null,
  images: {}, series: { speed: 0, pos_error: 0 }, progress: null, view: view,
};

// ---- connection ---------------------------------------------------------------------------------

function connect() {
  const ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws");
  ws.onopen = () => { setConn(true); };
  ws.onclose = () => { setConn(false); setTimeout(connect, 1000); };
  ws.onerror = () => { ws.close(); };
  ws.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    const secs = msg.sections || {};
    Object.assign(S, secs);
    window.monitorState.messages += 1;
    panels(secs);
    dirty = true;
  };
}

function setConn(on) {
  window.monitorState.connected = on;
  const c = $("conn");
  c.textContent = on ? "connected" : "disconnected — retrying";
  c.className = "conn " + (on ? "on" : "off");
}

// ---- view: world ↔ screen, pan and zoom ----------------------------------------------------------

function sx(x) { return canvas.width / 2 + (x - view.cx) * view.scale; }
function sy(y) { return canvas.height / 2 - (y - view.cy) * view.scale; }

function resize() {
  const r = canvas.getBoundingClientRect();
  canvas.width = Math.max(100, Math.round(r.width));
  canvas.height = Math.max(100, Math.round(r.height));
  for (const id of ["ts-speed", "ts-err"]) {
    const c = $(id), b = c.getBoundingClientRect();
    c.width = Math.max(50, Math.round(b.width)); c.height = Math.max(30, Math.round(b.height));
  }
  dirty = true;
}

function fitTo(pointLists, margin) {
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const pts of pointLists) {
    for (const p of pts) { x0 = Math.min(x0, p[0]); y0 = Math.min(y0, p[1]); x1 = Math.max(x1, p[0]); y1 = Math.max(y1, p[1]); }
  }
  if (!isFinite(x0)) return false;
  x0 -= margin; y0 -= margin; x1 += margin; y1 += margin;
  view.cx = (x0 + x1) / 2; view.cy = (y0 + y1) / 2;
  view.scale = Math.min(canvas.width / Math.max(10, x1 - x0), canvas.height / Math.max(10, y1 - y0));
  return true;
}

function autoFit() {
  if (view.moved) return;
  // the lawns span the whole site: fit the map to what is on them; once a route is known, to the route
  if (!view.fitted && (S.map || []).length) view.fitted = fitTo(S.map.filter((f) => f.kind !== "grass").map((f) => f.points), 5);
  if (!view.routeFitted && (S.route || []).length) {
    const lists = S.route.map((r) => r.points);
    if (S.estimate) lists.push([[S.estimate.x, S.estimate.y]]);
    view.routeFitted = fitTo(lists, 20);
  }
}

let drag = null;
canvas.addEventListener("mousedown", (e) => { drag = { x: e.clientX, y: e.clientY, cx: view.cx, cy: view.cy }; canvas.style.cursor = "grabbing"; });
window.addEventListener("mouseup", () => { drag = null; canvas.style.cursor = "grab"; });
window.addEventListener("mousemove", (e) => {
  if (!drag) return;
  view.cx = drag.cx - (e.clientX - drag.x) / view.scale;
  view.cy = drag.cy + (e.clientY - drag.y) / view.scale;
  $("l-follow").checked = false;
  view.moved = true;
  dirty = true;
});
canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  const r = canvas.getBoundingClientRect();
  const px = e.clientX - r.left, py = e.clientY - r.top;
  const wx = view.cx + (px - canvas.width / 2) / view.scale, wy = view.cy - (py - canvas.height / 2) / view.scale;
  view.scale = Math.min(400, Math.max(0.2, view.scale * Math.exp(-e.deltaY * 0.0015)));
  view.cx = wx - (px - canvas.width / 2) / view.scale;
  view.cy = wy + (py - canvas.height / 2) / view.scale;
  view.moved = true;
  dirty = true;
}, { passive: false });
for (const id of ["l-world", "l-truth", "l-trails", "l-units", "l-perceived", "l-follow"]) $(id).addEventListener("change", () => { dirty = true; });
window.addEventListener("resize", resize);

// ---- drawing -------------------------------------------------------------------------------------

function rgb(c, a) { return `rgba(${c[0]},${c[1]},${c[2]},${a})`; }

function path(points, close) {
  ctx.beginPath();
  points.forEach((p, i) => { const X = sx(p[0]), Y = sy(p[1]); if (i === 0) ctx.moveTo(X, Y); else ctx.lineTo(X, Y); });
  if (close) ctx.closePath();
}

function stroke(points, color, width, opts = {}) {
  if (!points || points.length < 2) return 0;
  path(points, !!opts.close);
  if (opts.fill) { ctx.fillStyle = opts.fill; ctx.fill(); }
  ctx.strokeStyle = color; ctx.lineWidth = width; ctx.setLineDash(opts.dash || []);
  ctx.stroke(); ctx.setLineDash([]);
  return points.length;
}

function drawFeatures(features, truth) {
  for (const f of features || []) {
    const c = f.rgb;
    if (f.shape === "polygon") {
      if (truth) stroke(f.points, "rgba(255,255,255,0.55)", 1, { close: true, dash: [4, 3] });
      else stroke(f.points, rgb(c, 0.9), 1, { close: true, fill: rgb(c, f.kind === "grass" ? 0.18 : 0.35) });
    } else if (f.shape === "line") {
      if (!truth && f.kind !== "edge") stroke(f.points, rgb(c, 0.8), 1);
      else if (!truth) stroke(f.points, "rgba(90,140,230,0.35)", 1, { dash: [2, 3] });
    } else if (f.shape === "point") {
      if (f.kind === "node") continue;
      const r = Math.max(2, (f.radius || 0.3) * view.scale);
      ctx.beginPath(); ctx.arc(sx(f.points[0][0]), sy(f.points[0][1]), r, 0, 2 * Math.PI);
      if (truth) { ctx.strokeStyle = "rgba(255,255,255,0.55)"; ctx.setLineDash([3, 3]); ctx.stroke(); ctx.setLineDash([]); }
      else { ctx.fillStyle = rgb(c, 0.7); ctx.fill(); }
    }
  }
}

function vehicle(p, color, hollow, label) {
  const X = sx(p.x), Y = sy(p.y);
  const L = Math.max(12, 2.2 * view.scale), W = Math.max(8, 1.4 * view.scale);
  ctx.save(); ctx.translate(X, Y); ctx.rotate(-p.yaw);
  ctx.beginPath(); ctx.moveTo(L * 0.6, 0); ctx.lineTo(-L * 0.4, W / 2); ctx.lineTo(-L * 0.4, -W / 2); ctx.closePath();
  if (hollow) { ctx.strokeStyle = color; ctx.lineWidth = 2; ctx.setLineDash([4, 3]); ctx.stroke(); ctx.setLineDash([]); }
  else { ctx.fillStyle = color; ctx.fill(); ctx.strokeStyle = "#000"; ctx.lineWidth = 1; ctx.stroke(); }
  ctx.restore();
  if (label) { ctx.fillStyle = color; ctx.font = "11px system-ui"; ctx.fillText(label, X + 10, hollow ? Y - 10 : Y + 18); }
  return { x: p.x, y: p.y, yaw: p.yaw, t: p.t, sx: X, sy: Y };
}

function draw() {
  const st = window.monitorState;
  autoFit();
  if ($("l-follow").checked && S.estimate) { view.cx = S.estimate.x; view.cy = S.estimate.y; }
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  drawFeatures(S.map, false);
  if ($("l-world").checked) drawFeatures(S.world, true);
  st.map.features = (S.map || []).length;

  // EDDIE annotations and triggers
  let na = 0;
  for (const a of S.annotations || []) {
    na += stroke(a.points, "rgba(160,92,255,0.9)", 2, { close: a.points.length > 2, fill: a.points.length > 2 ? "rgba(160,92,255,0.12)" : null }) ? 1 : 0;
  }
  st.annotations.count = na;

  // route and the current segment
  let rp = 0;
  for (const r of S.route || []) rp += stroke(r.points, "rgba(59,108,255,0.9)", Math.max(2, 0.6 * view.scale));
  st.route = { count: (S.route || []).length, points: rp };
  const seg = S.segment;
  st.segment = { drawn: !!(seg && stroke(seg.centreline, "rgba(0,229,255,0.55)", Math.max(3, (seg.width_m || 1) * view.scale))), id: seg ? seg.id : null, mode: seg ? seg.mode : null };

  // driving units, perceived regions, view frames
  const ids = [];
  if ($("l-units").checked) {
    for (const u of S.units || []) {
      const col = { pending: "#ffc21a", perceived: "#33dd55", failed: "#ff4040" }[u.status] || "#ffc21a";
      if (stroke(u.region, col, 2, { close: true, fill: "rgba(255,194,26,0.08)" })) ids.push(u.id);
      stroke(u.centreline, "rgba(255,255,255,0.5)", 1, { dash: [3, 3] });
    }
  }
  st.units = { count: ids.length, ids: ids };
  let np = 0;
  if ($("l-perceived").checked) {
    const ps = (S.perceived || []).slice().sort((a, b) => a.captured_at - b.captured_at);
    ps.forEach((p, i) => {
      if (stroke(p.navigable_region, "#33dd55", 1.5, { close: true, fill: "rgba(51,221,85,0.22)" })) np += 1;
      if (i < ps.length - 2) return;   // the sensor view frame and the detected objects of the newest results only
      stroke(p.view_frame, "rgba(127,232,255,0.9)", 1.5, { close: true, dash: [5, 3] });
      for (const d of p.detected || []) stroke(d, "rgba(255,140,26,0.7)", 1, { close: true });
    });
  }
  st.perceived = { count: np };

  // paths: the local path plan (CODGER) and the controller's path (EDDIE)
  st.plan = { points: S.plan ? stroke(S.plan.points, "#ff4de6", 2.5) : 0 };
  st.controllerPath = { points: S.controller && S.controller.path ? stroke(S.controller.path, "#ff8c1a", 2.5, { dash: [6, 3] }) : 0 };

  // trails
  if ($("l-trails").checked && S.trails) {
    stroke(S.trails.estimate, "rgba(255,140,26,0.7)", 1.5);
    if ($("l-truth").checked) stroke(S.trails.truth, "rgba(255,255,255,0.45)", 1, { dash: [2, 3] });
  }

  // triggers as they fired (a skipped one hollow); only the newest few labelled, the rest are listed beside
  const trigs = S.triggers || [];
  let nt = 0, nfired = 0;
  trigs.forEach((t, i) => {
    const X = sx(t.x), Y = sy(t.y), fired = (t.event || "fired") === "fired";
    ctx.beginPath(); ctx.arc(X, Y, 6, 0, 2 * Math.PI);
    if (fired) { ctx.fillStyle = "#ff3b8b"; ctx.fill(); nfired += 1; }
    else { ctx.strokeStyle = "#ff3b8b"; ctx.lineWidth = 2; ctx.stroke(); }
    if (i >= trigs.length - 3) {
      ctx.fillStyle = "#ffb3d1"; ctx.font = "11px system-ui";
      ctx.fillText(`${fired ? "" : t.event + " "}${t.type} → ${t.destination}`, X + 8, Y + 4 + 13 * (i - trigs.length + 3));
    }
    nt += 1;
  });
  const last = trigs.length ? trigs[trigs.length - 1] : null;
  st.triggers = { count: nt, fired: nfired, last: last ? { type: last.type, destination: last.destination, event: last.event || "fired", t: last.t } : null };

  // poses: truth (evaluation only) under the estimate
  st.truth = (S.truth && $("l-truth").checked) ? vehicle(S.truth, "#ffffff", true, "truth (evaluation only)") : null;
  st.vehicle = S.estimate ? vehicle(S.estimate, "#ff8c1a", false, "estimate") : null;

  // scale bar
  const m = niceLength(120 / view.scale);
  $("scale").textContent = `${m} m = ${Math.round(m * view.scale)} px`;
  st.frames += 1;
  canvas.dataset.frames = String(st.frames);
  if (st.vehicle) { canvas.dataset.vehicleX = st.vehicle.x.toFixed(3); canvas.dataset.vehicleY = st.vehicle.y.toFixed(3); }
}

function niceLength(v) { const e = Math.pow(10, Math.floor(Math.log10(v))); for (const k of [1, 2, 5, 10]) if (k * e >= v) return k * e; return 10 * e; }

function loop() {
  if (dirty) { dirty = false; draw(); }
  requestAnimationFrame(loop);
}

// ---- side panels ---------------------------------------------------------------------------------

function esc(s) { return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c])); }

function panels(secs) {
  const st = window.monitorState;
  if (secs.meta) {
    const m = secs.meta;
    st.replay = !!m.replay; st.arch = m.arch; st.simTime = m.sim_time; st.progress = m.progress;
    $("simtime").textContent = (m.sim_time || 0).toFixed(1);
    $("rtf").textContent = m.rtf == null ? "–" : m.rtf;
    $("arch").textContent = m.arch + (m.namespace ? ` · ${m.namespace}` : "");
    const b = $("badge");
    b.textContent = m.replay ? "REPLAY" : "LIVE"; b.className = "badge" + (m.replay ? " replay" : "");
    const p = m.progress;
    $("progress").textContent = p ? `${p.done ? "finished" : "playing"} ${(p.t - p.start).toFixed(0)} / ${(p.end - p.start).toFixed(0)} s at ${p.speed}×` : (m.error || "");
  }
  if (secs.modules) {
    st.modules = secs.modules.map((r) => ({ name: r.name, state: r.state, alive: r.alive, age: r.age_s }));
    $("modules").querySelector("tbody").innerHTML = secs.modules.map((r) =>
      `<tr data-module="${esc(r.name)}"><td>${esc(r.name)}</td><td class="state-${esc(r.state)}">${esc(r.state)}</td>` +
      `<td>${r.age_s == null ? "–" : r.age_s.toFixed(1)}</td></tr>`).join("");
  }
  if ("segment" in secs) {
    const g = secs.segment;
    $("segment").textContent = g ? `current segment: ${g.mode || ""} ${g.text || g.id || ""}`.replace(/\s+/g, " ") : "";
  }
  if ("mission" in secs) {
    const m = secs.mission;
    st.mission = m ? { id: m.mission_id, name: m.name, state: m.state, step: m.current_step } : null;
    $("mission").innerHTML = !m ? "no mission yet" :
      `<div><b>${esc(m.name)}</b> <span class="dim">${esc(m.mission_id)}</span></div>` +
      `<div>state <span class="state">${esc(m.state)}</span> · step ${(m.current_step ?? 0) + 1}/${m.step_count} ${esc(m.reason || "")}</div>` +
      `<ul>${(m.steps || []).map((s) => `<li>${esc(s.name)}: ${esc(s.state)} ${esc(s.reason || "")}</li>`).join("")}</ul>`;
  }
  if (secs.images) {
    for (const [name, im] of Object.entries(secs.images)) {
      const img = $("img-" + name);
      if (img && (st.images[name] || {}).version !== im.version) {
        img.src = `/image/${name}?v=${im.version}`;
        $("cap-" + name).textContent = `t = ${im.stamp.toFixed(1)} s`;
      }
      st.images[name] = { version: im.version, stamp: im.stamp };
    }
  }
  if (secs.series) {
    st.series = { speed: secs.series.speed.length, pos_error: secs.series.pos_error.length };
    series($("ts-speed"), secs.series.speed, "#8fd3ff");
    series($("ts-err"), secs.series.pos_error, "#ff8c1a");
    const sp = secs.series.speed, er = secs.series.pos_error;
    $("speed-now").textContent = sp.length ? sp[sp.length - 1][1].toFixed(2) : "";
    $("err-now").textContent = er.length ? er[er.length - 1][1].toFixed(2) : "";
  }
  if (secs.controller && Object.keys(secs.controller).length > 1) {
    $("controller-panel").hidden = false;
    const c = secs.controller;
    $("controller").textContent = `v ${(c.v || 0).toFixed(2)} m/s · curvature ${(c.curvature || 0).toFixed(3)} 1/m · client ${c.client || "–"} · mode ${c.mode || "–"}`;
  }
  if (secs.triggers) {
    if (secs.triggers.length) $("controller-panel").hidden = false;
    $("triggers").innerHTML = secs.triggers.slice(-30).reverse().map((t) =>
      `<li>${t.t.toFixed(1)} s ${(t.event && t.event !== "fired") ? "<b>" + esc(t.event) + "</b> " : ""}${esc(t.type)} → ${esc(t.destination)} ${esc(t.text)}</li>`).join("");
  }
  if (secs.events) {
    $("events").innerHTML = secs.events.slice().reverse().map((e) =>
      `<li>${(e.stamp || 0).toFixed(1)} s <b>${esc(e.kind)}</b> ${esc(e.object_id || "")} ${esc(e.detail || "")}</li>`).join("");
  }
}

function series(c, data, color) {
  const g = c.getContext("2d");
  g.clearRect(0, 0, c.width, c.height);
  if (!data || data.length < 2) return;
  const t0 = data[0][0], t1 = data[data.length - 1][0];
  let vmax = 0; for (const d of data) vmax = Math.max(vmax, d[1]);
  vmax = vmax > 0 ? vmax * 1.1 : 1;
  g.strokeStyle = color; g.lineWidth = 1.5; g.beginPath();
  data.forEach((d, i) => {
    const X = (d[0] - t0) / Math.max(1e-6, t1 - t0) * (c.width - 4) + 2, Y = c.height - 2 - d[1] / vmax * (c.height - 14);
    if (i === 0) g.moveTo(X, Y); else g.lineTo(X, Y);
  });
  g.stroke();
  g.fillStyle = "#8b96a3"; g.font = "10px system-ui";
  g.fillText(vmax.toFixed(2), 2, 10); g.fillText(`${t0.toFixed(0)}–${t1.toFixed(0)} s`, c.width - 70, 10);
}

resize();
connect();
requestAnimationFrame(loop);
