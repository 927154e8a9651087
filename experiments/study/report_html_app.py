"""The script and style report.html carries inline (report_html.py writes the page around them).

The script reads the page's JSON (`#drt-data`: per study its scene views, the images as base64
float16, the colour map, relMSE's epsilon) and builds one viewer per `div.viewer`: the current image
drawn at its own resolution on a canvas that CSS scales with `image-rendering: pixelated`; radiance x
2^exposure, clipped, sRGB-encoded; or the per-pixel error against the reference (mean over channels
of relative squared error (x - y)^2 / (y^2 + eps), as the studies' relMSE, or of absolute error) on a
log scale shared by every image of the scene, so flipping compares like with like."""

STYLE = r"""
body{font:14px/1.45 system-ui,sans-serif;margin:1.5em auto;max-width:1200px;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}
.note{color:#555;font-size:.92em}
code{background:#f2f2f2;padding:0 .2em;border-radius:3px}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #ddd}figcaption{color:#555;font-size:.9em}
.scroll{overflow-x:auto}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}
td,th{border:1px solid #ddd;padding:.15em .45em;text-align:left;vertical-align:top}
th{background:#f6f6f6}
.viewer{border:2px solid #ddd;border-radius:6px;padding:.6em;margin:1em 0}
.viewer.active{border-color:#4a7ebb}
.vhead{font-size:1.1em;margin-bottom:.3em}.vhead .current{font-family:monospace;margin-left:.6em}
.controls{display:flex;flex-wrap:wrap;gap:1em;align-items:center;margin-bottom:.4em}
.vmain{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}
.port{position:relative;overflow:hidden;background:#303030;cursor:grab;flex:0 0 auto;user-select:none}
.port canvas{position:absolute;left:0;top:0;transform-origin:0 0;image-rendering:pixelated}
.crop{position:absolute;border:1px solid #fff;outline:1px dashed #000;pointer-events:none}
.side{flex:1 1 320px;min-width:300px;max-width:100%}
.picker button{font:12px monospace;padding:.1em .4em;cursor:pointer;background:#fff;border:1px solid #bbb}
.picker button.on{background:#4a7ebb;color:#fff;border-color:#4a7ebb}
.metrics tr.on td{background:#e4eefa}
.metrics td:first-child{white-space:nowrap}
.metrics td:nth-child(n+2){text-align:right;font-family:monospace}
.cbar{margin:.4em 0}.cbar canvas{width:256px;height:14px;display:block;border:1px solid #999}
.cbar .ticks{display:flex;justify-content:space-between;width:258px;font:11px monospace}
.help,.pixel{font-size:.85em;color:#555;margin-top:.3em}.pixel{font-family:monospace;min-height:1.2em}
"""

SCRIPT = r"""
"use strict";
const DATA = JSON.parse(document.getElementById("drt-data").textContent);
const HELP = "Keys: \u2190 \u2192 sample count N, \u2191 \u2193 sampler, 1\u20139 sampler k, 0 reference, " +
  "space flip back to the previous image, E image / relative squared error / absolute error / FLIP, " +
  "+ \u2212 exposure, F fit. Mouse: wheel zooms, drag pans, shift-drag selects the crop the table measures.";
const MODES = {image: "image", relse: "relative squared error", abs: "absolute error", flip: "FLIP (perceptual error)"};

function half(h) {                    // IEEE 754 binary16 -> number
  const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 31, f = h & 1023;
  if (e === 0) return s * f * Math.pow(2, -24);
  if (e === 31) return f ? NaN : s * Infinity;
  return s * (1 + f / 1024) * Math.pow(2, e - 15);
}
const HALF = new Float32Array(65536);
for (let i = 0; i < 65536; i++) HALF[i] = half(i);
const decoded = {};
function pixels(key) {
  if (!decoded[key]) {
    const bin = atob(DATA.images[key]), dv = new DataView(new ArrayBuffer(bin.length));
    for (let i = 0; i < bin.length; i++) dv.setUint8(i, bin.charCodeAt(i));
    const out = new Float32Array(bin.length / 2);
    for (let i = 0; i < out.length; i++) out[i] = HALF[dv.getUint16(2 * i, true)];
    decoded[key] = out;
  }
  return decoded[key];
}
function flipMap(key) {              // the image's HDR-FLIP map, embedded as bytes (value x 255)
  const k = "flip:" + key;
  if (!decoded[k]) {
    const b64 = DATA.flip[key];
    if (!b64) return null;
    const bin = atob(b64), out = new Float32Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i) / 255;
    decoded[k] = out;
  }
  return decoded[k];
}
function srgb(v) {                    // IEC 61966-2-1 encoding of a value clipped to [0, 1]
  v = v > 0 ? (v < 1 ? v : 1) : 0;
  return 255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055);
}
function cmap(t) {                    // t in [0, 1] -> [r, g, b] on the embedded colour map
  const c = DATA.colourmap, x = Math.min(Math.max(t, 0), 1) * (c.length - 1), i = Math.min(Math.floor(x), c.length - 2), f = x - i;
  return [0, 1, 2].map(k => c[i][k] + f * (c[i + 1][k] - c[i][k]));
}
const fmt = v => (v === null || v === undefined || !isFinite(v)) ? "\u2013" :
  (v !== 0 && (Math.abs(v) < 1e-3 || Math.abs(v) >= 1e4) ? v.toExponential(2) : v.toPrecision(3));
function el(tag, attrs, text) {
  const e = document.createElement(tag);
  for (const k in attrs || {}) e.setAttribute(k, attrs[k]);
  if (text !== undefined) e.textContent = text;
  return e;
}

let active = null;
class Viewer {
  constructor(root, v) {
    this.root = root; this.v = v; this.W = v.width; this.H = v.height;
    this.cur = 0; this.prev = 0; this.exposure = 0; this.mode = "image"; this.scales = {};
    this.crop = v.crop.slice();
    this.build(); this.fit(); this.measure(); this.draw();
  }
  build() {
    const r = this.root, v = this.v;
    this.head = el("div", {class: "vhead"}); this.head.append(el("b", {}, v.scene));
    this.label = el("span", {class: "current"}); this.head.append(this.label);
    const ctl = el("div", {class: "controls"});
    const exp = el("label", {}, "Exposure ");
    this.expIn = el("input", {type: "range", min: "-10", max: "10", step: "0.5", value: "0", class: "exposure"});
    this.expOut = el("span", {class: "expval"});
    this.expIn.addEventListener("input", () => this.setExposure(parseFloat(this.expIn.value)));
    exp.append(this.expIn, this.expOut);
    const mode = el("label", {}, "Show ");
    this.modeIn = el("select", {class: "mode"});
    for (const k in MODES) this.modeIn.append(el("option", {value: k}, MODES[k]));
    this.modeIn.addEventListener("change", () => this.setMode(this.modeIn.value));
    mode.append(this.modeIn);
    const fit = el("button", {type: "button"}, "fit"); fit.addEventListener("click", () => this.fit());
    ctl.append(exp, mode, fit);
    const main = el("div", {class: "vmain"});
    this.port = el("div", {class: "port"});
    this.canvas = el("canvas", {class: "img", width: this.W, height: this.H});
    this.ctx = this.canvas.getContext("2d"); this.data = this.ctx.createImageData(this.W, this.H);
    this.cropBox = el("div", {class: "crop"});
    this.port.append(this.canvas, this.cropBox);
    const side = el("div", {class: "side"});
    side.append(this.picker(), this.colourBar(), this.metricsTable());
    main.append(this.port, side);
    this.pixel = el("div", {class: "pixel"}, "\u00a0");
    r.append(this.head, ctl, main, el("div", {class: "help"}, HELP), this.pixel);
    this.mouse();
    r.addEventListener("mouseenter", () => setActive(this));
    r.addEventListener("mousedown", () => setActive(this));
  }
  find(s, n) { return this.v.images.findIndex(e => e.sampler === s && e.spp === n); }
  picker() {
    const t = el("table", {class: "picker"}), v = this.v, head = el("tr");
    this.buttons = [];
    const ref = el("button", {type: "button"}, "0 reference"); ref.addEventListener("click", () => this.show(0));
    this.buttons[0] = ref;
    const th = el("th"); th.append(ref); head.append(th);
    for (const n of v.spp) head.append(el("th", {}, "N=" + n));
    t.append(head);
    v.samplers.forEach((s, k) => {
      const row = el("tr"); row.append(el("td", {}, (k + 1) + " " + s));
      for (const n of v.spp) {
        const td = el("td"), i = this.find(s, n);
        if (i >= 0) {
          const e = v.images[i], b = el("button", {type: "button", title: e.seconds ? fmt(e.seconds) + " s per render" : ""}, "N=" + n);
          b.addEventListener("click", () => this.show(i)); this.buttons[i] = b; td.append(b);
        } else td.textContent = "\u2013";
        row.append(td);
      }
      t.append(row);
    });
    return t;
  }
  colourBar() {
    this.cbar = el("div", {class: "cbar"});
    const c = el("canvas", {width: 256, height: 1}), g = c.getContext("2d"), im = g.createImageData(256, 1);
    for (let i = 0; i < 256; i++) { const [r, gg, b] = cmap(i / 255); im.data.set([r, gg, b, 255], 4 * i); }
    g.putImageData(im, 0, 0);
    this.cbarTitle = el("div"); this.ticks = el("div", {class: "ticks"});
    this.cbar.append(this.cbarTitle, c, this.ticks);
    return this.cbar;
  }
  metricsTable() {
    this.table = el("table", {class: "metrics"});
    const h = el("tr");
    const heads = ["image", "MSE (crop)", "relMSE (crop)", "MSE (whole)", "relMSE (whole)"];
    if (this.v.metric) heads.push(this.v.metric + " (whole)");   // a plugin's metric: Python's number
    heads.push("s per render");
    for (const c of heads) h.append(el("th", {}, c));
    this.cropCaption = el("div", {class: "note"});
    this.table.append(h);
    this.rows = this.v.images.map((e, i) => {
      const tr = el("tr"); tr.addEventListener("click", () => this.show(i));
      tr.append(el("td", {}, e.label)); for (let k = 1; k < heads.length; k++) tr.append(el("td"));
      this.table.append(tr); return tr;
    });
    const wrap = el("div", {class: "scroll"}); wrap.append(this.cropCaption, this.table);
    return wrap;
  }
  errors(i) {                         // per pixel error of image i against the reference, this.mode
    if (this.mode === "flip") return flipMap(this.v.images[i].key) || new Float32Array(this.W * this.H);
    const x = pixels(this.v.images[i].key), y = pixels(this.v.images[0].key), n = this.W * this.H;
    const out = new Float32Array(n), eps = DATA.relEps, rel = this.mode === "relse";
    for (let p = 0; p < n; p++) {
      let s = 0;
      for (let c = 0; c < 3; c++) {
        const d = x[3 * p + c] - y[3 * p + c], r = y[3 * p + c];
        s += rel ? d * d / (r * r + eps) : Math.abs(d);
      }
      out[p] = s / 3;
    }
    return out;
  }
  scale() {                           // the scene's log scale: up to the 99th percentile of every image's errors
    if (this.mode === "flip") return {lo: 0, hi: 1, linear: true};   // FLIP's own range, as its maps are shown
    if (!this.scales[this.mode]) {
      let all = [];
      for (let i = 1; i < this.v.images.length; i++) all = all.concat(Array.from(this.errors(i)).filter(e => e > 0 && isFinite(e)));
      all.sort((a, b) => a - b);
      const hi = all.length ? all[Math.floor(0.99 * (all.length - 1))] : 1;
      this.scales[this.mode] = {lo: hi * 1e-4, hi: hi};
    }
    return this.scales[this.mode];
  }
  draw() {
    const d = this.data.data, n = this.W * this.H, e = this.v.images[this.cur];
    if (this.mode === "image") {
      const x = pixels(e.key), m = Math.pow(2, this.exposure);
      for (let p = 0; p < n; p++) {
        const r = x[3 * p], g = x[3 * p + 1], b = x[3 * p + 2];
        if (isNaN(r + g + b)) d.set([255, 0, 255, 255], 4 * p);
        else d.set([srgb(r * m), srgb(g * m), srgb(b * m), 255], 4 * p);
      }
      this.cbar.style.display = "none";
    } else {
      const err = this.errors(this.cur), {lo, hi, linear} = this.scale(), a = Math.log10(lo), w = Math.log10(hi) - a;
      for (let p = 0; p < n; p++) {
        if (isNaN(err[p])) { d.set([255, 0, 255, 255], 4 * p); continue; }
        const c = cmap(linear ? err[p] : err[p] > 0 ? (Math.log10(err[p]) - a) / w : 0);
        d.set([c[0], c[1], c[2], 255], 4 * p);
      }
      this.cbar.style.display = "";
      this.cbarTitle.textContent = linear ? MODES[this.mode] + ", linear scale 0 to 1 (the flip-evaluator map of repetition 0)"
        : MODES[this.mode] + " (mean over channels), log scale; magenta: not finite";
      this.ticks.replaceChildren(...(linear ? [0, 0.5, 1].map(t => el("span", {}, t.toFixed(1))) :
        [lo, Math.sqrt(lo * hi), hi].map((t, k) => el("span", {}, (k === 0 ? "\u2264" : k === 2 ? "\u2265" : "") + t.toExponential(1)))));
    }
    this.ctx.putImageData(this.data, 0, 0);
    this.label.textContent = e.label + (this.mode === "image" ? "" : " \u2014 " + MODES[this.mode] + (this.cur === 0 ? " (zero: it is the reference)" : ""));
    this.expOut.textContent = (this.exposure >= 0 ? " +" : " \u2212") + Math.abs(this.exposure).toFixed(1) + " stops";
    this.buttons.forEach((b, i) => b && b.classList.toggle("on", i === this.cur));
    this.rows.forEach((r, i) => r.classList.toggle("on", i === this.cur));
  }
  measure() {                         // MSE and relMSE of each image in the crop and whole
    const [cx, cy, cw, ch] = this.crop, y = pixels(this.v.images[0].key), eps = DATA.relEps;
    this.cropCaption.textContent = "Against the reference (its own noise not removed); crop x " + cx + "\u2013" + (cx + cw - 1) +
      ", y " + cy + "\u2013" + (cy + ch - 1) + " (" + cw + "\u00d7" + ch + " px).";
    this.v.images.forEach((e, i) => {
      const x = pixels(e.key), sums = [0, 0, 0, 0];
      let nc = 0;
      for (let q = 0; q < this.W * this.H; q++) {
        const inside = q % this.W >= cx && q % this.W < cx + cw && Math.floor(q / this.W) >= cy && Math.floor(q / this.W) < cy + ch;
        for (let c = 0; c < 3; c++) {
          const d = x[3 * q + c] - y[3 * q + c], se = d * d, rse = se / (y[3 * q + c] * y[3 * q + c] + eps);
          sums[2] += se; sums[3] += rse;
          if (inside) { sums[0] += se; sums[1] += rse; }
        }
        if (inside) nc += 3;
      }
      const n = 3 * this.W * this.H, cells = this.rows[i].children;
      const values = [sums[0] / nc, sums[1] / nc, sums[2] / n, sums[3] / n];
      if (this.v.metric) values.push(e.sampler === null ? null : e.metric);
      values.push(e.seconds);
      values.forEach((v, k) => cells[k + 1].textContent = fmt(v));
    });
  }
  show(i) { if (i >= 0 && i < this.v.images.length && i !== this.cur) { this.prev = this.cur; this.cur = i; this.draw(); } }
  setExposure(v) { this.exposure = Math.max(-10, Math.min(10, v)); this.expIn.value = this.exposure; this.draw(); }
  setMode(m) { this.mode = m; this.modeIn.value = m; this.draw(); }
  step(dn, ds) {                      // move along N (dn) or samplers (ds) from the current image
    const v = this.v, e = v.images[this.cur];
    let s = e.sampler === null ? 0 : v.samplers.indexOf(e.sampler), n = e.spp === null ? 0 : v.spp.indexOf(e.spp);
    if (e.sampler !== null) { s += ds; n += dn; }
    for (; s >= 0 && s < v.samplers.length && n >= 0 && n < v.spp.length; s += ds, n += dn) {
      const i = this.find(v.samplers[s], v.spp[n]);
      if (i >= 0) return this.show(i);
      if (!ds && !dn) break;
    }
  }
  fit() {                             // the image as large as leaves the side panel its table's width
    const side = Math.max(360, this.table.scrollWidth + 48);
    const w = Math.min(720, Math.max(240, this.root.clientWidth - side));
    this.z = w / this.W; this.px = 0; this.py = 0;
    this.port.style.width = w + "px"; this.port.style.height = Math.round(this.H * this.z) + "px";
    this.place();
  }
  place() {
    this.canvas.style.transform = "translate(" + this.px + "px," + this.py + "px) scale(" + this.z + ")";
    const [cx, cy, cw, ch] = this.crop, b = this.cropBox.style;
    b.left = (this.px + cx * this.z) + "px"; b.top = (this.py + cy * this.z) + "px";
    b.width = (cw * this.z - 2) + "px"; b.height = (ch * this.z - 2) + "px";
  }
  at(ev) {                            // image coordinates under the pointer
    const r = this.port.getBoundingClientRect();
    return [(ev.clientX - r.left - this.px) / this.z, (ev.clientY - r.top - this.py) / this.z, ev.clientX - r.left, ev.clientY - r.top];
  }
  mouse() {
    let drag = null;
    this.port.addEventListener("wheel", ev => {
      ev.preventDefault();
      const [, , sx, sy] = this.at(ev), z = this.z * (ev.deltaY < 0 ? 1.25 : 0.8);
      this.px = sx - (sx - this.px) * z / this.z; this.py = sy - (sy - this.py) * z / this.z; this.z = z; this.place();
    }, {passive: false});
    this.port.addEventListener("mousedown", ev => {
      ev.preventDefault();
      const [ix, iy, sx, sy] = this.at(ev);
      drag = ev.shiftKey ? {crop: [Math.floor(ix), Math.floor(iy)]} : {sx: sx - this.px, sy: sy - this.py};
    });
    window.addEventListener("mousemove", ev => {
      const [ix, iy, sx, sy] = this.at(ev);
      if (drag && drag.crop) {
        const cl = (v, m) => Math.max(0, Math.min(m - 1, Math.floor(v)));
        const x0 = cl(Math.min(drag.crop[0], ix), this.W), x1 = cl(Math.max(drag.crop[0], ix), this.W);
        const y0 = cl(Math.min(drag.crop[1], iy), this.H), y1 = cl(Math.max(drag.crop[1], iy), this.H);
        this.crop = [x0, y0, x1 - x0 + 1, y1 - y0 + 1]; this.place();
      } else if (drag) { this.px = sx - drag.sx; this.py = sy - drag.sy; this.place(); }
      if (ev.target === this.port || ev.target === this.canvas) {
        const x = Math.floor(ix), y = Math.floor(iy);
        if (x >= 0 && y >= 0 && x < this.W && y < this.H) {
          const a = pixels(this.v.images[this.cur].key), g = pixels(this.v.images[0].key), p = 3 * (y * this.W + x);
          this.pixel.textContent = "pixel (" + x + ", " + y + "): " + [0, 1, 2].map(c => fmt(a[p + c])).join(" ") +
            "   reference: " + [0, 1, 2].map(c => fmt(g[p + c])).join(" ");
        }
      }
    });
    window.addEventListener("mouseup", () => { if (drag && drag.crop) this.measure(); drag = null; });
  }
  key(ev) {
    const k = ev.key;
    if (k === "ArrowRight") this.step(1, 0); else if (k === "ArrowLeft") this.step(-1, 0);
    else if (k === "ArrowDown") this.step(0, 1); else if (k === "ArrowUp") this.step(0, -1);
    else if (k === "0" || k === "g") this.show(0);
    else if (/^[1-9]$/.test(k)) {
      const s = this.v.samplers[+k - 1], e = this.v.images[this.cur];
      if (s !== undefined) this.show(this.find(s, e.spp === null ? this.v.spp[0] : e.spp));
    }
    else if (k === " ") { const p = this.prev; this.prev = this.cur; this.cur = p; this.draw(); }
    else if (k === "e" || k === "E") { const m = Object.keys(MODES); this.setMode(m[(m.indexOf(this.mode) + 1) % m.length]); }
    else if (k === "+" || k === "=") this.setExposure(this.exposure + 0.5);
    else if (k === "-" || k === "_") this.setExposure(this.exposure - 0.5);
    else if (k === "f" || k === "F") this.fit();
    else return false;
    return true;
  }
}
function setActive(v) {
  if (active) active.root.classList.remove("active");
  active = v; v.root.classList.add("active");
}
window.drtViewers = [];
document.querySelectorAll("div.viewer").forEach(div => {
  window.drtViewers.push(new Viewer(div, DATA.studies[+div.dataset.study][+div.dataset.view]));
});
if (window.drtViewers.length) setActive(window.drtViewers[0]);
document.addEventListener("keydown", ev => {
  const t = ev.target.tagName;
  if (!active || ev.ctrlKey || ev.metaKey || ev.altKey || t === "SELECT" || t === "TEXTAREA" || (t === "INPUT" && ev.target.type !== "range")) return;
  if (t === "INPUT" && ev.key.startsWith("Arrow")) return;
  if (active.key(ev)) ev.preventDefault();
});
"""
