// cyclomesh explore: the page. Every control change posts the state to /api/analyse
// (the one study pipeline of `cyclomesh run`) and redraws; a refused value shows the
// server's one-line message beside its control.
"use strict";

const $ = (id) => document.getElementById(id);
const FONT = { family: "system-ui, DejaVu Sans, sans-serif", size: 12, color: "#1d2330" };
const CONFIG = { displaylogo: false, responsive: true, modeBarButtonsToRemove: ["select2d", "lasso2d"] };
// light yellow to dark red (ColorBrewer YlOrRd)
const SCALE = [[0, "#ffffb2"], [0.25, "#fecc5c"], [0.5, "#fd8d3c"], [0.75, "#f03b20"], [1, "#bd0026"]];

let seq = 0;
let shown = 0;
let timer = null;
let lastKey = "";
let latest = null;
let defaults = null;

function parseValue(text, integer) {
  const t = String(text).trim();
  if (t !== "" && /^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$/.test(t)) {
    const v = Number(t);
    if (integer && Number.isInteger(v)) return v;
    return integer ? v : v;
  }
  return t; // sent as typed: the server names the key and what it expects
}

function state() {
  const overrides = {};
  document.querySelectorAll("[data-key]").forEach((el) => {
    const key = el.dataset.key;
    if (el.type === "checkbox") overrides[key] = el.checked;
    else if (el.tagName === "SELECT") overrides[key] = el.value;
    else overrides[key] = parseValue(el.value, !!el.dataset.int);
  });
  const magnitude = parseValue($("torque").value, false);
  overrides["load.torque_nm"] = typeof magnitude === "number"
    ? magnitude * Number($("direction").value) : magnitude;
  const factor = parseValue($("efactor").value, false);
  const seed = parseValue($("eseed").value, true);
  const exag = parseValue($("exagf").value, false);
  const body = {
    overrides,
    pin_errors: { mode: $("emode").value, factor, seed },
    crank_angle_deg: Number($("crank").value),
    exaggeration: $("exag").checked ? exag : 1,
    torsion: $("torsion").checked,
  };
  if (defaults && defaults.cases.length > 1) body.case = $("case").value;
  return body;
}

function clearErrors() {
  document.querySelectorAll(".err").forEach((el) => { el.textContent = ""; });
  document.querySelectorAll(".bad").forEach((el) => el.classList.remove("bad"));
}

function showError(message, key) {
  clearErrors();
  let box = key ? document.querySelector(`.err[data-err="${key}"]`) : null;
  if (!box && lastKey) box = document.querySelector(`.err[data-err="${lastKey}"]`);
  if (!box) box = $("general-error");
  box.textContent = message;
  const ctl = box.closest(".ctl");
  if (ctl) ctl.querySelectorAll("input.num").forEach((el) => el.classList.add("bad"));
  $("status").textContent = "refused: see the message beside the control";
}

function schedule(key, delay) {
  if (key !== undefined) lastKey = key;
  clearTimeout(timer);
  timer = setTimeout(() => { timer = null; update(); }, delay || 0);
}

let inFlight = false;
let pending = false;
// true when no change waits to be sent and no answer is awaited (the page shows its state)
window.exploreIdle = () => timer === null && !inFlight && !pending;

async function update() {
  // one request at a time: changes made meanwhile are sent together when it answers
  if (inFlight) { pending = true; return; }
  inFlight = true;
  try {
    await ask();
  } finally {
    inFlight = false;
    if (pending) { pending = false; update(); }
  }
}

async function ask() {
  const mine = ++seq;
  const start = performance.now();
  document.body.classList.add("busy");
  let response;
  try {
    response = await fetch("/api/analyse", {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(state()),
    });
  } catch (err) {
    document.body.classList.remove("busy");
    showError(`no answer from the server (${err})`, "");
    return;
  }
  const data = await response.json();
  if (mine < shown) return; // an older answer arriving late
  shown = mine;
  document.body.classList.remove("busy");
  if (!response.ok) { showError(data.error, data.key); return; }
  clearErrors();
  latest = data;
  draw(data);
  const ms = performance.now() - start;
  $("status").textContent = `answered in ${ms.toFixed(0)} ms (solve ${(1000 * data.seconds).toFixed(0)} ms)`;
}

function fmt(v, name = "") {
  if (v === null || v === undefined) return "—";
  if (typeof v === "boolean") return v ? "yes" : "no";
  // order rows of summary.json: [crank order, output order, amplitude]
  if (name.endsWith("_orders") && Array.isArray(v))
    return v.map((r) => `crank ×${r[0]}: ${fmt(r[2])}`).join(", ");
  if (Array.isArray(v)) return v.map((x) => fmt(x)).join(" / ");
  // a table of summary.json (path -> value): compliance shares, losses per path
  if (typeof v === "object") return Object.entries(v).map(([k, x]) => `${k} ${fmt(x)}`).join(", ");
  if (typeof v !== "number") return String(v);
  if (Number.isInteger(v)) return String(v);
  if (Math.abs(v) >= 1e5) return v.toFixed(0);
  return String(Number(v.toPrecision(5)));
}

function colour(t) {
  t = Math.max(0, Math.min(1, t));
  for (let i = 1; i < SCALE.length; i++) {
    if (t <= SCALE[i][0]) {
      const [t0, c0] = SCALE[i - 1], [t1, c1] = SCALE[i];
      const u = (t - t0) / (t1 - t0);
      const a = [1, 3, 5].map((k) => parseInt(c0.substr(k, 2), 16));
      const b = [1, 3, 5].map((k) => parseInt(c1.substr(k, 2), 16));
      return `rgb(${a.map((x, j) => Math.round(x + u * (b[j] - x))).join(",")})`;
    }
  }
  return SCALE[SCALE.length - 1][1];
}

function axis(title, extra) {
  return Object.assign({ title: { text: title }, zeroline: false, automargin: false,
    gridcolor: "#e6e8ec", linecolor: "#9aa3af", showline: true, mirror: true }, extra || {});
}

function layout(title, x, y, extra) {
  return Object.assign({
    title: { text: title, font: { size: 13 }, x: 0.02, xanchor: "left" },
    font: FONT, margin: { l: 60, r: 20, t: 36, b: 46 }, xaxis: x, yaxis: y,
    paper_bgcolor: "#fff", plot_bgcolor: "#fff", showlegend: false, uirevision: "keep",
  }, extra || {});
}

function drawScene(d) {
  const s = d.scene, loads = d.at_angle.pin_load_n;
  const peak = Math.max(1e-9, ...loads.map((v) => v || 0));
  const traces = [{
    x: s.disc_x_mm, y: s.disc_y_mm, mode: "lines", fill: "toself", fillcolor: "rgba(47,109,181,0.10)",
    line: { color: "#2f6db5", width: 1.2 }, hoverinfo: "skip", name: "disc",
  }];
  const ring = [], rx = [], ry = [];
  for (let k = 0; k <= 180; k++) {
    const t = (2 * Math.PI * k) / 180;
    rx.push(s.pin_circle_radius_mm * Math.cos(t)); ry.push(s.pin_circle_radius_mm * Math.sin(t));
  }
  traces.push({ x: rx, y: ry, mode: "lines", line: { color: "#9aa3af", width: 1, dash: "dot" }, hoverinfo: "skip" });
  const idle = { x: [], y: [] };
  for (let i = 0; i < s.pin_x_mm.length; i++) {
    const px = [], py = [], r = s.pin_radius_mm[i];
    for (let k = 0; k <= 24; k++) {
      const t = (2 * Math.PI * k) / 24;
      px.push(s.pin_x_mm[i] + r * Math.cos(t)); py.push(s.pin_y_mm[i] + r * Math.sin(t));
    }
    const load = loads[i] || 0;
    if (load > 0) {
      traces.push({
        x: px, y: py, mode: "lines", fill: "toself", fillcolor: colour(load / peak),
        line: { color: "#7a0019", width: 1.2 }, hoveron: "fills", hoverinfo: "text",
        text: `pin ${i + 1}: ${fmt(load)} N, ${fmt(d.at_angle.contact_stress_mpa[i])} MPa`,
      });
    } else { // the unloaded pins: one trace, a gap between pins
      idle.x.push(...px, null); idle.y.push(...py, null);
    }
  }
  traces.push({ x: idle.x, y: idle.y, mode: "lines", fill: "toself", fillcolor: "#eef0f3",
    line: { color: "#8a93a0", width: 0.8 }, hoverinfo: "skip", connectgaps: false });
  traces.push({ // the colour bar of the pin loads
    x: [s.disc_centre_mm[0]], y: [s.disc_centre_mm[1]], mode: "markers",
    marker: { size: 6, color: [0], cmin: 0, cmax: peak, colorscale: SCALE, showscale: true,
      colorbar: { title: { text: "pin load [N]", side: "right" }, thickness: 12, len: 0.8 } },
    hoverinfo: "text", text: "disc centre",
  });
  const ex = d.exaggeration !== 1 ? `, deformation ×${fmt(d.exaggeration)}` : " (to scale)";
  const lim = s.pin_circle_radius_mm + 2 * Math.max(...s.pin_radius_mm);
  Plotly.react("scene", traces, layout(
    `Disc and pin ring at φ = ${fmt(d.crank_angle_deg)}°${ex}`,
    axis("x [mm]", { range: [-lim, lim], constrain: "domain" }),
    axis("y [mm]", { range: [-lim, lim], scaleanchor: "x", scaleratio: 1 }),
    { margin: { l: 56, r: 10, t: 36, b: 46 } },
  ), CONFIG);
}

function marker(angle) {
  return [{ type: "line", xref: "x", yref: "paper", x0: angle, x1: angle, y0: 0, y1: 1,
    line: { color: "#bd0026", width: 1, dash: "dash" } }];
}

function draw(d) {
  const p = d.plots, a = d.at_angle;
  const pins = a.pin_load_n.map((_, i) => i + 1);
  drawScene(d);
  Plotly.react("loads", [
    { type: "bar", x: pins, y: a.pin_load_n, name: "pin-tooth Fc", marker: { color: "#f03b20" } },
    { type: "bar", x: pins, y: a.groove_load_n, name: "pin-groove Fp", marker: { color: "#2f6db5" } },
  ], layout(`Pin loads at φ = ${fmt(d.crank_angle_deg)}° (${a.contacts} pins in contact)`,
    axis("pin"), axis("load [N]"),
    { showlegend: true, legend: { orientation: "h", x: 0.5, xanchor: "center", y: -0.14 }, barmode: "group",
      margin: { l: 60, r: 20, t: 36, b: 80 } }), CONFIG);
  Plotly.react("te", [
    { x: p.crank_angle_deg, y: p.te_arcsec, mode: "lines", line: { color: "#2f6db5", width: 1.5 } },
  ], layout(`Loaded transmission error (Eq. 25), p-p ${fmt(d.summary.te_pp_arcsec)} arcsec`,
    axis("crank angle φ [deg]"), axis("TE [arcsec]"), { shapes: marker(d.crank_angle_deg) }), CONFIG);
  Plotly.react("ratio", [
    { x: p.crank_angle_deg, y: p.gear_ratio, mode: "lines", line: { color: "#1b7f3b", width: 1.2 } },
    { x: [p.crank_angle_deg[0], p.crank_angle_deg[p.crank_angle_deg.length - 1]],
      y: [p.ideal_ratio, p.ideal_ratio], mode: "lines", line: { color: "#5b6472", dash: "dot", width: 1 },
      hoverinfo: "skip" },
  ], layout(`Instantaneous gear ratio (Eq. 26), ripple ${fmt(d.summary.gear_ratio_ripple_pct)} %`,
    axis("crank angle φ [deg]"), axis("gear ratio [-]"), { shapes: marker(d.crank_angle_deg) }), CONFIG);
  const sp = p.stress_profile;
  const nowX = [], nowY = [], nowT = [];
  a.contact_stress_mpa.forEach((v, i) => {
    if (a.pin_load_n[i] > 0) { nowX.push(a.profile_angle_deg[i]); nowY.push(v); nowT.push(`pin ${i + 1}`); }
  });
  Plotly.react("stress", [
    { x: sp.profile_angle_deg, y: sp.stress_mpa, mode: "lines", name: "every pin, every crank angle",
      line: { width: 1, color: "rgba(47,109,181,0.45)" }, connectgaps: false, hoverinfo: "skip" },
    { x: nowX, y: nowY, mode: "markers", name: `at φ = ${fmt(d.crank_angle_deg)}°`, text: nowT,
      marker: { size: 8, color: "#bd0026", line: { color: "#fff", width: 1 } } },
  ], layout(`Contact stress over the tooth profile, peak ${fmt(d.summary.max_contact_stress_mpa)} MPa`,
    axis("profile angle φ1 [deg]"), axis("contact stress σH [MPa]"),
    { showlegend: true, legend: { orientation: "h", x: 0.5, xanchor: "center", y: -0.3 },
      margin: { l: 60, r: 20, t: 36, b: 84 } }), CONFIG);
  const tp = $("torsion-plot");
  if (d.torsion) {
    tp.hidden = false;
    const t = d.torsion;
    Plotly.react("torsion-plot", [
      { x: t.torque_nm, y: t.rotation_arcsec, mode: "lines+markers", marker: { size: 4 }, line: { color: "#6a3d9a" } },
    ], layout(`Torsion curve of the mesh (cyclomesh stiffness), rated ${fmt(t.rated_torque_nm)} N·m`,
      axis("torque T [N·m]"), axis("disc rotation, mean over φ [arcsec]")), CONFIG);
  } else {
    tp.hidden = true;
  }
  tables(d);
}

function row(cells, attrs) {
  const tr = document.createElement("tr");
  Object.entries(attrs || {}).forEach(([k, v]) => tr.setAttribute(k, v));
  cells.forEach(([text, cls]) => {
    const td = document.createElement("td");
    td.textContent = text;
    if (cls) td.className = cls;
    tr.appendChild(td);
  });
  return tr;
}

function tables(d) {
  const body = $("summary").querySelector("tbody");
  body.replaceChildren();
  const add = (name, value, unit, label) => {
    const tr = row([[label || name, ""], [fmt(value, name), value !== null && typeof value === "object" ? "v t" : "v"], [unit === "1" ? "" : unit || "", ""], [name, "n"]],
      { id: `metric-${name}`, "data-value": JSON.stringify(value) });
    body.appendChild(tr);
  };
  Object.entries(d.summary).forEach(([name, value]) => {
    if (name === "gear_ratio_step_deg") add(name, value, "deg", "ratio taken over");
    else add(name, value, d.units[name], d.labels[name]);
  });
  if (d.torsion) {
    Object.entries(d.torsion.summary).forEach(([name, value]) => {
      if (name in d.torsion.units) add(name, value, d.torsion.units[name], d.torsion.labels[name]);
    });
  }
  const checks = $("checks").querySelector("tbody");
  checks.replaceChildren();
  // the torsion curve checks what the run cannot (lost motion, rigidity)
  const extra = d.torsion ? (d.torsion.checks.rows || []).filter(
    (r) => (d.checks.not_checked || []).includes(r.check)) : [];
  const notChecked = (d.checks.not_checked || []).filter((k) => !extra.some((r) => r.check === k));
  [...(d.checks.rows || []), ...extra].forEach((r) => {
    const unit = r.unit === "1" ? "" : ` ${r.unit}`;
    const margin = r.margin_pct === null || r.margin_pct === undefined ? "—" : `${fmt(r.margin_pct)} %`;
    const tr = row([[r.label, ""], [fmt(r.limit) + unit, "v"], [fmt(r.value) + unit, "v"], [margin, "v"],
      [r.verdict, r.verdict]], { id: `check-${r.check}`, title: r.note || "" });
    checks.appendChild(tr);
  });
  if (notChecked.length) {
    const hint = d.torsion ? "" : " (tick torsion curve)";
    checks.appendChild(row([[`not computed here${hint}: ${notChecked.join(", ")}`, "n"]]));
  }
  const warn = $("warnings");
  warn.replaceChildren();
  (d.warnings || []).forEach((w) => { const li = document.createElement("li"); li.textContent = w; warn.appendChild(li); });
}

function fill(def) {
  defaults = def;
  $("study-title").textContent = `${def.file}: ${def.title}`;
  document.querySelectorAll("[data-key]").forEach((el) => {
    const v = def.overrides[el.dataset.key];
    if (v === undefined) return;
    if (el.type === "checkbox") el.checked = !!v; else el.value = String(v);
  });
  const t = def.overrides["load.torque_nm"];
  $("torque").value = String(Math.abs(t));
  $("direction").value = t < 0 ? "-1" : "1";
  document.querySelectorAll(".slider").forEach((s) => { s.value = $(s.dataset.for).value; });
  const crank = $("crank");
  crank.min = def.crank_start_deg;
  crank.max = def.crank_stop_deg;
  crank.step = def.overrides["analysis.crank_step_deg"];
  crank.value = def.crank_start_deg;
  $("crank-out").textContent = `${crank.value}°`;
  $("emode").querySelector('option[value="drawn"]').disabled = !def.tolerance;
  const cg = $("case-group");
  cg.hidden = def.cases.length < 2;
  const sel = $("case");
  if (!sel.options.length) def.cases.forEach((c) => sel.add(new Option(c, c)));
  sel.value = def.case;
}

async function loadDefaults(caseName) {
  const q = caseName ? `?case=${encodeURIComponent(caseName)}` : "";
  const response = await fetch(`/api/defaults${q}`);
  const data = await response.json();
  if (!response.ok) { showError(data.error, data.key); return; }
  fill(data);
  update();
}

async function download() {
  const response = await fetch("/api/study", {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(state()),
  });
  if (!response.ok) { const data = await response.json(); showError(data.error, data.key); return; }
  const blob = await response.blob();
  const name = (response.headers.get("Content-Disposition") || "").match(/filename="([^"]+)"/);
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = name ? name[1] : "explored.toml";
  document.body.appendChild(a);
  a.click();
  a.remove();
}

function wire() {
  document.querySelectorAll("input.num").forEach((el) => {
    const key = el.dataset.key || (el.closest(".ctl").querySelector(".err") || {}).dataset?.err;
    el.addEventListener("input", () => {
      const s = document.querySelector(`.slider[data-for="${el.id}"]`);
      if (s && el.value.trim() !== "" && !isNaN(Number(el.value))) s.value = el.value;
      schedule(key, 150);
    });
    el.addEventListener("change", () => schedule(key, 0));
  });
  document.querySelectorAll(".slider").forEach((s) => {
    s.addEventListener("input", () => {
      const target = $(s.dataset.for);
      target.value = s.value;
      schedule(target.dataset.key, 30);
    });
  });
  document.querySelectorAll("select, input[type=checkbox]").forEach((el) => {
    if (el.id === "case") return;
    const key = el.dataset.key || (el.closest(".ctl").querySelector(".err") || {}).dataset?.err || "";
    el.addEventListener("change", () => schedule(key, 0));
  });
  $("crank").addEventListener("input", () => {
    $("crank-out").textContent = `${$("crank").value}°`;
    schedule(undefined, 20);
  });
  $("step").addEventListener("change", () => { $("crank").step = $("step").value; });
  $("case").addEventListener("change", () => loadDefaults($("case").value));
  $("download").addEventListener("click", download);
}

wire();
loadDefaults(null);
