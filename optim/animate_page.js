// The viewer of jaxflex's animation page (optim/animate_page.py inlines it with the data and
// plotly.js): the part's surface moving along its path, bending (scaled), coloured by the
// deviation, the stress or the distance to the obstacles, and a small time plot.
"use strict";

(function () {
  const D = JSON.parse(document.getElementById("jaxflex-data").textContent);

  function bytes(b64) {
    const raw = atob(b64);
    const out = new Uint8Array(raw.length);
    for (let i = 0; i < raw.length; i++) out[i] = raw.charCodeAt(i);
    return out.buffer;
  }
  const base = new Float64Array(bytes(D.base));
  const triangles = new Int32Array(bytes(D.triangles));
  const translation = new Float64Array(bytes(D.translation));
  const rotation = new Float64Array(bytes(D.rotation));
  const disp = new Float32Array(bytes(D.displacement));
  const fields = {};
  for (const name of Object.keys(D.fields)) {
    fields[name] = new Uint16Array(bytes(D.fields[name].data));
  }
  const nV = D.n_vertices;
  const nF = D.t_s.length;
  const ti = [], tj = [], tk = [];
  for (let t = 0; t < triangles.length; t += 3) {
    ti.push(triangles[t]); tj.push(triangles[t + 1]); tk.push(triangles[t + 2]);
  }

  const state = { frame: 0, scale: 1, colour: D.default_colour, playing: false, probe: null };
  const errors = [];
  window.jaxflexPage = {
    state: state,
    times: D.t_s,
    node: D.node,
    errors: errors,
    show: show,
    drawn: function (i) {
      const trace = document.getElementById("plot").data[0];
      return [trace.x[i], trace.y[i], trace.z[i]];
    },
  };

  // positions of frame f at deformation scale s: pivot + s(t) + R(t) (x - pivot) + s d
  function positions(f, s) {
    const x = new Array(nV), y = new Array(nV), z = new Array(nV);
    const R = rotation.subarray(9 * f, 9 * f + 9);
    const T = translation.subarray(3 * f, 3 * f + 3);
    const P = D.pivot_m;
    for (let i = 0; i < nV; i++) {
      const a = base[3 * i] - P[0], b = base[3 * i + 1] - P[1], c = base[3 * i + 2] - P[2];
      const o = 3 * (f * nV + i);
      x[i] = P[0] + T[0] + R[0] * a + R[1] * b + R[2] * c + s * disp[o];
      y[i] = P[1] + T[1] + R[3] * a + R[4] * b + R[5] * c + s * disp[o + 1];
      z[i] = P[2] + T[2] + R[6] * a + R[7] * b + R[8] * c + s * disp[o + 2];
    }
    return [x, y, z];
  }

  function colours(f) {
    const field = D.fields[state.colour];
    const q = fields[state.colour];
    const out = new Array(nV);
    const step = (field.high - field.low) / 65535;
    for (let i = 0; i < nV; i++) out[i] = (field.low + step * q[f * nV + i]) * field.display;
    return out;
  }

  function partTrace(f) {
    const p = positions(f, state.scale);
    const field = D.fields[state.colour];
    return {
      type: "mesh3d", x: p[0], y: p[1], z: p[2], i: ti, j: tj, k: tk,
      intensity: colours(f), colorscale: field.colorscale, reversescale: field.reverse,
      cmin: field.cmin * field.display, cmax: field.cmax * field.display,
      colorbar: { title: { text: field.label }, len: 0.6, y: 0.68 },
      flatshading: false, hoverinfo: "skip", name: "part",
      lighting: { ambient: 0.55, diffuse: 0.6, specular: 0.1 },
    };
  }

  function curveTraces() {
    const c = D.curves[state.colour];
    const field = D.fields[state.colour];
    const traces = [{
      type: "scatter", mode: "lines", x: D.curve_t_s, y: c.values.map((v) => v * field.display),
      xaxis: "x", yaxis: "y", name: c.label, line: { color: "#1f77b4", width: 1.5 },
      hoverinfo: "x+y",
    }];
    if (c.limit !== null) {
      traces.push({
        type: "scatter", mode: "lines", x: [0, D.curve_t_s[D.curve_t_s.length - 1]],
        y: [c.limit * field.display, c.limit * field.display], xaxis: "x", yaxis: "y",
        name: c.limit_label, line: { color: "black", dash: "dash", width: 1 }, hoverinfo: "skip",
      });
    }
    return traces;
  }

  function layout() {
    const c = D.curves[state.colour];
    const field = D.fields[state.colour];
    const yaxis = { title: { text: field.label }, domain: [0, 0.22], anchor: "x" };
    if (c.log) yaxis.type = "log";
    if (c.range) yaxis.range = c.range.map((v) => (c.log ? Math.log10(v * field.display) : v * field.display));
    const marks = [
      { type: "line", xref: "x", yref: "paper", x0: D.cycle_time_s, x1: D.cycle_time_s, y0: 0,
        y1: 0.22, line: { color: "#d62728", width: 1.5, dash: "dot" } },
      { type: "line", xref: "x", yref: "paper", x0: D.t_s[state.frame], x1: D.t_s[state.frame],
        y0: 0, y1: 0.22, line: { color: "black", width: 2 } },
    ];
    return {
      margin: { l: 60, r: 20, t: 10, b: 40 },
      showlegend: true,
      legend: { x: 1, xanchor: "right", y: 0.235, yanchor: "bottom", orientation: "h" },
      scene: {
        domain: { x: [0, 1], y: [0.28, 1] }, aspectmode: "data",
        xaxis: { title: { text: "x [m]" } }, yaxis: { title: { text: "y [m]" } },
        zaxis: { title: { text: "z [m]" } }, camera: D.camera, uirevision: "keep",
      },
      xaxis: { title: { text: "time [s]" }, domain: [0, 1], anchor: "y", range: [0, D.curve_t_s[D.curve_t_s.length - 1]] },
      yaxis: yaxis,
      shapes: marks,
      annotations: [{ xref: "x", yref: "paper", x: D.cycle_time_s, y: 0.22, yanchor: "bottom",
        text: "cycle " + D.cycle_time_s.toFixed(3) + " s", showarrow: false,
        font: { color: "#d62728", size: 11 } }],
      uirevision: "keep",
    };
  }

  function staticTraces() {
    const out = [];
    if (D.obstacles) {
      out.push({
        type: "mesh3d", x: D.obstacles.x, y: D.obstacles.y, z: D.obstacles.z,
        i: D.obstacles.i, j: D.obstacles.j, k: D.obstacles.k, color: "#8c8c8c",
        opacity: 0.2, flatshading: true, hoverinfo: "skip", name: "obstacles",
        showlegend: false,
      });
    }
    out.push({
      type: "scatter3d", mode: "lines", x: D.path.x, y: D.path.y, z: D.path.z,
      line: { color: "#2ca02c", width: 4 }, name: "path", hoverinfo: "skip", showlegend: false,
    });
    if (D.via.x.length) {
      out.push({
        type: "scatter3d", mode: "markers", x: D.via.x, y: D.via.y, z: D.via.z,
        marker: { size: 5, color: "#2ca02c", symbol: "diamond" }, name: "via points",
        showlegend: false,
      });
    }
    return out;
  }

  let nStatic = 0;
  function draw() {
    const gd = document.getElementById("plot");
    const statics = staticTraces();
    nStatic = statics.length;
    Plotly.react(gd, [partTrace(state.frame), ...statics, ...curveTraces()], layout(),
      { responsive: true, displaylogo: false });
    report();
  }

  function show(f) {
    state.frame = Math.max(0, Math.min(nF - 1, f | 0));
    const gd = document.getElementById("plot");
    const p = positions(state.frame, state.scale);
    Plotly.restyle(gd, { x: [p[0]], y: [p[1]], z: [p[2]], intensity: [colours(state.frame)] }, [0]);
    Plotly.relayout(gd, { "shapes[1].x0": D.t_s[state.frame], "shapes[1].x1": D.t_s[state.frame] });
    report();
  }

  // the status element tells a reader of the page (or a test) what is drawn: the frame, its
  // time, the errors caught, the 3-D view's place on the page and, with #probe=I in the
  // address, the position drawn for vertex I (its model node, from plotly's own data)
  function report() {
    const f = state.frame;
    document.getElementById("slider").value = f;
    const t = D.t_s[f];
    const phase = t <= D.transfer_time_s ? "moving" : "settling";
    document.getElementById("time").textContent = "t = " + t.toFixed(3) + " s (" + phase + ")";
    const status = document.getElementById("status");
    status.dataset.frame = String(f);
    status.dataset.time = String(t);
    status.dataset.errors = JSON.stringify(window.__jaxflexErrors);
    const scene = document.getElementById("scene") || document.getElementById("plot");
    const box = scene.getBoundingClientRect();
    status.dataset.scene = JSON.stringify([box.left, box.top, box.right, box.bottom]);
    if (state.probe !== null) {
      status.dataset.probe = JSON.stringify({
        vertex: state.probe, node: D.node[state.probe], drawn: window.jaxflexPage.drawn(state.probe),
      });
    }
    status.dataset.ready = "1";
  }

  // playing: the frame whose time the clock (real time x speed) has reached, every 40 ms
  let last = null, clock = 0;
  function tick() {
    if (!state.playing) return;
    const now = performance.now();
    if (last !== null) clock += (now - last) / 1000 * Number(document.getElementById("speed").value);
    last = now;
    let f = state.frame;
    while (f < nF - 1 && D.t_s[f + 1] <= clock) f++;
    if (f !== state.frame) show(f);
    if (state.frame >= nF - 1) { pause(); return; }
    setTimeout(tick, 40);
  }
  function play() {
    if (state.frame >= nF - 1) show(0);
    state.playing = true; last = null; clock = D.t_s[state.frame];
    document.getElementById("play").textContent = "pause";
    tick();
  }
  function pause() {
    state.playing = false;
    document.getElementById("play").textContent = "play";
  }

  function controls() {
    const slider = document.getElementById("slider");
    slider.max = String(nF - 1);
    slider.addEventListener("input", () => { pause(); show(Number(slider.value)); });
    document.getElementById("play").addEventListener("click", () => (state.playing ? pause() : play()));
    const scale = document.getElementById("scale");
    scale.addEventListener("change", () => { state.scale = Number(scale.value); show(state.frame); });
    const colour = document.getElementById("colour");
    for (const name of Object.keys(D.fields)) {
      const option = document.createElement("option");
      option.value = name; option.textContent = D.fields[name].menu;
      colour.appendChild(option);
    }
    colour.value = state.colour;
    colour.addEventListener("change", () => { state.colour = colour.value; draw(); });
  }

  function fromHash() {
    const args = new URLSearchParams(location.hash.slice(1));
    if (args.has("scale")) { state.scale = Number(args.get("scale")); document.getElementById("scale").value = args.get("scale"); }
    if (args.has("colour") && D.fields[args.get("colour")]) { state.colour = args.get("colour"); document.getElementById("colour").value = state.colour; }
    if (args.has("probe")) state.probe = Math.max(0, Math.min(nV - 1, Number(args.get("probe")) | 0));
    if (args.has("speed")) document.getElementById("speed").value = args.get("speed");
    if (args.has("frame")) state.frame = Math.max(0, Math.min(nF - 1, Number(args.get("frame")) | 0));
    return args.has("play");
  }

  controls();
  const autoplay = fromHash();
  draw();
  if (autoplay) play();
})();
