// bearing-sweep web page: hand-written vanilla JS, no framework, nothing fetched from
// elsewhere. Talks to the service's JSON API (README "Service"); every figure is drawn
// here in SVG from the variant records (README "Sweeps", "Reductions").
"use strict";

// ---------------------------------------------------------------- small helpers
const $ = (sel, root = document) => root.querySelector(sel);
const SVGNS = "http://www.w3.org/2000/svg";
function el(tag, attrs = {}, ...kids) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === "text") e.textContent = v;
    else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v === true ? "" : v);
  }
  for (const kid of kids) if (kid !== null && kid !== undefined) e.append(kid);
  return e;
}
function svg(tag, attrs = {}, text) {
  const e = document.createElementNS(SVGNS, tag);
  for (const [k, v] of Object.entries(attrs)) if (v !== undefined && v !== null) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}
const isNum = (x) => typeof x === "number" && Number.isFinite(x);

// Numbers: 4 significant digits, plain notation in [1e-3, 1e5), else a x 10^n form.
function fmt(x, sig = 4) {
  if (x === null || x === undefined) return "—";
  if (typeof x === "boolean") return x ? "yes" : "no";
  if (typeof x !== "number") return String(x);
  if (!Number.isFinite(x)) return String(x);
  if (x === 0) return "0";
  const a = Math.abs(x);
  if (a >= 1e-3 && a < 1e5) return String(Number(x.toPrecision(sig))); // 1000, not 1.00e+3
  const [m, e] = x.toExponential(sig - 1).split("e");
  return `${m.replace(/0+$/, "").replace(/\.$/, "")}e${Number(e)}`;
}
function fmtDuration(s) {
  if (!isNum(s)) return "—";
  if (s < 60) return `${s.toFixed(s < 10 ? 1 : 0)} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min ${Math.round(s % 60)} s`;
  return `${Math.floor(s / 3600)} h ${Math.round((s % 3600) / 60)} min`;
}

// Display units of known quantities: SI value * scale shown with the unit label.
const UNITS = {
  m_um: { unit: "µm", scale: 1e6 }, m_mm: { unit: "mm", scale: 1e3 }, pas: { unit: "Pa·s", scale: 1 },
  mpas: { unit: "mPa·s", scale: 1e3 }, mrad: { unit: "mrad", scale: 1e3 },
  kg: { unit: "kg", scale: 1 }, rads: { unit: "rad/s", scale: 1 }, rad: { unit: "rad", scale: 1 },
  s: { unit: "s", scale: 1 }, ms: { unit: "ms", scale: 1 }, n: { unit: "N", scale: 1 }, w: { unit: "W", scale: 1 },
  nm: { unit: "N·m", scale: 1 }, one: { unit: "", scale: 1 }, ms2: { unit: "m/s²", scale: 1 },
  kgm2: { unit: "kg·m²", scale: 1 }, mps: { unit: "m/s", scale: 1 },
};
// The unit of a scene field from the last name in an axis path (README "Scenes and run");
// the same table as `unit_of_path` in src/plot.rs, so the page and the server's SVGs agree.
function unitOfPath(path) {
  const names = path.replace(/\[[^\]]*\]/g, "").split(".");
  const last = names[names.length - 1];
  const table = {
    clearance: "m_um", radius: "m_mm", length: "m_mm", axial_position: "m_mm", viscosity: "mpas",
    mass: "kg", inertia: "kgm2", static_unbalance: "m_um", couple_unbalance: "mrad", gravity: "ms2",
    spin: names.includes("initial") || names.length === 1 ? "rads" : "one", angle: "mrad", offset: "m_um",
    velocity: "mps", tilt: "mrad", t_end: "s", sample_interval: "s", fixed_step: "s", max_step: "s",
    threshold: "m_um", stiffness: "one", damping: "one", duration: "s", g_radius: "m_um",
    cost_ms: "ms", orbit: "m_um", whirl: "m_um", load: "n", eccentricity: "one", whirl_ratio: "one",
    friction_coefficient: "one", rtol: "one", atol: "one",
  };
  return UNITS[table[last] || "one"];
}
const pathLabel = (p) => p.replace(/^bearings\[\*\]\./, "").replace(/^initial\./, "initial ");
// "143.1 µm", "24.2 mPa·s": an SI value in its display unit, 4 significant digits.
const withUnit = (x, u) => (isNum(x) ? `${fmt(x * u.scale)}${u.unit ? " " + u.unit : ""}` : JSON.stringify(x));

// A path into a JSON value: "a.b[2].c".
function getPath(obj, path) {
  let cur = obj;
  for (const part of path.split(".")) {
    const m = part.match(/^([^[]*)((?:\[\d+\])*)$/);
    if (!m) return undefined;
    if (m[1]) cur = cur == null ? undefined : cur[m[1]];
    for (const idx of m[2].matchAll(/\[(\d+)\]/g)) cur = cur == null ? undefined : cur[Number(idx[1])];
  }
  return cur;
}
const maxOver = (arr, f) => {
  let best = null;
  for (const x of arr || []) { const v = f(x); if (isNum(v) && (best === null || v > best)) best = v; }
  return best;
};

// Scalar columns of a variant (reductions, SI values) with their display units.
const QUANTITIES = [
  { key: "h_min", label: "h_min", title: "thinnest film over all bearings and the run", u: UNITS.m_um,
    get: (v) => getPath(v, "reductions.h_min.value_m"), map: true },
  { key: "eps_max", label: "ε_max", title: "largest end eccentricity ratio over bearings and the run", u: UNITS.one,
    get: (v) => maxOver(getPath(v, "reductions.bearings"), (b) => getPath(b, "eccentricity_max.value")), map: true },
  { key: "friction", label: "f (bearing 1)", title: "friction coefficient of bearing 1, window mean", u: UNITS.one,
    get: (v) => getPath(v, "reductions.bearings[0].friction_coefficient.mean"), map: true, curve: true },
  { key: "power", label: "power loss", title: "sum over bearings of the window mean of |Mz·spin|", u: UNITS.w,
    get: (v) => getPath(v, "reductions.power_loss_w"), map: true },
  { key: "force_peak", label: "peak force", title: "largest film force over bearings and the run", u: UNITS.n,
    get: (v) => maxOver(getPath(v, "reductions.bearings"), (b) => getPath(b, "force_peak_n.value")) },
  { key: "g_orbit", label: "G orbit radius", title: "orbit radius of the centre of mass over the window", u: UNITS.m_um,
    get: (v) => getPath(v, "reductions.g_orbit.radius_m") },
  { key: "whirl_ratio", label: "whirl ratio", title: "dominant whirl frequency / mean spin", u: UNITS.one,
    get: (v) => getPath(v, "reductions.whirl_ratio") },
  { key: "oil_whirl", label: "oil whirl", title: "some bearing shows sub-synchronous whirl", u: UNITS.one,
    get: (v) => getPath(v, "reductions.oil_whirl") },
];

// ---------------------------------------------------------------- API access
const TOKEN_KEY = "bearing-sweep-token";
const token = () => sessionStorage.getItem(TOKEN_KEY) || "";
function headers(extra = {}) {
  const h = { ...extra };
  if (token()) h.Authorization = `Bearer ${token()}`;
  return h;
}
function showAuthBanner(on) {
  const b = $("#auth-banner");
  if (on) {
    b.textContent = token()
      ? "The server refused the token (401 Unauthorized). Check it in the API token field above."
      : "This server needs an API token (401 Unauthorized). Enter it in the API token field above.";
    b.hidden = false;
  } else b.hidden = true;
}
// One API call: {ok, status, data (parsed JSON or null), text, error: {path, message} | null}.
async function api(method, path, body, opts = {}) {
  const init = { method, headers: headers(opts.headers || {}) };
  if (body !== undefined) {
    init.body = typeof body === "string" ? body : JSON.stringify(body);
    init.headers["Content-Type"] = "application/json";
  }
  let res;
  try {
    res = await fetch(path, init);
  } catch (e) {
    return { ok: false, status: 0, data: null, text: "", error: { path: "", message: `no answer from the server (${e.message})` } };
  }
  const text = await res.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch (_) { /* not JSON (CSV, SVG) */ }
  if (res.status === 401) showAuthBanner(true);
  else if (res.ok) showAuthBanner(false);
  let error = null;
  if (!res.ok) {
    const e = data && data.error;
    error = e && typeof e === "object" ? { path: e.path || "", message: e.message || text }
      : { path: "", message: typeof e === "string" ? e : text || res.statusText };
    if (res.status === 401) error.message = `401 Unauthorized: ${token() ? "the token was refused" : "this server needs a token"} (${error.message})`;
  }
  return { ok: res.ok, status: res.status, data, text, error };
}
function saveBlob(name, text, type) { saveBlobObj(name, new Blob([text], { type })); }
function saveBlobObj(name, blob) {
  const url = URL.createObjectURL(blob);
  const a = el("a", { href: url, download: name });
  document.body.append(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 5000);
}

// Server-Sent Events over fetch (EventSource cannot send the Authorization header).
function openEvents(id, onEvent, onEnd) {
  const ctrl = new AbortController();
  (async () => {
    let res;
    try {
      res = await fetch(`/api/sweeps/${encodeURIComponent(id)}/events`, {
        headers: headers({ Accept: "text/event-stream" }), signal: ctrl.signal });
    } catch (_) { onEnd(false); return; }
    if (res.status === 401) showAuthBanner(true);
    if (!res.ok || !res.body) { onEnd(false); return; }
    const reader = res.body.getReader();
    const dec = new TextDecoder();
    let buf = "";
    try {
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buf = (buf + dec.decode(value, { stream: true })).replace(/\r\n?/g, "\n");
        let cut;
        while ((cut = buf.indexOf("\n\n")) >= 0) {
          const block = buf.slice(0, cut);
          buf = buf.slice(cut + 2);
          let event = "message";
          const data = [];
          for (const line of block.split("\n")) {
            if (!line || line.startsWith(":")) continue;
            const i = line.indexOf(":");
            const field = i < 0 ? line : line.slice(0, i);
            const val = i < 0 ? "" : line.slice(i + 1).replace(/^ /, "");
            if (field === "event") event = val;
            else if (field === "data") data.push(val);
          }
          if (data.length) {
            let parsed = data.join("\n");
            try { parsed = JSON.parse(parsed); } catch (_) { /* plain text event */ }
            onEvent(event, parsed);
          }
        }
      }
    } catch (_) { /* aborted or broken */ }
    onEnd(true);
  })();
  return () => ctrl.abort();
}

// ---------------------------------------------------------------- state
const TERMINAL = new Set(["done", "failed", "cancelled"]);
const state = {
  sweeps: new Map(),     // id -> normalised sweep
  streams: new Map(),    // id -> close function of its SSE stream
  selected: null,        // id of the sweep in the detail panel
  variants: [],          // variant records of the selected sweep
  result: null,          // result.json of the selected sweep once done
  spec: null,            // the selected sweep's spec (for axis names and clearances)
  sort: { key: "id", dir: 1 },
  variantId: null,       // variant shown in the orbit panel
  examples: [],
};

// A sweep object from the list or the status route, whatever nesting the server uses.
function normSweep(s) {
  const p = s.progress || {};
  const pick = (k) => (p[k] !== undefined ? p[k] : s[k]);
  return {
    id: String(s.id), name: s.name || s.spec_name || "", status: s.status || "queued", created: s.created,
    done: pick("done") ?? 0, failed: pick("failed") ?? 0, total: pick("total") ?? s.variants ?? null,
    rate: pick("variants_per_s"), eta: pick("eta_s"), message: s.message || s.error || null, raw: s,
  };
}
function mergeSweep(s) {
  const prev = state.sweeps.get(s.id) || {};
  const merged = { ...prev, ...Object.fromEntries(Object.entries(s).filter(([, v]) => v !== undefined && v !== null)) };
  state.sweeps.set(s.id, merged);
  noteProgress(merged);
  return merged;
}
// Rate and ETA from what this page saw finish over the last minute (the server's figures
// until 3 s of history exist), the ETA shown as a running blend of the previous estimate
// counted down and the new one: it moves smoothly instead of jumping with each batch.
const RATE_WINDOW_MS = 60000;
const progressSeen = new Map(); // id -> {hist: [[ms, done]], eta, at}
function noteProgress(s) {
  if (!isNum(s.done)) return;
  const p = progressSeen.get(s.id) || { hist: [], eta: null, at: 0 };
  const now = Date.now();
  if (!p.hist.length || p.hist[p.hist.length - 1][1] !== s.done) p.hist.push([now, s.done]);
  while (p.hist.length > 2 && now - p.hist[1][0] > RATE_WINDOW_MS) p.hist.shift();
  progressSeen.set(s.id, p);
}
function rateOf(s) {
  const p = progressSeen.get(s.id);
  if (p && p.hist.length >= 2) {
    const [t0, d0] = p.hist[0], [, d1] = p.hist[p.hist.length - 1];
    const span = (Date.now() - t0) / 1000;
    if (span >= 3 && d1 > d0) return (d1 - d0) / span;
  }
  return isNum(s.rate) ? s.rate : null;
}
function etaOf(s) {
  if (TERMINAL.has(s.status) || !isNum(s.total)) return null;
  const rate = rateOf(s);
  const raw = rate > 0 ? (s.total - s.done) / rate : isNum(s.eta) ? s.eta : null;
  if (raw === null) return null;
  const p = progressSeen.get(s.id) || { hist: [], eta: null, at: 0 };
  const now = Date.now();
  if (now - p.at < 900 && p.eta !== null) return p.eta; // once per second at most
  const counted = p.eta === null ? raw : Math.max(0, p.eta - (now - p.at) / 1000);
  p.eta = p.eta === null ? raw : 0.75 * counted + 0.25 * raw;
  p.at = now;
  progressSeen.set(s.id, p);
  return p.eta;
}
function fmtEta(x) {
  if (!isNum(x)) return "—";
  if (x >= 120) return fmtDuration(Math.round(x / 10) * 10); // no false precision
  return fmtDuration(x);
}

// ---------------------------------------------------------------- health and token
async function checkHealth() {
  const h = $("#health");
  try {
    const r = await fetch("/healthz");
    h.textContent = r.ok ? "server ready" : `server: ${r.status}`;
    h.className = `health ${r.ok ? "ok" : "bad"}`;
  } catch (_) { h.textContent = "server unreachable"; h.className = "health bad"; }
}
function initToken() {
  $("#token").value = token();
  $("#token-form").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const t = $("#token").value.trim();
    if (t) sessionStorage.setItem(TOKEN_KEY, t); else sessionStorage.removeItem(TOKEN_KEY);
    showAuthBanner(false);
    refreshAll();
  });
  $("#token-clear").addEventListener("click", () => {
    sessionStorage.removeItem(TOKEN_KEY); $("#token").value = ""; refreshAll();
  });
}

// ---------------------------------------------------------------- examples and editor
async function loadExamples() {
  const r = await api("GET", "/api/examples");
  const sel = $("#example");
  sel.innerHTML = "";
  if (!r.ok) { sel.append(el("option", { value: "", text: r.status === 401 ? "(needs the token)" : "(unavailable)" })); return; }
  state.examples = Array.isArray(r.data) ? r.data : r.data.examples || [];
  for (const ex of state.examples.filter((e) => e.role === "sweep"))
    sel.append(el("option", { value: ex.name, text: `${ex.name}${ex.title ? " — " + ex.title : ""}` }));
  const ev = state.examples.find((e) => e.role === "eval");
  if (ev && !evalFilled) {
    const r2 = await api("GET", `/api/examples/${encodeURIComponent(ev.name)}`);
    if (r2.ok && r2.data) fillEval(r2.data);
  }
  // The editor starts with an example (the page's first sweep needs no "Load example").
  if (!$("#spec").value.trim()) {
    const pick = state.examples.find((e) => e.role === "sweep" && e.name === "clearance-viscosity") || state.examples.find((e) => e.role === "sweep");
    if (pick) { sel.value = pick.name; await loadExample(); }
  }
  showExampleDesc();
}
function showExampleDesc() {
  const ex = state.examples.find((e) => e.name === $("#example").value);
  $("#example-desc").textContent = ex ? ex.description || "" : "";
}
async function loadExample() {
  const name = $("#example").value;
  if (!name) return;
  const r = await api("GET", `/api/examples/${encodeURIComponent(name)}`);
  if (!r.ok) { showSpecError(r.error); return; }
  setSpecText(r.text);
  showExampleDesc();
}
function setSpecText(text) {
  const ta = $("#spec");
  ta.value = text;
  clearSpecError();
}
function clearSpecError() {
  $("#spec-error").hidden = true;
  $("#spec").removeAttribute("aria-invalid");
}
// Where a JSON path ("base.bearings[1].clearance") starts in the editor's text, by a small
// tokenizer that records each value's offset under its path. Falls back to a shorter
// prefix of the path when the exact one is absent (e.g. a missing field).
function locatePath(text, path) {
  const offsets = new Map();
  let i = 0;
  const ws = () => { while (i < text.length && /\s/.test(text[i])) i++; };
  const str = () => { const s = i; i++; while (i < text.length && text[i] !== '"') i += text[i] === "\\" ? 2 : 1; i++; return JSON.parse(text.slice(s, i)); };
  function value(p) {
    ws();
    offsets.set(p, i);
    const c = text[i];
    if (c === "{") {
      i++; ws();
      if (text[i] === "}") { i++; return; }
      for (;;) {
        ws(); const k = str(); ws(); i++; // ':'
        value(p ? `${p}.${k}` : k); ws();
        if (text[i] === ",") { i++; continue; }
        i++; return;
      }
    } else if (c === "[") {
      i++; ws();
      if (text[i] === "]") { i++; return; }
      for (let k = 0; ; k++) {
        value(`${p}[${k}]`); ws();
        if (text[i] === ",") { i++; continue; }
        i++; return;
      }
    } else if (c === '"') str();
    else { while (i < text.length && !/[\s,}\]]/.test(text[i])) i++; }
  }
  try { value(""); } catch (_) { return null; }
  let p = (path || "").replace(/^\$\.?/, "");
  // A scene path of a sweep's variant ("bearings[1].length") lives under "base".
  if (!offsets.has(p) && offsets.has(`base.${p}`)) p = `base.${p}`;
  for (;;) {
    if (offsets.has(p)) return { offset: offsets.get(p), path: p };
    const cut = Math.max(p.lastIndexOf("."), p.lastIndexOf("["));
    if (cut <= 0) return p ? { offset: offsets.get("") ?? 0, path: "" } : null;
    p = p.slice(0, cut);
  }
}
function lineOf(text, offset) { return text.slice(0, offset).split("\n").length; }
function showSpecError(err) {
  const box = $("#spec-error");
  box.innerHTML = "";
  const ta = $("#spec");
  const text = ta.value;
  let where = "";
  const loc = err.path ? locatePath(text, err.path) : null;
  if (loc) {
    where = ` (line ${lineOf(text, loc.offset)})`;
    ta.setSelectionRange(loc.offset, loc.offset);
  }
  if (err.path) box.append(el("span", { class: "path", text: err.path }), document.createTextNode(": "));
  box.append(document.createTextNode(err.message + where));
  box.hidden = false;
  ta.setAttribute("aria-invalid", "true");
}
// The editor's JSON, or null after showing where it does not parse.
function specJson() {
  const text = $("#spec").value;
  try {
    return JSON.parse(text);
  } catch (e) {
    const m = String(e.message).match(/position (\d+)/);
    const where = m ? ` (line ${lineOf(text, Number(m[1]))})` : "";
    showSpecError({ path: "", message: `not valid JSON: ${e.message}${where}` });
    return null;
  }
}
function submitQuery() {
  const q = new URLSearchParams();
  if ($("#opt-backend").value) q.set("backend", $("#opt-backend").value);
  if ($("#opt-accuracy").value) q.set("accuracy", $("#opt-accuracy").value);
  if ($("#opt-full-model").checked) q.set("full_model", "true");
  const s = q.toString();
  return s ? `?${s}` : "";
}
async function checkSpec() {
  clearSpecError();
  if (specJson() === null) return;
  const st = $("#submit-status");
  st.textContent = "checking…";
  const r = await api("POST", `/api/validate${submitQuery()}`, $("#spec").value);
  if (r.ok) {
    const n = r.data && r.data.variants;
    st.textContent = `spec is valid: ${r.data.kind || "sweep"}${isNum(n) ? `, ${n} variants` : ""} (nothing stored or run)`;
  } else { st.textContent = ""; showSpecError(r.error); }
}
async function submitSpec() {
  clearSpecError();
  if (specJson() === null) return;
  const st = $("#submit-status");
  const btn = $("#submit");
  btn.disabled = true;
  st.textContent = "submitting…";
  const r = await api("POST", `/api/sweeps${submitQuery()}`, $("#spec").value);
  btn.disabled = false;
  if (!r.ok) {
    st.textContent = `not submitted (${r.status})`;
    showSpecError(r.error);
    return;
  }
  const s = mergeSweep(normSweep({ ...r.data, total: r.data.variants, name: (specJsonQuiet() || {}).name }));
  st.textContent = `submitted: ${s.id} (${s.total ?? "?"} variants)`;
  renderQueue();
  watch(s.id);
  selectSweep(s.id);
  refreshQueue();
}
function specJsonQuiet() { try { return JSON.parse($("#spec").value); } catch (_) { return null; } }

// ---------------------------------------------------------------- queue and progress
async function refreshQueue() {
  const r = await api("GET", "/api/sweeps");
  if (!r.ok) return;
  const list = Array.isArray(r.data) ? r.data : r.data.sweeps || r.data.items || [];
  const seen = new Set();
  for (const raw of list) { const s = mergeSweep(normSweep(raw)); seen.add(s.id); if (!TERMINAL.has(s.status)) watch(s.id); }
  for (const id of [...state.sweeps.keys()]) if (!seen.has(id)) state.sweeps.delete(id);
  renderQueue();
  if (state.selected && state.sweeps.has(state.selected)) renderProgress();
}
function statusClass(s) {
  return ["ok", "done", "running", "queued", "failed", "cancelled", "film_breakdown", "through_wall"].includes(s) ? `st-${s}` : "st-other";
}
// Rows are updated in place (keyed by id), so focus and hover survive the refreshes.
function renderQueue() {
  const tb = $("#queue tbody");
  const rows = [...state.sweeps.values()].sort((a, b) => String(b.created ?? "").localeCompare(String(a.created ?? "")) || (b.id > a.id ? 1 : -1));
  $("#queue-empty").hidden = rows.length > 0;
  const existing = new Map([...tb.children].map((tr) => [tr.dataset.id, tr]));
  for (const [id, tr] of existing) if (!state.sweeps.has(id)) tr.remove();
  rows.forEach((s, k) => {
    let tr = existing.get(s.id);
    if (!tr) {
      tr = el("tr", { "data-id": s.id },
        el("td", {}, el("button", { class: "link", type: "button", onclick: () => selectSweep(s.id) })),
        el("td"), el("td", {}, el("progress", { max: 1, value: 0 }), el("span")), el("td", { class: "num" }),
        el("td", { class: "num" }), el("td", { class: "num" }), el("td"));
    }
    const label = s.name || s.id;
    const c = tr.children;
    tr.classList.toggle("sel", s.id === state.selected);
    const open = c[0].firstChild;
    if (open.textContent !== label) { open.textContent = label; open.title = `open sweep ${s.id}`; }
    if (c[1].textContent !== s.status) { c[1].textContent = s.status; c[1].className = statusClass(s.status); }
    const bar = c[2].firstChild;
    bar.value = s.total ? s.done / s.total : 0;
    bar.setAttribute("aria-label", `${label} progress`);
    c[2].lastChild.textContent = ` ${s.done}/${s.total ?? "?"}`;
    c[3].textContent = String(s.failed);
    const rate = rateOf(s);
    c[4].textContent = isNum(rate) && rate > 0 ? `${fmt(rate, 3)} /s` : "—";
    c[5].textContent = TERMINAL.has(s.status) ? "—" : fmtEta(etaOf(s));
    const term = TERMINAL.has(s.status) ? "1" : "0";
    if (tr.dataset.term !== term) {
      tr.dataset.term = term;
      c[6].innerHTML = "";
      c[6].append(term === "1"
        ? el("button", { type: "button", text: "Delete", "aria-label": `delete ${label}`, onclick: () => deleteSweep(s.id) })
        : el("button", { type: "button", text: "Cancel", "aria-label": `cancel ${label}`, onclick: () => cancelSweep(s.id) }));
    }
    if (tb.children[k] !== tr) tb.insertBefore(tr, tb.children[k] || null);
  });
}
// Live progress: an SSE stream per unfinished sweep (at most 4 open; the browser allows
// ~6 connections per server), each event refreshes that sweep's status.
const MAX_STREAMS = 4;
function watch(id) {
  if (state.streams.has(id)) return;
  if (state.streams.size >= MAX_STREAMS && id !== state.selected) return;
  const throttled = throttle(() => refreshSweep(id), 300);
  // Events (README "Service"): `status` {status, progress} first and on every change,
  // `variant` {id (the variant's), status ok|not_ok, progress} per finished variant.
  const close = openEvents(id, (event, data) => {
    if (state.selected === id) { // what arrived live, for a look in the inspector (and the browser test)
      const d = $("#detail").dataset;
      d.events = String(Number(d.events || 0) + 1);
      d.lastEvent = `${event}:${data && data.status}`;
    }
    if (data && typeof data === "object") {
      const p = data.progress || {};
      const upd = { id };
      if (event === "status" && data.status) upd.status = data.status;
      // A final status event carries no counts: those come from the status route.
      if (p.total && !(event === "status" && TERMINAL.has(data.status))) {
        Object.assign(upd, { done: p.done, failed: p.failed, total: p.total, rate: p.variants_per_s, eta: p.eta_s });
      }
      const s = mergeSweep(upd);
      if (state.selected === id) { renderProgress(); if (event === "variant") loadVariantsThrottled(false); }
      renderQueue();
      if (TERMINAL.has(s.status)) { refreshSweep(id); return; }
    }
    throttled();
  }, () => {
    state.streams.delete(id);
    const s = state.sweeps.get(id);
    refreshSweep(id).then(() => {
      const s2 = state.sweeps.get(id);
      if (s2 && !TERMINAL.has(s2.status)) setTimeout(() => watch(id), 1000);
    });
    void s;
  });
  state.streams.set(id, close);
}
function throttle(fn, ms) {
  let last = 0, timer = null;
  return () => {
    const now = Date.now();
    if (now - last >= ms) { last = now; fn(); }
    else if (!timer) timer = setTimeout(() => { timer = null; last = Date.now(); fn(); }, ms - (now - last));
  };
}
async function refreshSweep(id) {
  const r = await api("GET", `/api/sweeps/${encodeURIComponent(id)}`);
  if (r.status === 404) { state.sweeps.delete(id); renderQueue(); return; }
  if (!r.ok) return;
  const before = state.sweeps.get(id);
  const s = mergeSweep(normSweep(r.data));
  renderQueue();
  if (state.selected === id) {
    renderProgress();
    const finished = TERMINAL.has(s.status) && !(before && TERMINAL.has(before.status) && state.result);
    loadVariantsThrottled(finished);
  }
}
async function cancelSweep(id) {
  const r = await api("POST", `/api/sweeps/${encodeURIComponent(id)}/cancel`);
  if (!r.ok) alert(`cancel failed: ${r.error.message}`);
  refreshSweep(id);
}
async function deleteSweep(id) {
  if (!confirm("Delete this sweep and its results?")) return;
  const r = await api("DELETE", `/api/sweeps/${encodeURIComponent(id)}`);
  if (!r.ok && r.status !== 404) { alert(`delete failed: ${r.error.message}`); return; }
  state.sweeps.delete(id);
  if (state.selected === id) { state.selected = null; $("#detail").hidden = true; writeHash(); }
  renderQueue();
}

// ---------------------------------------------------------------- detail panel
// Each sweep (and its open variant) has its own URL: #sweep=ID&variant=N. A reload, a
// bookmark or a link opens the same view; the back button returns to the previous sweep.
function hashParams() {
  const h = new URLSearchParams(location.hash.replace(/^#/, ""));
  return { sweep: h.get("sweep"), variant: h.get("variant") };
}
function writeHash(newEntry) {
  const p = new URLSearchParams();
  if (state.selected) p.set("sweep", state.selected);
  if (state.selected && state.variantId !== null) p.set("variant", String(state.variantId));
  const h = p.toString() ? `#${p}` : "";
  if (location.hash === h || (!h && !location.hash)) return;
  const url = h || location.pathname + location.search;
  const sameSweep = hashParams().sweep === state.selected;
  if (newEntry && !sameSweep) history.pushState(null, "", url); else history.replaceState(null, "", url);
}
function followHash() {
  const { sweep, variant } = hashParams();
  if (sweep && sweep !== state.selected) {
    state.pendingVariant = variant === null ? null : Number(variant);
    selectSweep(sweep);
  } else if (sweep && variant !== null && Number(variant) !== state.variantId) showVariant(variant, false);
}
async function selectSweep(id) {
  if (state.selected !== id) {
    state.selected = id;
    delete $("#detail").dataset.events; delete $("#detail").dataset.lastEvent;
    state.variants = []; state.result = null; state.spec = null; state.variantId = null;
    $("#sweep-message").hidden = true;
    $("#variant-id").textContent = "(click a map cell or a table row)";
    $("#variant-params").textContent = "";
    $("#orbit").innerHTML = ""; $("#history").innerHTML = "";
    $("#server-plots").innerHTML = "";
    plotsFor = null;
  }
  $("#detail").hidden = false;
  writeHash(true);
  renderQueue();
  renderProgress();
  watch(id);
  await refreshSweep(id);
  if (!state.sweeps.has(id) && state.selected === id) {
    $("#sweep-message").hidden = false;
    $("#sweep-message").textContent = `No sweep ${id} on this server (deleted, or a link from another server).`;
    return;
  }
  await loadVariants(true);
  $("#detail-h").scrollIntoView({ block: "start", behavior: "smooth" });
}
function renderProgress() {
  const s = state.sweeps.get(state.selected);
  if (!s) return;
  $("#detail-name").textContent = s.name ? `${s.name} (${s.id})` : s.id;
  const st = $("#sweep-status");
  st.textContent = s.status;
  st.className = statusClass(s.status);
  const p = $("#sweep-progress");
  p.value = s.total ? s.done / s.total : 0;
  $("#sweep-counts").textContent = `${s.done} / ${s.total ?? "?"} done, ${s.failed} failed`;
  const curves = state.result && state.result.curves;
  if (Array.isArray(curves) && curves.length) { // a friction map: one document, no variant records
    p.value = 1;
    $("#sweep-counts").textContent = `friction map: ${curves.length} speeds × ${curves[0].points.length} loads`;
  }
  const rate = rateOf(s), eta = etaOf(s);
  $("#sweep-rate").textContent = isNum(rate) ? `${fmt(rate, 3)} variants/s` : "";
  $("#sweep-eta").textContent = !TERMINAL.has(s.status) && isNum(eta) ? `ETA ${fmtEta(eta)}` : "";
  $("#detail-cancel").hidden = TERMINAL.has(s.status);
  const msg = $("#sweep-message");
  msg.hidden = !s.message;
  msg.textContent = s.message || "";
}
// Reloads while a sweep runs: at most every 1.5 s, and at most 20 % of the time when the
// records are large (a reload that takes 1 s waits 5 s before the next).
let variantsTimer = null, variantsLast = 0, variantsCost = 0;
function loadVariantsThrottled(force) {
  const wait = force ? 0 : Math.max(0, Math.max(1500, 5 * variantsCost) - (Date.now() - variantsLast));
  if (variantsTimer && !force) return;
  clearTimeout(variantsTimer);
  variantsTimer = setTimeout(() => { variantsTimer = null; loadVariants(force); }, wait);
}
// All variant records (pages of 1000), readable while the sweep runs; then result.json.
async function loadVariants(withResult) {
  const id = state.selected;
  if (!id) return;
  variantsLast = Date.now();
  variantsStarted = performance.now();
  const s = state.sweeps.get(id);
  const all = [];
  const LIMIT = 1000;
  for (let offset = 0; offset < 200000; offset += LIMIT) {
    const r = await api("GET", `/api/sweeps/${encodeURIComponent(id)}/variants?offset=${offset}&limit=${LIMIT}`);
    if (!r.ok || state.selected !== id) break;
    const page = Array.isArray(r.data) ? r.data : r.data.variants || r.data.items || [];
    all.push(...page.filter((v) => v && v.id !== undefined && v.reductions !== undefined || (v && v.status && v.id !== undefined)));
    if (page.length < LIMIT) break;
  }
  if (state.selected !== id) return;
  variantsCost = Date.now() - variantsLast;
  all.sort((a, b) => a.id - b.id);
  state.variants = all;
  if (withResult && s && s.status === "done" && !state.result) {
    const r = await api("GET", `/api/sweeps/${encodeURIComponent(id)}/result`);
    if (r.ok && state.selected === id) {
      state.result = r.data;
      state.spec = r.data.spec || state.spec;
      if (!state.variants.length && Array.isArray(r.data.variants)) state.variants = r.data.variants;
    }
    loadServerPlots(id);
  }
  if (!state.spec && s && s.raw && s.raw.spec) state.spec = s.raw.spec;
  // Redraw only when something changed (a redraw loses hover and keyboard focus).
  const sig = `${id}|${state.variants.length}|${state.variants.length ? state.variants[state.variants.length - 1].id : ""}|${Boolean(state.result)}`;
  if (sig === renderedSig) return;
  renderedSig = sig;
  const t0 = performance.now();
  renderDetail();
  // Costs of the last reload, for a look in the inspector (and BENCHMARKS.md "Web page").
  const d = $("#detail").dataset;
  d.loadMs = String(Math.round(t0 - variantsStarted));
  d.renderMs = String(Math.round(performance.now() - t0));
}
let renderedSig = "", variantsStarted = 0;
function axesOf() {
  // Axis paths from the spec if known, else from the variants' params (in key order).
  const fromSpec = state.spec && Array.isArray(state.spec.axes) ? state.spec.axes.map((a) => a.path) : null;
  if (fromSpec && fromSpec.length) return fromSpec;
  const keys = [];
  for (const v of state.variants.slice(0, 50)) for (const k of Object.keys(v.params || {})) if (!keys.includes(k)) keys.push(k);
  return keys;
}
function renderDetail() {
  // A friction_map sweep has no variant records: its result is Fig. 4's curves.
  const isMap = Boolean(state.result && Array.isArray(state.result.curves));
  $("#fig4-fig").hidden = !isMap;
  for (const sel of ["#variant-h", "#variant-h + .row", "#variant-note", "#detail .grid2:not(#maps)", "#variant-params", "#table-h", "#table-h + .row", "#detail .tablewrap"])
    for (const e of document.querySelectorAll(sel)) e.hidden = isMap;
  if (isMap) {
    renderProgress();
    $("#parallel-fig").hidden = true;
    drawFig4(state.result); $("#maps-controls").hidden = true; $("#curves-controls").hidden = true; $("#curves-fig").hidden = true; $("#maps").innerHTML = ""; $("#maps-note").textContent = ""; return; }
  renderTable();
  renderMaps();
  renderCurves();
  renderParallel();
  const pend = state.pendingVariant;
  if (pend !== null && pend !== undefined && state.variants.some((v) => v.id === Number(pend))) { state.pendingVariant = null; showVariant(pend, false); }
  else if (state.variantId === null && state.variants.length) showVariant(state.variants[0].id, false);
  else if (state.variantId !== null) showVariant(state.variantId, false);
}

// ---- variant table
function tableColumns() {
  const cols = [{ key: "id", label: "id", num: true, get: (v) => v.id, u: UNITS.one }];
  for (const p of axesOf()) {
    const u = unitOfPath(p);
    cols.push({ key: `p:${p}`, label: pathLabel(p), title: p, u, num: true, get: (v) => (v.params || {})[p] });
  }
  cols.push({ key: "status", label: "status", get: (v) => v.status, u: UNITS.one });
  for (const q of QUANTITIES) {
    if (state.variants.some((v) => q.get(v) !== undefined && q.get(v) !== null)) cols.push({ ...q, num: q.key !== "oil_whirl" });
  }
  return cols;
}
function cellText(col, x) {
  if (typeof x === "number") return fmt(x * col.u.scale);
  if (x === null || x === undefined) return "—";
  if (typeof x === "boolean") return x ? "yes" : "no";
  return typeof x === "object" ? JSON.stringify(x) : String(x);
}
function renderTable() {
  const cols = tableColumns();
  const thead = $("#variants thead");
  const focusKey = document.activeElement && document.activeElement.closest && document.activeElement.closest("#variants thead th") ? document.activeElement.closest("th").dataset.key : null;
  thead.innerHTML = "";
  const hr = el("tr");
  for (const c of cols) {
    const sorted = state.sort.key === c.key;
    const th = el("th", { scope: "col", class: c.num ? "num" : null, "data-key": c.key, title: c.title || null,
      "aria-sort": sorted ? (state.sort.dir > 0 ? "ascending" : "descending") : "none" });
    const b = el("button", { type: "button", onclick: () => { state.sort = { key: c.key, dir: sorted ? -state.sort.dir : 1 }; renderTable(); } },
      c.label, c.u.unit ? el("span", { class: "unit", text: ` (${c.u.unit})` }) : null);
    th.append(b);
    hr.append(th);
  }
  thead.append(hr);
  if (focusKey) { const f = thead.querySelector(`th[data-key="${CSS.escape(focusKey)}"] button`); if (f) f.focus(); }
  // status filter choices
  const fsel = $("#status-filter");
  const cur = fsel.value;
  const statuses = [...new Set(state.variants.map((v) => v.status))].sort();
  fsel.innerHTML = "";
  fsel.append(el("option", { value: "", text: `all (${state.variants.length})` }));
  for (const st of statuses) fsel.append(el("option", { value: st, text: `${st} (${state.variants.filter((v) => v.status === st).length})` }));
  fsel.value = statuses.includes(cur) ? cur : "";
  const col = cols.find((c) => c.key === state.sort.key) || cols[0];
  const rows = state.variants.filter((v) => !fsel.value || v.status === fsel.value);
  rows.sort((a, b) => {
    const x = col.get(a), y = col.get(b);
    if (x === y) return a.id - b.id;
    if (x === null || x === undefined) return 1;
    if (y === null || y === undefined) return -1;
    return (x < y ? -1 : 1) * state.sort.dir;
  });
  const tb = $("#variants tbody");
  // Rebuilt on every reload while the sweep runs: keep the keyboard focus where it was.
  const act = document.activeElement;
  const focusRow = act && act.closest && act.closest("#variants tbody tr") ? act.closest("tr").dataset.id : null;
  tb.innerHTML = "";
  const MAX_ROWS = 2000; // the DOM stays responsive; downloads have all rows
  for (const v of rows.slice(0, MAX_ROWS)) {
    const tr = el("tr", { "data-id": v.id, tabindex: 0, class: v.id === state.variantId ? "sel" : null,
      onclick: () => showVariant(v.id, true), onkeydown: (e) => { if (e.key === "Enter") showVariant(v.id, true); } });
    for (const c of cols) {
      const x = c.get(v);
      const td = el("td", { class: c.key === "status" ? statusClass(x) : c.num ? "num" : null, "data-key": c.key,
        "data-value": typeof x === "number" ? String(x) : null, text: cellText(c, x) });
      if (c.key === "status" && v.message) td.title = v.message;
      tr.append(td);
    }
    tb.append(tr);
  }
  if (focusRow !== null) { const r = tb.querySelector(`tr[data-id="${focusRow}"]`); if (r) r.focus(); }
  const s = state.sweeps.get(state.selected);
  $("#table-count").textContent = `${rows.length} of ${state.variants.length} variants shown${rows.length > MAX_ROWS ? ` (first ${MAX_ROWS} rows; the downloads have all)` : ""}${s && s.total ? `; sweep has ${s.total}` : ""}`;
}

// ---- colour and axes helpers
const VIRIDIS = ["#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779", "#6ece58", "#b5de2b", "#fde725"];
function colour(t) {
  t = Math.min(1, Math.max(0, t));
  const x = t * (VIRIDIS.length - 1), i = Math.min(VIRIDIS.length - 2, Math.floor(x)), f = x - i;
  const c = (h) => [1, 3, 5].map((k) => parseInt(h.slice(k, k + 2), 16));
  const a = c(VIRIDIS[i]), b = c(VIRIDIS[i + 1]);
  return `rgb(${a.map((v, k) => Math.round(v + (b[k] - v) * f)).join(",")})`;
}
// Ticks as src/plot.rs draws them: [{v, label}], label "" for a minor tick.
// Linear: steps 1, 2, 2.5, 5 x 10^n, zero exactly "0" (never -1.11e-16).
function niceTicks(lo, hi, n = 5) {
  if (!(hi > lo)) return [{ v: lo, label: fmt(lo, 3) }];
  const raw = (hi - lo) / n, mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((st) => st >= raw * (1 - 1e-9)) || 10 * mag;
  const out = [];
  const e = Math.floor(Math.log10(step) + 1e-9);
  const dec = Math.abs(step / 10 ** e - 2.5) < 1e-6 ? Math.max(0, 1 - e) : Math.max(0, -e); // 0.25, 2.5, 250
  const big = Math.max(Math.abs(lo), Math.abs(hi));
  for (let k = Math.ceil(lo / step - 1e-9); k <= Math.floor(hi / step + 1e-9) && out.length < 100; k++) {
    const v = k * step;
    out.push({ v, label: k === 0 ? "0" : big >= 1e5 || big < 1e-3 ? fmt(v, 3) : v.toFixed(dec) });
  }
  return out;
}
// Log: decades (2..9 as minor ticks), else 1-2-5, else 1..9, else linear: at least 3 labels.
function logTicks(lo, hi) {
  const e0 = Math.floor(Math.log10(lo)), e1 = Math.ceil(Math.log10(hi));
  const inside = (v) => v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9);
  const every = Math.max(1, Math.ceil(Math.log10(hi / lo) / 8));
  const withM = (mults, labelled) => {
    const out = [];
    for (let e = e0; e <= e1; e++) for (const m of mults) {
      const v = Number((m * 10 ** e).toPrecision(12));
      if (inside(v)) out.push({ v, label: labelled && (m !== 1 || ((e % every) + every) % every === 0) ? fmt(v, 3) : "" });
    }
    return out;
  };
  const count = (t) => t.filter((x) => x.label).length;
  const dec = withM([1], true);
  if (count(dec) >= 3) return Math.log10(hi / lo) <= 8 ? dec.concat(withM([2, 3, 4, 5, 6, 7, 8, 9], false)) : dec;
  const ots = withM([1, 2, 5], true);
  if (count(ots) >= 3) return ots.concat(withM([3, 4, 6, 7, 8, 9], false));
  const all = withM([1, 2, 3, 4, 5, 6, 7, 8, 9], true);
  if (count(all) >= 3) return all;
  for (let n = 4; n <= 12; n++) { const t = niceTicks(lo, hi, n).filter((x) => x.v > 0); if (t.length >= 3 || n === 12) return t; }
  return [];
}
const tip = () => $("#tip");
function showTip(evt, text) {
  const t = tip();
  t.textContent = text;
  t.hidden = false;
  let x = 14, y = 14;
  if (evt && evt.clientX !== undefined) { x += evt.clientX; y += evt.clientY; }
  else if (evt && evt.target && evt.target.getBoundingClientRect) { const r = evt.target.getBoundingClientRect(); x += r.right; y += r.top; }
  t.style.left = `${Math.min(x, window.innerWidth - 260)}px`;
  t.style.top = `${Math.min(y, window.innerHeight - 60)}px`;
}
const hideTip = () => { tip().hidden = true; };

// Drawing width in SVG units: the figure's CSS width on narrow screens (so 11 px text
// stays 11 px on a phone), 520 otherwise (scaled up on wide ones).
function figWidth(s) {
  const w = (s.parentElement && s.parentElement.clientWidth) || 520;
  return Math.round(Math.min(520, Math.max(330, w)));
}

// ---- clearance x viscosity maps (any two numeric axes), heatmaps in SVG
function numericAxes() {
  return axesOf().filter((p) => state.variants.some((v) => isNum((v.params || {})[p])));
}
function axisValues(p) {
  return [...new Set(state.variants.map((v) => (v.params || {})[p]).filter(isNum))].sort((a, b) => a - b);
}
function fillSelect(sel, items, keep) {
  const cur = sel.value;
  sel.innerHTML = "";
  for (const [value, text] of items) sel.append(el("option", { value, text }));
  if (keep && items.some(([v]) => v === cur)) sel.value = cur;
}
function renderMaps() {
  const axes = numericAxes();
  const xs = $("#map-x"), ys = $("#map-y");
  const holder = $("#maps");
  holder.innerHTML = "";
  const isRotorLike = state.variants.length && axes.length >= 1;
  $("#maps-controls").hidden = !isRotorLike;
  $("#curves-controls").hidden = !isRotorLike;
  $("#curves-fig").hidden = !isRotorLike;
  if (!isRotorLike) { $("#maps-note").textContent = state.variants.length ? "No numeric axes to map." : "No finished variants yet."; return; }
  fillSelect(xs, axes.map((p) => [p, pathLabel(p)]), true);
  fillSelect(ys, [["", "(none)"], ...axes.map((p) => [p, pathLabel(p)])], true);
  if (!xs.value) xs.value = axes.find((p) => /clearance/.test(p)) || axes[0];
  if (ys.value === "" && !ys.dataset.touched) ys.value = axes.find((p) => p !== xs.value && /viscosity/.test(p)) || axes.find((p) => p !== xs.value) || "";
  if (ys.value === xs.value) ys.value = axes.find((p) => p !== xs.value) || "";
  // Other axes are held at a chosen value.
  const fixed = $("#map-fixed");
  const others = axesOf().filter((p) => p !== xs.value && p !== ys.value);
  const prev = Object.fromEntries([...fixed.querySelectorAll("select")].map((s) => [s.dataset.path, s.value]));
  fixed.innerHTML = "";
  for (const p of others) {
    const vals = [...new Set(state.variants.map((v) => JSON.stringify((v.params || {})[p])))].sort();
    const id = `fix-${p.replace(/[^a-z0-9]/gi, "_")}`;
    const sel = el("select", { id, "data-path": p, onchange: () => { renderMaps(); renderCurves(); } });
    for (const j of vals) sel.append(el("option", { value: j, text: cellText({ u: unitOfPath(p) }, JSON.parse(j)) }));
    if (prev[p] && vals.includes(prev[p])) sel.value = prev[p];
    fixed.append(el("label", { for: id, text: `${pathLabel(p)} =` }), sel);
  }
  const act = document.activeElement;
  const focusCell = act && act.closest && act.closest("#maps rect.cell") ? [act.closest("svg").id, act.dataset.id] : null;
  const quantities = QUANTITIES.filter((q) => q.map && state.variants.some((v) => isNum(q.get(v))));
  $("#maps-note").textContent = `Hover or focus a cell to read it; click (or Enter) opens that variant's orbit. Colour scale logarithmic where the values span more than a factor 20.`;
  for (const q of quantities) {
    const fig = el("figure");
    const s = svg("svg", { role: "img", "aria-label": `${q.label} map`, id: `map-${q.key}` });
    fig.append(s, el("figcaption", { text: `${q.label}${q.u.unit ? ` (${q.u.unit})` : ""}: ${q.title}` }));
    holder.append(fig);
    drawHeatmap(s, q, xs.value, ys.value);
  }
  if (focusCell) { const c = document.querySelector(`#${focusCell[0]} rect.cell[data-id="${focusCell[1]}"]`); if (c) c.focus(); }
}
function matchesFixed(v) {
  for (const sel of $("#map-fixed").querySelectorAll("select")) {
    if (JSON.stringify((v.params || {})[sel.dataset.path]) !== sel.value) return false;
  }
  return true;
}
function drawHeatmap(s, q, px, py) {
  const xv = axisValues(px), yv = py ? axisValues(py) : [null];
  const cell = new Map();
  for (const v of state.variants) {
    if (!matchesFixed(v)) continue;
    const p = v.params || {};
    cell.set(`${p[px]}|${py ? p[py] : null}`, v);
  }
  const vals = [...cell.values()].map((v) => q.get(v)).filter(isNum);
  const lo = Math.min(...vals), hi = Math.max(...vals);
  const logScale = lo > 0 && hi / lo > 20;
  const norm = (x) => (hi === lo ? 0.5 : logScale ? Math.log(x / lo) / Math.log(hi / lo) : (x - lo) / (hi - lo));
  const W = figWidth(s), H = 330, ml = 78, mr = 86, mt = 26, mb = 52;
  const cw = (W - ml - mr) / xv.length, ch = (H - mt - mb) / yv.length;
  s.setAttribute("viewBox", `0 0 ${W} ${H}`);
  s.append(svg("text", { x: ml, y: 16, class: "title" }, `${q.label}${q.u.unit ? ` (${q.u.unit})` : ""}`));
  const ux = unitOfPath(px), uy = py ? unitOfPath(py) : UNITS.one;
  xv.forEach((x, i) => {
    yv.forEach((y, j) => {
      const v = cell.get(`${x}|${y}`);
      const val = v ? q.get(v) : null;
      const r = svg("rect", { x: ml + i * cw, y: mt + (yv.length - 1 - j) * ch, width: cw, height: ch,
        class: `cell${isNum(val) ? "" : " missing"}${v && v.id === state.variantId ? " sel" : ""}`,
        fill: isNum(val) ? colour(norm(val)) : "#eee", "data-id": v ? v.id : null, "data-value": isNum(val) ? String(val) : null });
      const label = `${pathLabel(px)} ${fmt(x * ux.scale)}${ux.unit ? " " + ux.unit : ""}${py ? `, ${pathLabel(py)} ${fmt(y * uy.scale)}${uy.unit ? " " + uy.unit : ""}` : ""}: ${q.label} ${v ? cellText(q, val) : "not run yet"}${q.u.unit && isNum(val) ? " " + q.u.unit : ""}${v ? ` (variant ${v.id}, ${v.status})` : ""}`;
      r.append(svg("title", {}, label));
      if (v) {
        r.setAttribute("tabindex", "0");
        r.setAttribute("role", "button");
        r.setAttribute("aria-label", label);
        r.addEventListener("click", () => showVariant(v.id, true));
        r.addEventListener("keydown", (e) => { if (e.key === "Enter" || e.key === " ") { e.preventDefault(); showVariant(v.id, true); } });
        r.addEventListener("focus", (e) => showTip(e, label));
        r.addEventListener("blur", hideTip);
      }
      r.addEventListener("mousemove", (e) => showTip(e, label));
      r.addEventListener("mouseleave", hideTip);
      s.append(r);
      // The value in the cell where it fits (dark text on the light end of the scale).
      if (isNum(val) && cw >= 44 && ch >= 16)
        s.append(svg("text", { x: ml + (i + 0.5) * cw, y: mt + (yv.length - 1 - j + 0.5) * ch + 4, "text-anchor": "middle",
          class: norm(val) > 0.6 ? "cv dark" : "cv light" }, fmt(val * q.u.scale, 3)));
    });
  });
  // axis labels: every value when few, else every k-th
  const stepX = Math.ceil(xv.length / 8), stepY = Math.ceil(yv.length / 10);
  xv.forEach((x, i) => { if (i % stepX === 0) s.append(svg("text", { x: ml + (i + 0.5) * cw, y: H - mb + 14, "text-anchor": "middle" }, fmt(x * ux.scale, 3))); });
  if (py) yv.forEach((y, j) => { if (j % stepY === 0) s.append(svg("text", { x: ml - 4, y: mt + (yv.length - 1 - j + 0.5) * ch + 4, "text-anchor": "end" }, fmt(y * uy.scale, 3))); });
  s.append(svg("text", { x: ml + (W - ml - mr) / 2, y: H - 12, "text-anchor": "middle" }, `${pathLabel(px)}${ux.unit ? ` (${ux.unit})` : ""}`));
  if (py) s.append(svg("text", { x: 14, y: mt + (H - mt - mb) / 2, "text-anchor": "middle", transform: `rotate(-90 14 ${mt + (H - mt - mb) / 2})` }, `${pathLabel(py)}${uy.unit ? ` (${uy.unit})` : ""}`));
  // colour bar
  const bx = W - mr + 14, bh = H - mt - mb, N = 40;
  for (let k = 0; k < N; k++) s.append(svg("rect", { x: bx, y: mt + bh - ((k + 1) * bh) / N, width: 14, height: bh / N + 0.5, fill: colour((k + 0.5) / N) }));
  if (vals.length) {
    let ticks = (logScale ? logTicks(lo, hi) : niceTicks(lo, hi, 4)).filter((t) => t.label).map((t) => t.v);
    if (ticks.filter((t) => t >= lo && t <= hi).length < 3) ticks = [lo, hi]; // a narrow range: label its ends
    for (const t of ticks) {
      const yy = mt + bh - norm(t) * bh;
      if (yy < mt - 1 || yy > mt + bh + 1) continue;
      s.append(svg("line", { x1: bx + 14, x2: bx + 18, y1: yy, y2: yy, stroke: "#444" }));
      s.append(svg("text", { x: bx + 20, y: yy + 4 }, fmt(t * q.u.scale, 3)));
    }
  }
  addFigureTools(s);
}

// ---- line charts (curves, Fig. 4, orbits, time histories)
// The palette and line patterns of src/plot.rs (Okabe-Ito without yellow; patterns
// after the seventh curve), so the page and the server's SVGs look alike.
const PALETTE = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#56B4E9", "#E69F00", "#000000"];
const DASHES = [null, "7 4", "9 3 2 3", "2 3"];
const textW = (t, px = 12) => String(t).length * 0.6 * px; // DejaVu-like average advance
// Whether segment a-b meets rectangle r (Liang-Barsky).
function meetsRect(r, a, b) {
  const dx = b[0] - a[0], dy = b[1] - a[1];
  let t0 = 0, t1 = 1;
  for (const [p, q] of [[-dx, a[0] - r.x], [dx, r.x + r.w - a[0]], [-dy, a[1] - r.y], [dy, r.y + r.h - a[1]]]) {
    if (p === 0) { if (q < 0) return false; } else {
      const t = q / p;
      if (p < 0) t0 = Math.max(t0, t); else t1 = Math.min(t1, t);
      if (t0 > t1) return false;
    }
  }
  return true;
}
// series: [{name, xs, ys, color?, dash?}]; opts: {title, xLabel, yLabel, xLog, yLog, equal, circle}.
// Drag a rectangle to zoom (the axes re-tick), double-click or "Reset zoom" to go back.
function lineChart(s, series, opts) {
  s.innerHTML = "";
  s._redraw = () => lineChart(s, series, opts);
  const W = figWidth(s), H = opts.equal ? 460 : 330;
  s.setAttribute("viewBox", `0 0 ${W} ${H}`);
  const ok = (x, y) => isNum(x) && isNum(y) && (!opts.xLog || x > 0) && (!opts.yLog || y > 0);
  const pts = series.flatMap((ser) => ser.xs.map((x, i) => [x, ser.ys[i]])).filter(([x, y]) => ok(x, y));
  s.append(svg("text", { x: 70, y: 17, class: "title" }, opts.title || ""));
  addFigureTools(s, { reset: () => { s._zoom = null; s._redraw(); } });
  if (!pts.length) { s.append(svg("text", { x: W / 2, y: H / 2, "text-anchor": "middle" }, "no data")); return; }
  let x0 = Math.min(...pts.map((p) => p[0])), x1 = Math.max(...pts.map((p) => p[0]));
  let y0 = Math.min(...pts.map((p) => p[1])), y1 = Math.max(...pts.map((p) => p[1]));
  if (opts.circle) { x0 = Math.min(x0, -opts.circle); x1 = Math.max(x1, opts.circle); y0 = Math.min(y0, -opts.circle); y1 = Math.max(y1, opts.circle); }
  const pad = (a, b, log) => {
    if (log) { if (a === b) return [a / 1.5, b * 1.5]; const f = Math.max(1.1, (b / a) ** 0.04); return [a / f, b * f]; }
    if (a === b) return [a - (Math.abs(a) || 1) * 0.1, b + (Math.abs(b) || 1) * 0.1];
    const d = (b - a) * 0.04; return [a - d, b + d];
  };
  [x0, x1] = pad(x0, x1, opts.xLog); [y0, y1] = pad(y0, y1, opts.yLog);
  if (s._zoom) ({ x0, x1, y0, y1 } = s._zoom);
  const named = series.filter((ser) => ser.name);
  const legendOn = series.length > 1 ? named.length > 0 : named.length === 1;
  const items = legendOn ? series.map((ser, k) => ({ ser, k })).filter(({ ser }) => ser.name).slice(0, 12) : [];
  const lw = items.length ? Math.max(...items.map(({ ser }) => textW(ser.name))) + 44 : 0, lh = items.length * 15 + 8;
  // The frame for `extra` px kept on the right (an outside legend).
  const frame = (extra) => {
    const ml = 72, mr = 18 + extra, mt = 28, mb = 48;
    const pw = W - ml - mr, ph = H - mt - mb;
    let [a0, a1, b0, b1] = [x0, x1, y0, y1];
    if (opts.equal && !s._zoom) { // same scale on both axes: widen the shorter span
      const k = Math.max((a1 - a0) / pw, (b1 - b0) / ph), cx = (a0 + a1) / 2, cy = (b0 + b1) / 2;
      a0 = cx - (k * pw) / 2; a1 = cx + (k * pw) / 2; b0 = cy - (k * ph) / 2; b1 = cy + (k * ph) / 2;
    }
    const tx = (x) => ml + (opts.xLog ? Math.log(x / a0) / Math.log(a1 / a0) : (x - a0) / (a1 - a0)) * pw;
    const ty = (y) => mt + ph - (opts.yLog ? Math.log(y / b0) / Math.log(b1 / b0) : (y - b0) / (b1 - b0)) * ph;
    const ix = (px) => { const t = (px - ml) / pw; return opts.xLog ? a0 * (a1 / a0) ** t : a0 + t * (a1 - a0); };
    const iy = (py) => { const t = (mt + ph - py) / ph; return opts.yLog ? b0 * (b1 / b0) ** t : b0 + t * (b1 - b0); };
    return { ml, mr, mt, mb, pw, ph, tx, ty, ix, iy, x0: a0, x1: a1, y0: b0, y1: b1 };
  };
  let f = frame(0);
  // Legend: the first free spot inside (corners, then edge middles), else outside right.
  let box = null;
  if (items.length) {
    const segs = [], dots = [];
    for (const ser of series) {
      let prev = null;
      ser.xs.forEach((x, i) => {
        const y = ser.ys[i];
        if (!ok(x, y)) { prev = null; return; }
        const q = [f.tx(x), f.ty(y)];
        if (prev) segs.push([prev, q]); else dots.push(q);
        prev = q;
      });
    }
    if (opts.circle) for (let k = 0; k < 48; k++) {
      const a = (2 * Math.PI * k) / 48, b = (2 * Math.PI * (k + 1)) / 48, r = opts.circle;
      segs.push([[f.tx(r * Math.cos(a)), f.ty(r * Math.sin(a))], [f.tx(r * Math.cos(b)), f.ty(r * Math.sin(b))]]);
    }
    const L = f.ml + 6, R = f.ml + f.pw - lw - 6, T = f.mt + 6, B = f.mt + f.ph - lh - 6;
    const CX = f.ml + (f.pw - lw) / 2, CY = f.mt + (f.ph - lh) / 2;
    for (const [x, y] of [[R, T], [L, T], [R, B], [L, B], [CX, T], [CX, B], [R, CY], [L, CY]]) {
      if (lw + 12 > f.pw || lh + 12 > f.ph) break;
      const g = { x: x - 3, y: y - 3, w: lw + 6, h: lh + 6 };
      if (!segs.some(([a, b]) => meetsRect(g, a, b)) && !dots.some(([a, b]) => a >= g.x - 2 && a <= g.x + g.w + 2 && b >= g.y - 2 && b <= g.y + g.h + 2)) { box = { x, y }; break; }
    }
    if (!box) { f = frame(lw + 10); box = { x: f.ml + f.pw + 8, y: f.mt }; }
  }
  const { ml, mt, pw, ph, tx, ty } = f;
  const grid = svg("g", { class: "grid" }), axis = svg("g", { class: "axis" });
  let lastRight = -Infinity;
  for (const t of opts.xLog ? logTicks(f.x0, f.x1) : niceTicks(f.x0, f.x1, Math.max(3, Math.round(pw / 90)))) {
    grid.append(svg("line", { x1: tx(t.v), x2: tx(t.v), y1: mt, y2: mt + ph, class: t.label ? null : "minor" }));
    axis.append(svg("line", { x1: tx(t.v), x2: tx(t.v), y1: mt + ph, y2: mt + ph + (t.label ? 5 : 3) }));
    const half = textW(t.label) / 2;
    if (t.label && tx(t.v) - half > lastRight + 6) { axis.append(svg("text", { x: tx(t.v), y: mt + ph + 17, "text-anchor": "middle", class: "tick x" }, t.label)); lastRight = tx(t.v) + half; }
  }
  for (const t of opts.yLog ? logTicks(f.y0, f.y1) : niceTicks(f.y0, f.y1, Math.max(3, Math.round(ph / 60)))) {
    grid.append(svg("line", { x1: ml, x2: ml + pw, y1: ty(t.v), y2: ty(t.v), class: t.label ? null : "minor" }));
    axis.append(svg("line", { x1: ml - (t.label ? 5 : 3), x2: ml, y1: ty(t.v), y2: ty(t.v) }));
    if (t.label) axis.append(svg("text", { x: ml - 7, y: ty(t.v) + 4, "text-anchor": "end", class: "tick y" }, t.label));
  }
  axis.append(svg("rect", { x: ml, y: mt, width: pw, height: ph, fill: "none", stroke: "#444" }));
  s.append(grid, axis);
  s.append(svg("text", { x: ml + pw / 2, y: H - 10, "text-anchor": "middle", class: "label" }, opts.xLabel || ""));
  s.append(svg("text", { x: 15, y: mt + ph / 2, "text-anchor": "middle", class: "label", transform: `rotate(-90 15 ${mt + ph / 2})` }, opts.yLabel || ""));
  const clipId = `clip-${s.id || Math.random().toString(36).slice(2)}`;
  s.append(svg("clipPath", { id: clipId }, undefined));
  s.lastChild.append(svg("rect", { x: ml, y: mt, width: pw, height: ph }));
  const body = svg("g", { "clip-path": `url(#${clipId})` });
  s.append(body);
  if (opts.circle) body.append(svg("circle", { cx: tx(0), cy: ty(0), r: Math.abs(tx(opts.circle) - tx(0)), fill: "none", stroke: "#777", "stroke-width": 1.5, "stroke-dasharray": "7 4", class: "guide" }));
  const drawn = [];
  series.forEach((ser, k) => {
    const c = ser.color || PALETTE[k % PALETTE.length];
    const dash = ser.dash !== undefined ? ser.dash : DASHES[Math.floor(k / PALETTE.length) % 4];
    let d = "", pen = false;
    ser.xs.forEach((x, i) => {
      const y = ser.ys[i];
      if (!ok(x, y)) { pen = false; return; }
      d += `${pen ? "L" : "M"}${tx(x).toFixed(1)},${ty(y).toFixed(1)}`;
      pen = true;
      drawn.push({ x, y, name: ser.name, px: tx(x), py: ty(y) });
    });
    body.append(svg("path", { d, fill: "none", stroke: c, "stroke-width": 2, "stroke-linejoin": "round", "stroke-dasharray": dash, class: "series", "data-name": ser.name }));
    if (ser.xs.length <= 40) ser.xs.forEach((x, i) => { const y = ser.ys[i]; if (ok(x, y)) body.append(svg("circle", { cx: tx(x), cy: ty(y), r: 3, fill: c, class: "marker" })); });
  });
  if (box) {
    s.append(svg("rect", { x: box.x, y: box.y, width: lw, height: lh, class: "legend", fill: "#fff", "fill-opacity": 0.92, stroke: "#b8bec6" }));
    items.forEach(({ ser, k }, i) => {
      const y = box.y + 4 + 15 * (i + 0.5);
      s.append(svg("line", { x1: box.x + 8, x2: box.x + 32, y1: y, y2: y, stroke: ser.color || PALETTE[k % PALETTE.length], "stroke-width": 2,
        "stroke-dasharray": ser.dash !== undefined ? ser.dash : DASHES[Math.floor(k / PALETTE.length) % 4] }));
      s.append(svg("text", { x: box.x + 38, y: y + 4, class: "legend-entry" }, ser.name));
    });
  }
  // hover: the nearest drawn point
  const hover = svg("circle", { r: 4, fill: "none", stroke: "#000", visibility: "hidden" });
  s.append(hover);
  s.onmousemove = (e) => {
    if (s._dragging) return;
    const r = s.getBoundingClientRect();
    const mx = ((e.clientX - r.left) / r.width) * W, my = ((e.clientY - r.top) / r.height) * H;
    let best = null, bd = Infinity;
    for (const p of drawn) { const d = (p.px - mx) ** 2 + (p.py - my) ** 2; if (d < bd) { bd = d; best = p; } }
    if (!best || bd > 900) { hover.setAttribute("visibility", "hidden"); hideTip(); return; }
    hover.setAttribute("cx", best.px); hover.setAttribute("cy", best.py); hover.setAttribute("visibility", "visible");
    showTip(e, `${best.name ? best.name + ": " : ""}${opts.xName || "x"} ${fmt(best.x)}, ${opts.yName || "y"} ${fmt(best.y)}`);
  };
  s.onmouseleave = () => { hover.setAttribute("visibility", "hidden"); hideTip(); };
  s._zoomTo = (a, b, c, d) => { // a viewBox rectangle -> data ranges
    const xa = f.ix(a), xb = f.ix(c), ya = f.iy(d), yb = f.iy(b);
    s._zoom = { x0: Math.min(xa, xb), x1: Math.max(xa, xb), y0: Math.min(ya, yb), y1: Math.max(ya, yb) };
    s._redraw();
  };
  enableDragZoom(s);
}

// ---- zoom and export of every figure
// Drag a rectangle on a figure to zoom into it: line charts re-draw their axes over the
// data in the rectangle (s._zoomTo); other figures (maps, parallel coordinates, the
// server's SVGs) magnify by their viewBox. Double-click (or "Reset zoom") goes back.
function enableDragZoom(s) {
  if (s._dragZoom) return;
  s._dragZoom = true;
  let start = null, box = null;
  const at = (e) => {
    const r = s.getBoundingClientRect(), vb = s.viewBox.baseVal;
    return [vb.x + ((e.clientX - r.left) / r.width) * vb.width, vb.y + ((e.clientY - r.top) / r.height) * vb.height];
  };
  s.addEventListener("pointerdown", (e) => {
    if (e.button !== 0 || !s.viewBox.baseVal || !s.viewBox.baseVal.width) return;
    start = at(e); s._dragging = false;
  });
  s.addEventListener("pointermove", (e) => {
    if (!start) return;
    const p = at(e);
    if (!s._dragging && Math.hypot(p[0] - start[0], p[1] - start[1]) < 6) return;
    if (!s._dragging) { s._dragging = true; s.setPointerCapture(e.pointerId); box = svg("rect", { class: "zoombox" }); s.append(box); hideTip(); }
    box.setAttribute("x", Math.min(p[0], start[0])); box.setAttribute("y", Math.min(p[1], start[1]));
    box.setAttribute("width", Math.abs(p[0] - start[0])); box.setAttribute("height", Math.abs(p[1] - start[1]));
  });
  s.addEventListener("pointerup", (e) => {
    const a = start; start = null;
    if (!a || !s._dragging) { s._dragging = false; return; }
    const p = at(e);
    if (box) box.remove();
    box = null;
    // The click that ends a drag must not open a variant.
    const swallow = (ev) => ev.stopPropagation();
    s.addEventListener("click", swallow, { capture: true, once: true });
    setTimeout(() => s.removeEventListener("click", swallow, { capture: true }), 300);
    setTimeout(() => { s._dragging = false; }, 0);
    const [x0, y0, x1, y1] = [Math.min(a[0], p[0]), Math.min(a[1], p[1]), Math.max(a[0], p[0]), Math.max(a[1], p[1])];
    if (x1 - x0 < 8 || y1 - y0 < 8) return;
    if (s._zoomTo) s._zoomTo(x0, y0, x1, y1);
    else zoomViewBox(s, x0, y0, x1, y1);
  });
  s.addEventListener("dblclick", () => resetZoom(s));
}
function zoomViewBox(s, x0, y0, x1, y1) {
  const vb = s.viewBox.baseVal;
  if (!s._vb0) s._vb0 = `${vb.x} ${vb.y} ${vb.width} ${vb.height}`;
  // Keep the figure's aspect: widen the rectangle's shorter side.
  const k = vb.width / vb.height;
  let w = x1 - x0, h = y1 - y0;
  if (w / h > k) h = w / k; else w = h * k;
  const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
  s.setAttribute("viewBox", `${cx - w / 2} ${cy - h / 2} ${w} ${h}`);
  s.classList.add("zoomed");
}
function resetZoom(s) {
  if (s._zoom) { s._zoom = null; if (s._redraw) s._redraw(); }
  if (s._vb0) { s.setAttribute("viewBox", s._vb0); s._vb0 = null; }
  s.classList.remove("zoomed");
}
// Styles an exported SVG needs (the page's CSS does not travel with it).
const FIG_CSS = "text{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;font-size:12px;fill:#222}" +
  ".title{font-size:14px;font-weight:600}.label{font-size:13px}.grid line{stroke:#e4e7eb}.grid line.minor{stroke:#f0f2f4}.axis line{stroke:#444}" +
  "rect.cell{stroke:#fff;stroke-width:.5}rect.cell.missing{fill:#eee}text.cv.light{fill:#fff}text.cv.dark{fill:#111}.pc-line{fill:none}";
function svgText(s) {
  const c = s.cloneNode(true);
  c.setAttribute("xmlns", SVGNS);
  const vb = s.viewBox.baseVal;
  c.setAttribute("width", String(Math.round(vb.width))); c.setAttribute("height", String(Math.round(vb.height)));
  for (const e of c.querySelectorAll(".zoombox")) e.remove();
  const st = document.createElementNS(SVGNS, "style");
  st.textContent = FIG_CSS;
  c.insertBefore(svg("rect", { x: vb.x, y: vb.y, width: vb.width, height: vb.height, fill: "#fff" }), c.firstChild);
  c.insertBefore(st, c.firstChild);
  return `<?xml version="1.0" encoding="UTF-8"?>\n${new XMLSerializer().serializeToString(c)}\n`;
}
function figureName(s) {
  const sw = state.sweeps.get(state.selected);
  const stem = (sw && sw.name ? sw.name : state.selected || "figure").replace(/[^a-z0-9._-]+/gi, "-").slice(0, 40);
  return `${stem}-${(s.id || "figure").replace(/[^a-z0-9_-]+/gi, "-")}`;
}
function exportPng(s) {
  const vb = s.viewBox.baseVal, k = 2; // twice the drawing size: sharp in a report
  const url = URL.createObjectURL(new Blob([svgText(s)], { type: "image/svg+xml" }));
  const img = new Image();
  img.onload = () => {
    const cv = document.createElement("canvas");
    cv.width = Math.round(vb.width * k); cv.height = Math.round(vb.height * k);
    const g = cv.getContext("2d");
    g.fillStyle = "#fff"; g.fillRect(0, 0, cv.width, cv.height);
    g.drawImage(img, 0, 0, cv.width, cv.height);
    URL.revokeObjectURL(url);
    cv.toBlob((blob) => saveBlobObj(`${figureName(s)}.png`, blob));
  };
  img.src = url;
}
// Buttons under a figure: reset zoom, SVG, PNG (once per figure element).
function addFigureTools(s, opts = {}) {
  enableDragZoom(s);
  const fig = s.closest("figure");
  if (!fig || fig.querySelector(":scope > .figtools")) return;
  const label = s.getAttribute("aria-label") || s.id || "figure";
  const bar = el("div", { class: "figtools" },
    el("span", { class: "note", text: "drag to zoom" }),
    el("button", { type: "button", class: "zoom-reset", text: "Reset zoom", "aria-label": `reset zoom of ${label}`, onclick: () => resetZoom(s) }),
    el("button", { type: "button", class: "export-svg", text: "SVG", "aria-label": `save ${label} as SVG`, onclick: () => saveBlob(`${figureName(s)}.svg`, svgText(s), "image/svg+xml") }),
    el("button", { type: "button", class: "export-png", text: "PNG", "aria-label": `save ${label} as PNG`, onclick: () => exportPng(s) }));
  void opts;
  fig.append(bar);
}
function renderCurves() {
  const sel = $("#curve-q");
  const quantities = QUANTITIES.filter((q) => q.map && state.variants.some((v) => isNum(q.get(v))));
  fillSelect(sel, quantities.map((q) => [q.key, q.label]), true);
  if (!sel.value && quantities.find((q) => q.key === "friction")) sel.value = "friction";
  const q = QUANTITIES.find((x) => x.key === sel.value);
  const px = $("#map-x").value, py = $("#map-y").value;
  if (!q || !px) return;
  const ux = unitOfPath(px), uy = py ? unitOfPath(py) : null;
  const groups = new Map();
  for (const v of state.variants) {
    if (!matchesFixed(v)) continue;
    const key = py ? v.params[py] : "";
    if (!groups.has(key)) groups.set(key, []);
    groups.get(key).push(v);
  }
  const series = [...groups.entries()].sort((a, b) => a[0] - b[0]).map(([key, vs]) => {
    vs.sort((a, b) => a.params[px] - b.params[px]);
    return { name: py ? `${pathLabel(py)} ${fmt(key * uy.scale, 3)}${uy.unit ? " " + uy.unit : ""}` : "",
      xs: vs.map((v) => v.params[px] * ux.scale), ys: vs.map((v) => { const y = q.get(v); return isNum(y) ? y * q.u.scale : null; }) };
  });
  const allPos = (arr) => arr.every((x) => !isNum(x) || x > 0);
  lineChart($("#curves"), series, { title: `${q.label} against ${pathLabel(px)}`, xLabel: `${pathLabel(px)}${ux.unit ? ` (${ux.unit})` : ""}`,
    yLabel: `${q.label}${q.u.unit ? ` (${q.u.unit})` : ""}`, xLog: allPos(series.flatMap((s) => s.xs)), yLog: allPos(series.flatMap((s) => s.ys)),
    xName: pathLabel(px), yName: q.label });
  $("#curves-cap").textContent = `${q.title}; log axes where all values are positive.`;
}
function drawFig4(result) {
  const series = result.curves.map((c) => ({
    name: `ω ${fmt(c.speed_rad_s ?? c.speed ?? c.omega, 3)} rad/s`,
    xs: c.points.map((p) => p.load_n), ys: c.points.map((p) => p.friction_coefficient) }));
  lineChart($("#fig4"), series, { title: "Friction coefficient (Fig. 4)", xLabel: "load (N)", yLabel: "friction coefficient f", xLog: true, yLog: true, xName: "load", yName: "f" });
}
let plotsFor = null;
async function loadServerPlots(id) {
  if (plotsFor === id) return; // once per selected sweep (several reloads may ask at once)
  plotsFor = id;
  const holder = $("#server-plots");
  holder.innerHTML = "";
  const r = await api("GET", `/api/sweeps/${encodeURIComponent(id)}/plots`);
  if (!r.ok || state.selected !== id) { if (plotsFor === id) plotsFor = null; return; }
  const names = (Array.isArray(r.data) ? r.data : r.data.plots || []).map((p) => (typeof p === "string" ? p : p.name)).filter(Boolean);
  if (!names.length) return;
  holder.append(el("p", { class: "note", text: "Plots the spec asks for, as `run` writes them:" }));
  for (const name of names) {
    const rr = await api("GET", `/api/sweeps/${encodeURIComponent(id)}/plots/${encodeURIComponent(name)}`);
    if (!rr.ok || state.selected !== id || plotsFor !== id) continue;
    // Inline (not an <img>): the same zoom and export as the page's own figures.
    const doc = new DOMParser().parseFromString(rr.text, "image/svg+xml");
    const root = doc.documentElement;
    if (!root || root.nodeName !== "svg") continue;
    const s = document.importNode(root, true);
    s.removeAttribute("width"); s.removeAttribute("height");
    s.id = `server-${name.replace(/[^a-z0-9_-]+/gi, "-")}`;
    s.setAttribute("role", "img"); s.setAttribute("aria-label", `server plot ${name}`);
    // Each SVG names its clip path "plot-area": unique ids on one page.
    for (const c of s.querySelectorAll("clipPath#plot-area")) c.id = `${s.id}-clip`;
    for (const g of s.querySelectorAll("[clip-path]")) g.setAttribute("clip-path", `url(#${s.id}-clip)`);
    const fig = el("figure", { class: "server-plot" }, s, el("figcaption", { text: name }));
    holder.append(fig);
    addFigureTools(s);
  }
}

// ---- one variant: orbit and time histories
function clearanceOf(v, k) {
  const p = v.params || {};
  for (const key of [`bearings[${k}].clearance`, "bearings[*].clearance"]) if (isNum(p[key])) return p[key];
  const base = state.spec && state.spec.base;
  return base && base.bearings && base.bearings[k] ? base.bearings[k].clearance : null;
}
// Full-resolution series of variants ("sweep/variant" -> series, "loading" or {error}):
// the records keep `reductions.points` samples; the server simulates the variant again
// for the orbit (GET /api/sweeps/{id}/variants/{v}/series).
const FULL_POINTS = 4000;
const fullSeries = new Map();
function isRotorSweep() {
  const k = state.spec && state.spec.kind;
  return !k || k === "rotor";
}
function seriesOf(v) {
  const f = fullSeries.get(`${state.selected}/${v.id}`);
  return f && f.t ? { s: f, full: true } : { s: v.series, full: false };
}
async function loadFullSeries(v) {
  const sweep = state.selected, key = `${sweep}/${v.id}`;
  if (fullSeries.has(key) || !isRotorSweep() || v.status === "invalid") return;
  fullSeries.set(key, "loading");
  const r = await api("GET", `/api/sweeps/${encodeURIComponent(sweep)}/variants/${v.id}/series?points=${FULL_POINTS}`);
  fullSeries.set(key, r.ok && r.data && r.data.series ? r.data.series : { error: (r.error && r.error.message) || "no series" });
  if (state.selected === sweep && state.variantId === v.id) showVariant(v.id, false);
}
function showVariant(id, user) {
  const v = state.variants.find((x) => x.id === Number(id));
  if (!v) { $("#variant-note").textContent = `variant ${id} is not finished (or not in this sweep)`; return; }
  if (state.variantId !== v.id) { resetZoom($("#orbit")); resetZoom($("#history")); }
  state.variantId = v.id;
  writeHash();
  for (const tr of document.querySelectorAll("#variants tbody tr")) tr.classList.toggle("sel", Number(tr.dataset.id) === v.id);
  for (const r of document.querySelectorAll("#maps rect.cell")) r.classList.toggle("sel", Number(r.dataset.id) === v.id);
  for (const l of document.querySelectorAll("#parallel .pc-line")) l.classList.toggle("sel", Number(l.dataset.id) === v.id);
  $("#variant-id").textContent = `${v.id} (${v.status})`;
  $("#variant-pick").value = v.id;
  $("#variant-params").textContent = Object.entries(v.params || {}).map(([k, x]) => `${pathLabel(k)} = ${withUnit(x, unitOfPath(k))}`).join("\n") + (v.message ? `\n${v.message}` : "");
  loadFullSeries(v);
  const { s, full } = seriesOf(v);
  const bsel = $("#orbit-bearing"), hsel = $("#hist-series");
  const pending = fullSeries.get(`${state.selected}/${v.id}`);
  if (!s) {
    $("#variant-note").textContent = pending === "loading" ? "Simulating this variant again for its time series…"
      : isRotorSweep() ? `No time series: ${pending && pending.error ? pending.error : "this sweep kept none"}.` : "This kind of sweep has no time series.";
    $("#orbit").innerHTML = ""; $("#history").innerHTML = "";
    bsel.innerHTML = ""; hsel.innerHTML = "";
    $("#orbit-cap").textContent = ""; $("#history-cap").textContent = "";
  } else {
    $("#variant-note").textContent = full ? "" : pending === "loading" ? "Showing the kept samples; loading the full-resolution series…" : "";
    const nb = (s.bearings || []).length;
    const orbitItems = [];
    for (let k = 0; k < nb; k++) if (s.bearings[k].xi) orbitItems.push([`b${k}`, `bearing ${k + 1} journal (face z = 0)`]);
    if (s.x_g) orbitItems.push(["g", "centre of mass G"]);
    fillSelect(bsel, orbitItems, true);
    const hist = [];
    for (const [key, arr] of Object.entries(s)) if (key !== "t" && key !== "bearings" && Array.isArray(arr)) hist.push([key, key]);
    for (let k = 0; k < nb; k++) for (const [key, arr] of Object.entries(s.bearings[k])) if (Array.isArray(arr)) hist.push([`bearings[${k}].${key}`, `bearing ${k + 1} ${key}`]);
    fillSelect(hsel, hist, true);
    drawOrbit(v); drawHistory(v);
  }
  if (user) $("#variant-h").scrollIntoView({ block: "start", behavior: "smooth" });
}
function samplesNote(full, n) {
  return full ? `full resolution: ${n} samples (the variant simulated again)` : `${n} kept samples (the spec's reductions.points)`;
}
function drawOrbit(v) {
  const { s, full } = seriesOf(v), which = $("#orbit-bearing").value;
  if (!which || !s) { $("#orbit").innerHTML = ""; return; }
  let xs, ys, circle = null, name;
  if (which === "g") { xs = s.x_g; ys = s.y_g; name = "G"; }
  else {
    const k = Number(which.slice(1));
    xs = s.bearings[k].xi; ys = s.bearings[k].yi; name = `bearing ${k + 1}`;
    const c = clearanceOf(v, k);
    if (isNum(c)) circle = c * 1e6;
  }
  const um = (a) => (a || []).map((x) => (isNum(x) ? x * 1e6 : null));
  const o = $("#orbit");
  o.dataset.full = full ? "1" : "0";
  lineChart(o, [{ name: "", xs: um(xs), ys: um(ys) }], { title: `Orbit of ${name}, variant ${v.id}`, xLabel: "x (µm)", yLabel: "y (µm)", equal: true, circle, xName: "x µm", yName: "y µm" });
  $("#orbit-cap").textContent = `${name} in the bearing frame over the kept span${circle ? "; dashed: the clearance circle" : ""}; ${samplesNote(full, (xs || []).length)}.`;
}
function seriesUnit(key) {
  if (/(^|\.)(x_g|y_g|xi|yi|xj|yj|h_min)$/.test(key)) return UNITS.m_um;
  if (/(^|\.)(wx|wy)$/.test(key)) return UNITS.n;
  if (/(^|\.)mz$/.test(key)) return UNITS.nm;
  if (/(^|\.)spin$/.test(key)) return UNITS.rads;
  return UNITS.one;
}
function drawHistory(v) {
  const key = $("#hist-series").value, { s, full } = seriesOf(v);
  if (!key || !s) { $("#history").innerHTML = ""; return; }
  const ys = getPath(s, key) || [];
  const u = seriesUnit(key);
  lineChart($("#history"), [{ name: "", xs: s.t || ys.map((_, i) => i), ys: ys.map((y) => (isNum(y) ? y * u.scale : null)) }],
    { title: `${key}, variant ${v.id}`, xLabel: s.t ? "t (s)" : "sample", yLabel: `${key}${u.unit ? ` (${u.unit})` : ""}`, xName: "t", yName: key });
  $("#history-cap").textContent = `Time history of ${key}; ${samplesNote(full, ys.length)}.`;
}

// ---- parallel coordinates: every variant a line across its swept parameters and the
// chosen quantity (coloured by it), for sweeps with more than two numeric axes.
function renderParallel() {
  const fig = $("#parallel-fig");
  const axes = numericAxes();
  const q = QUANTITIES.find((x) => x.key === $("#curve-q").value);
  if (axes.length <= 2 || !q || !state.variants.length) { fig.hidden = true; return; }
  fig.hidden = false;
  const s = $("#parallel");
  s.innerHTML = "";
  const W = Math.round(Math.min(1100, Math.max(330, (s.parentElement && s.parentElement.clientWidth) || 800))), H = 360;
  const mt = 62, mb = 40, ml = 40, mr = 70;
  s.setAttribute("viewBox", `0 0 ${W} ${H}`);
  s.append(svg("text", { x: ml, y: 17, class: "title" }, `${q.label} over the ${axes.length} swept parameters`));
  const cols = axes.map((p) => ({ label: pathLabel(p), u: unitOfPath(p), get: (v) => (v.params || {})[p] }))
    .concat([{ label: q.label, u: q.u, get: (v) => q.get(v), quantity: true }]);
  for (const c of cols) {
    const vals = state.variants.map(c.get).filter(isNum);
    c.lo = Math.min(...vals); c.hi = Math.max(...vals);
    c.log = c.lo > 0 && c.hi / c.lo > 20;
    c.norm = (x) => (c.hi === c.lo ? 0.5 : c.log ? Math.log(x / c.lo) / Math.log(c.hi / c.lo) : (x - c.lo) / (c.hi - c.lo));
  }
  const X = (i) => ml + (i * (W - ml - mr)) / (cols.length - 1);
  const Y = (t) => mt + (1 - t) * (H - mt - mb);
  const qc = cols[cols.length - 1];
  const lines = svg("g", { class: "pc-lines" });
  s.append(lines);
  const ordered = [...state.variants].sort((a, b) => (isNum(qc.get(a)) ? 1 : 0) - (isNum(qc.get(b)) ? 1 : 0));
  for (const v of ordered) {
    const qv = qc.get(v);
    const pts = cols.map((c, i) => { const x = c.get(v); return isNum(x) ? `${X(i).toFixed(1)},${Y(c.norm(x)).toFixed(1)}` : null; }).filter(Boolean);
    const label = `variant ${v.id}: ${cols.map((c) => `${c.label} ${withUnit(c.get(v), c.u)}`).join(", ")}`;
    const line = svg("polyline", { points: pts.join(" "), class: `pc-line${v.id === state.variantId ? " sel" : ""}`, "data-id": v.id,
      stroke: isNum(qv) ? colour(0.85 * qc.norm(qv)) : "#bbb", "stroke-dasharray": isNum(qv) ? null : "3 3" }); // viridis short of its yellow end
    line.append(svg("title", {}, label));
    line.addEventListener("click", () => showVariant(v.id, true));
    line.addEventListener("mousemove", (e) => showTip(e, label));
    line.addEventListener("mouseleave", hideTip);
    lines.append(line);
  }
  cols.forEach((c, i) => {
    const x = X(i);
    s.append(svg("line", { x1: x, x2: x, y1: mt, y2: H - mb, stroke: "#444" }));
    s.append(svg("text", { x, y: mt - 12, "text-anchor": i === 0 ? "start" : i === cols.length - 1 ? "end" : "middle", class: c.quantity ? "label strong" : "label" },
      `${c.label}${c.u.unit ? ` (${c.u.unit})` : ""}`));
    const ticks = (c.log ? logTicks(c.lo, c.hi) : niceTicks(c.lo, c.hi, 4)).filter((t) => t.label && t.v >= c.lo - 1e-12 * Math.abs(c.lo) && t.v <= c.hi + 1e-12 * Math.abs(c.hi));
    const shown = ticks.length >= 2 ? ticks.map((t) => t.v) : [c.lo, c.hi];
    for (const t of shown) {
      const y = Y(c.norm(t));
      s.append(svg("line", { x1: x - 4, x2: x, y1: y, y2: y, stroke: "#444" }));
      s.append(svg("text", { x: x - 6, y: y + 4, "text-anchor": "end", class: "tick" }, fmt(t * c.u.scale, 3)));
    }
  });
  addFigureTools(s);
  $("#parallel-cap").textContent = `One line per variant through its swept parameters to ${q.label}, coloured by it (dashed grey: no value). Hover to read, click to open a variant; "Curves of" picks the quantity.`;
}

// ---------------------------------------------------------------- downloads
async function download(kind) {
  const id = state.selected;
  if (!id) return;
  const s = state.sweeps.get(id);
  const stem = (s && s.name ? s.name : id).replace(/[^a-z0-9._-]+/gi, "-").slice(0, 60);
  if (kind === "csv") {
    const r = await api("GET", `/api/sweeps/${encodeURIComponent(id)}/variants?format=csv`);
    if (r.ok) saveBlob(`${stem}.csv`, r.text, "text/csv"); else alert(r.error.message);
  } else if (kind === "jsonl") {
    saveBlob(`${stem}-variants.json`, JSON.stringify(state.variants), "application/json");
  } else {
    const r = await api("GET", `/api/sweeps/${encodeURIComponent(id)}/result`);
    if (r.ok) saveBlob(`${stem}-result.json`, r.text, "application/json");
    else alert(r.status === 409 ? "result.json exists once the sweep is done" : r.error.message);
  }
}

// ---------------------------------------------------------------- eval panel
const EVAL_BEARING = [["radius", "m"], ["length", "m"], ["clearance", "m"], ["viscosity", "Pa·s"]];
const EVAL_STATE = [["xi", "m"], ["yi", "m"], ["xj", "m"], ["yj", "m"], ["vxi", "m/s"], ["vyi", "m/s"], ["vxj", "m/s"], ["vyj", "m/s"], ["omega", "rad/s"]];
let evalFilled = false;
function evalInput(prefix, name, unit) {
  const id = `eval-${prefix}-${name}`;
  const input = el("input", { id, type: "text", inputmode: "decimal", "data-path": prefix === "b" ? `bearing.${name}` : `states[0].${name}`, "aria-describedby": `${id}-err` });
  return el("label", { for: id }, `${name} (${unit})`, input, el("span", { id: `${id}-err`, class: "fielderr" }));
}
function initEval() {
  const b = $("#eval-bearing"), s = $("#eval-state");
  for (const [n, u] of EVAL_BEARING) b.append(evalInput("b", n, u));
  const conv = el("select", { id: "eval-b-clearance_convention", "data-path": "bearing.clearance_convention" },
    el("option", { value: "paper", text: "paper (δ/2r0)" }), el("option", { value: "vogelpohl", text: "vogelpohl (δ/r0)" }));
  b.append(el("label", { for: "eval-b-clearance_convention" }, "clearance convention", conv));
  for (const [n, u] of EVAL_STATE) s.append(evalInput("s", n, u));
  fillEval({ bearing: { radius: 0.02, length: 0.02, clearance: 0.0003, viscosity: 0.0242 },
    states: [{ xi: 1.5e-4, yi: 0, xj: 1.5e-4, yj: 0, vxi: 0, vyi: 0, vxj: 0, vyj: 0, omega: 100 }] });
  evalFilled = false;
  $("#eval-form").addEventListener("submit", (e) => { e.preventDefault(); runEval(); });
}
function fillEval(input) {
  evalFilled = true;
  for (const [n] of EVAL_BEARING) if (input.bearing && input.bearing[n] !== undefined) $(`#eval-b-${n}`).value = input.bearing[n];
  if (input.bearing && input.bearing.clearance_convention) $("#eval-b-clearance_convention").value = input.bearing.clearance_convention;
  const st = (input.states || [])[0] || {};
  for (const [n] of EVAL_STATE) if (st[n] !== undefined) $(`#eval-s-${n}`).value = st[n];
}
const numOrText = (t) => { const x = Number(t.trim()); return t.trim() !== "" && Number.isFinite(x) ? x : t; };
async function runEval() {
  for (const i of document.querySelectorAll("#eval-form [data-path]")) i.removeAttribute("aria-invalid");
  for (const e of document.querySelectorAll("#eval-form .fielderr")) e.textContent = "";
  $("#eval-error").hidden = true;
  const bearing = {}, st = {};
  for (const [n] of EVAL_BEARING) bearing[n] = numOrText($(`#eval-b-${n}`).value);
  bearing.clearance_convention = $("#eval-b-clearance_convention").value;
  for (const [n] of EVAL_STATE) st[n] = numOrText($(`#eval-s-${n}`).value);
  $("#eval-status").textContent = "evaluating…";
  const r = await api("POST", "/api/eval", { bearing, states: [st] });
  $("#eval-status").textContent = r.ok ? "" : `error ${r.status}`;
  const tb = $("#eval-out tbody");
  tb.innerHTML = "";
  if (!r.ok) { showFieldError(r.error); return; }
  const load = (r.data.loads || [])[0] || {};
  if (load.status && load.status !== "ok") showFieldError({ path: "states[0]", message: `${load.status}: ${load.error || ""}` });
  const rows = [["status", load.status, ""], ["wx", load.wx, "N"], ["wy", load.wy, "N"], ["mx", load.mx, "N·m"], ["my", load.my, "N·m"],
    ["mz", load.mz, "N·m"], ["friction_coefficient", load.friction_coefficient, ""], ["sommerfeld", load.sommerfeld, ""],
    ["h_min", load.h_min, "m"], ["power_loss", load.power_loss, "W"]];
  for (const [k, x, u] of rows)
    tb.append(el("tr", { "data-key": k }, el("th", { scope: "row", text: k }),
      el("td", { class: "num", "data-value": isNum(x) ? String(x) : null, text: isNum(x) ? fmt(x) : x === undefined ? "—" : String(x ?? "—") }),
      el("td", { text: u })));
  const info = [r.data.backend && `backend ${typeof r.data.backend === "object" ? r.data.backend.name || JSON.stringify(r.data.backend) : r.data.backend}`,
    r.data.accuracy && `accuracy ${r.data.accuracy}`].filter(Boolean).join(", ");
  tb.append(el("tr", {}, el("th", { scope: "row", text: "run" }), el("td", { colspan: 2, text: info })));
}
function showFieldError(err) {
  const box = $("#eval-error");
  box.innerHTML = "";
  if (err.path) box.append(el("span", { class: "path", text: err.path }), document.createTextNode(": "));
  box.append(document.createTextNode(err.message));
  box.hidden = false;
  const input = [...document.querySelectorAll("#eval-form [data-path]")].find((i) => err.path && (err.path === i.dataset.path || err.path.startsWith(i.dataset.path + " ")));
  if (input) {
    input.setAttribute("aria-invalid", "true");
    const note = document.getElementById(`${input.id}-err`);
    if (note) note.textContent = err.message;
    input.focus();
  }
}

// ---------------------------------------------------------------- start
function refreshAll() { checkHealth(); loadExamples(); refreshQueue(); }
document.addEventListener("DOMContentLoaded", () => {
  initToken();
  initEval();
  $("#example").addEventListener("change", showExampleDesc);
  $("#example-load").addEventListener("click", loadExample);
  $("#upload").addEventListener("change", async (e) => { const f = e.target.files[0]; if (f) setSpecText(await f.text()); });
  $("#check").addEventListener("click", checkSpec);
  $("#submit").addEventListener("click", submitSpec);
  $("#detail-cancel").addEventListener("click", () => state.selected && cancelSweep(state.selected));
  $("#dl-csv").addEventListener("click", () => download("csv"));
  $("#dl-jsonl").addEventListener("click", () => download("jsonl"));
  $("#dl-result").addEventListener("click", () => download("result"));
  $("#status-filter").addEventListener("change", renderTable);
  $("#map-x").addEventListener("change", () => { renderMaps(); renderCurves(); });
  window.addEventListener("hashchange", followHash);
  $("#map-y").addEventListener("change", () => { $("#map-y").dataset.touched = "1"; renderMaps(); renderCurves(); });
  $("#curve-q").addEventListener("change", () => { renderCurves(); renderParallel(); });
  $("#variant-open").addEventListener("click", () => showVariant($("#variant-pick").value, true));
  $("#variant-pick").addEventListener("keydown", (e) => { if (e.key === "Enter") showVariant($("#variant-pick").value, true); });
  $("#orbit-bearing").addEventListener("change", () => { const v = state.variants.find((x) => x.id === state.variantId); if (v) drawOrbit(v); });
  $("#hist-series").addEventListener("change", () => { const v = state.variants.find((x) => x.id === state.variantId); if (v) drawHistory(v); });
  refreshAll();
  followHash();
  setInterval(refreshQueue, 3000); // the list (other clients' sweeps); live progress comes by SSE
  setInterval(checkHealth, 15000);
  // Figures are drawn for their width: redraw when it changes (phone turned, window resized).
  let resizeTimer = null, lastWidth = window.innerWidth;
  window.addEventListener("resize", () => {
    clearTimeout(resizeTimer);
    resizeTimer = setTimeout(() => {
      if (window.innerWidth !== lastWidth && state.selected) { lastWidth = window.innerWidth; renderDetail(); }
    }, 200);
  });
});
