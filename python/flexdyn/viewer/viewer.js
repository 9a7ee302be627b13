// flexdyn's 3-D motion view: draws the scene data written by flexdyn/viewer/__init__.py with
// plotly.js (inlined above this script), and animates it: time slider, play/pause, a scale
// factor on the beams' elastic displacement, colouring of the beams by a section load.
"use strict";
(function () {
  const D = JSON.parse(document.getElementById("flexdyn-data").textContent);
  const decode = (b64) => {
    if (!b64) return new Float32Array(0);
    const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    return new Float32Array(bytes.buffer);
  };
  const F = D.times.length, N = D.nodes, P = D.points;
  const X = decode(D.x), DX = decode(D.d), E2 = decode(D.e2);
  const LOADS = {};
  for (const k in D.loads) LOADS[k] = decode(D.loads[k]);
  const BODY = decode(D.bodies.corners), JREL = decode(D.joints.rel), ARMS = decode(D.arms.rel);
  const CX = decode(D.contacts.x), CD = decode(D.contacts.d);
  const B = D.bodies.nodes.length, J = D.joints.nodes.length, S = D.contacts.labels.length;
  const K = D.arms.nodes.length;
  const state = { frame: 0, scale: D.scale, color: D.color, playing: false };

  // Displayed node positions of frame f: x + (scale − 1)·d (only beams' elastic part grows).
  function nodes(f) {
    const out = new Float32Array(3 * N), o = 3 * N * f, s = state.scale - 1;
    for (let i = 0; i < 3 * N; i++) out[i] = X[o + i] + s * DX[o + i];
    return out;
  }

  function beamLines(p) {
    const x = [], y = [], z = [], text = [];
    for (const b of D.beams) {
      for (const n of b.nodes) { x.push(p[3 * n]); y.push(p[3 * n + 1]); z.push(p[3 * n + 2]); text.push(b.name); }
      x.push(null); y.push(null); z.push(null); text.push("");
    }
    return { x, y, z, text };
  }

  function ribbons(p, f) {
    const x = [], y = [], z = [], I = [], w = 0.5 * D.ribbon, load = LOADS[state.color];
    for (const b of D.beams) {
      b.nodes.forEach((n, k) => {
        const q = 3 * (P * f + b.first + k);
        for (const sgn of [-1, 1]) {
          x.push(p[3 * n] + sgn * w * E2[q]);
          y.push(p[3 * n + 1] + sgn * w * E2[q + 1]);
          z.push(p[3 * n + 2] + sgn * w * E2[q + 2]);
          I.push(load ? load[P * f + b.first + k] : 0);
        }
      });
    }
    return { x, y, z, intensity: I };
  }

  function ribbonFaces() {
    const i = [], j = [], k = [];
    let v = 0;
    for (const b of D.beams) {
      for (let a = 0; a + 1 < b.nodes.length; a++) {
        const o = v + 2 * a;
        i.push(o, o + 1); j.push(o + 1, o + 3); k.push(o + 2, o + 2);
      }
      v += 2 * b.nodes.length;
    }
    return { i, j, k };
  }

  function boxes(p, f) {
    const x = [], y = [], z = [];
    D.bodies.nodes.forEach((n, b) => {
      for (let c = 0; c < 8; c++) {
        const q = 3 * (8 * (B * f + b) + c);
        x.push(p[3 * n] + BODY[q]); y.push(p[3 * n + 1] + BODY[q + 1]); z.push(p[3 * n + 2] + BODY[q + 2]);
      }
    });
    return { x, y, z };
  }

  function boxFaces() {
    // Corner c has coordinate bits (x: 1, y: 2, z: 4); two triangles per face.
    const quads = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]];
    const i = [], j = [], k = [];
    for (let b = 0; b < B; b++) {
      for (const [a, c, d, e] of quads) {
        i.push(8 * b + a, 8 * b + a); j.push(8 * b + c, 8 * b + d); k.push(8 * b + d, 8 * b + e);
      }
    }
    return { i, j, k };
  }

  function points(p, f, rel, nodesOf, count) {
    const x = [], y = [], z = [];
    for (let m = 0; m < count; m++) {
      const n = nodesOf[m], q = 3 * (count * f + m);
      x.push(p[3 * n] + rel[q]); y.push(p[3 * n + 1] + rel[q + 1]); z.push(p[3 * n + 2] + rel[q + 2]);
    }
    return { x, y, z };
  }

  // Arms from nodes to their joints' attachment points: a rigid link shows as a bar.
  function arms(p, f) {
    const x = [], y = [], z = [];
    for (let m = 0; m < K; m++) {
      const n = D.arms.nodes[m], q = 3 * (K * f + m);
      x.push(p[3 * n], p[3 * n] + ARMS[q], null);
      y.push(p[3 * n + 1], p[3 * n + 1] + ARMS[q + 1], null);
      z.push(p[3 * n + 2], p[3 * n + 2] + ARMS[q + 2], null);
    }
    return { x, y, z };
  }

  function contacts(f) {
    const x = [], y = [], z = [], s = state.scale - 1;
    for (let c = 0; c < S; c++) {
      const q = 3 * (S * f + c);
      x.push(CX[q] + s * CD[q]); y.push(CX[q + 1] + s * CD[q + 1]); z.push(CX[q + 2] + s * CD[q + 2]);
    }
    return { x, y, z };
  }

  const rf = ribbonFaces(), bf = boxFaces();
  const ranges = D.load_range;
  const traces = [
    { type: "scatter3d", mode: "lines", name: "beams", line: { color: "#333", width: 5 }, hoverinfo: "text" },
    {
      type: "mesh3d", name: "sections (axis 2)", i: rf.i, j: rf.j, k: rf.k, color: "#7aa6c2",
      flatshading: true, showlegend: true, showscale: false, colorscale: "RdBu", reversescale: false,
      hoverinfo: "skip",
    },
    { type: "mesh3d", name: "bodies", i: bf.i, j: bf.j, k: bf.k, color: "#d9a441", flatshading: true, showlegend: true, hovertext: "body", hoverinfo: "name" },
    {
      type: "scatter3d", mode: "markers", name: "joints", text: D.joints.labels, hoverinfo: "text",
      marker: { symbol: "diamond", size: 5, color: "#2b7a3d" },
    },
    {
      type: "scatter3d", mode: "markers", name: "contact points", text: D.contacts.labels, hoverinfo: "text",
      marker: { symbol: "circle", size: 7, color: "#c0392b" },
    },
    {
      type: "scatter3d", mode: "markers", name: "ground", text: D.ground.map((g) => g[3]), hoverinfo: "text",
      x: D.ground.map((g) => g[0]), y: D.ground.map((g) => g[1]), z: D.ground.map((g) => g[2]),
      marker: { symbol: "square", size: 5, color: "#000" },
    },
    { type: "scatter3d", mode: "lines", name: "links", line: { color: "#8a6d3b", width: 6 }, hoverinfo: "skip" },
  ];

  function bounds() {
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    const grow = (x, y, z) => {
      [x, y, z].forEach((v, a) => { if (v < lo[a]) lo[a] = v; if (v > hi[a]) hi[a] = v; });
    };
    for (let f = 0; f < F; f++) {
      const p = nodes(f);
      for (let n = 0; n < N; n++) grow(p[3 * n], p[3 * n + 1], p[3 * n + 2]);
      const c = contacts(f);
      for (let m = 0; m < S; m++) grow(c.x[m], c.y[m], c.z[m]);
    }
    for (const g of D.ground) grow(g[0], g[1], g[2]);
    const pad = 0.08 * Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-9) + 0.5 * D.ribbon;
    return lo.map((l, a) => [l - pad, hi[a] + pad]);
  }

  const layout = {
    title: { text: D.title },
    margin: { l: 0, r: 0, t: 40, b: 0 },
    uirevision: "keep",
    legend: { x: 0, y: 1 },
    scene: { aspectmode: "manual", xaxis: { title: "x [m]" }, yaxis: { title: "y [m]" }, zaxis: { title: "z [m]" } },
  };

  // Fixed ranges (the scene must not rescale as the model moves) in true proportions.
  function setRanges() {
    const r = bounds(), spans = r.map(([lo, hi]) => hi - lo), top = Math.max(...spans);
    ["xaxis", "yaxis", "zaxis"].forEach((ax, a) => { layout.scene[ax].range = r[a]; layout.scene[ax].autorange = false; });
    layout.scene.aspectmode = "manual";
    layout.scene.aspectratio = { x: spans[0] / top, y: spans[1] / top, z: spans[2] / top };
    if (!layout.scene.camera) {
      // Look mostly along the model's thinnest direction: a planar mechanism shows its plane.
      const thin = spans.indexOf(Math.min(...spans)), eye = [0.9, -1.3, 0.9];
      const w = eye.map((e, a) => (a === thin ? Math.sign(e) * 1.7 : 0.8 * e));
      layout.scene.camera = { eye: { x: w[0], y: w[1], z: w[2] }, up: { x: 0, y: 0, z: 1 } };
    }
  }

  const plot = document.getElementById("flexdyn-plot");
  function draw() {
    const f = state.frame, p = nodes(f);
    Object.assign(traces[0], beamLines(p));
    Object.assign(traces[1], ribbons(p, f));
    const coloured = !!LOADS[state.color];
    traces[1].showscale = coloured;
    if (coloured) {
      const [lo, hi] = ranges[state.color];
      Object.assign(traces[1], { cmin: lo, cmax: hi, colorbar: { title: { text: `${state.color} [${D.load_units[state.color]}]` } } });
      delete traces[1].color;
    } else {
      traces[1].color = "#7aa6c2";
    }
    Object.assign(traces[2], boxes(p, f));
    Object.assign(traces[3], points(p, f, JREL, D.joints.nodes, J));
    Object.assign(traces[4], contacts(f));
    Object.assign(traces[6], arms(p, f));
    layout.datarevision = (layout.datarevision || 0) + 1;
    document.getElementById("flexdyn-time").textContent = `${D.dim} = ${D.times[f].toFixed(4)} ${D.unit}`;
    document.getElementById("flexdyn-slider").value = f;
    return Plotly.react(plot, traces, layout);
  }

  function show(f) {
    state.frame = Math.max(0, Math.min(F - 1, f | 0));
    return draw();
  }

  let timer = null;
  function play() {
    const button = document.getElementById("flexdyn-play");
    if (state.playing) { state.playing = false; clearTimeout(timer); button.textContent = "▶ play"; return; }
    state.playing = true;
    button.textContent = "❚❚ pause";
    if (state.frame >= F - 1) state.frame = 0;
    const step = () => {
      if (!state.playing) return;
      const started = performance.now();
      show(state.frame + 1).then(() => {
        if (state.frame >= F - 1) { play(); return; }
        const fps = Number(document.getElementById("flexdyn-fps").value);
        timer = setTimeout(step, Math.max(0, 1000 / fps - (performance.now() - started)));
      });
    };
    step();
  }

  function controls() {
    const slider = document.getElementById("flexdyn-slider");
    slider.max = F - 1;
    slider.addEventListener("input", () => show(Number(slider.value)));
    document.getElementById("flexdyn-play").addEventListener("click", play);
    const scale = document.getElementById("flexdyn-scale");
    scale.value = state.scale;
    scale.addEventListener("change", () => {
      const v = Number(scale.value);
      if (!(v >= 0)) { scale.value = state.scale; return; }
      state.scale = v; setRanges(); draw();
    });
    const color = document.getElementById("flexdyn-color");
    for (const k of ["none", ...Object.keys(LOADS)]) {
      const o = document.createElement("option");
      o.value = k; o.textContent = k === "none" ? "none" : `${k} [${D.load_units[k]}]`;
      color.appendChild(o);
    }
    color.value = state.color || "none";
    color.addEventListener("change", () => { state.color = color.value; draw(); });
  }

  // Legend entries only for what the model has.
  const counts = [D.beams.length, D.points, B, J, S, D.ground.length, K];
  counts.forEach((n, t) => { traces[t].showlegend = n > 0; });
  controls();
  setRanges();
  window.flexdynView = { frames: F, state, show, play, ready: false };
  draw().then(() => { window.flexdynView.ready = true; });
})();
