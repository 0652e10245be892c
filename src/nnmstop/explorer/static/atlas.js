/*
 * nnmstop explorer: the bifurcation atlas. For each map, the (frequency, force or gap) plane shaded by region as
 * the slices read them, the curves (grazing, folds, Neimark-Sacker, flips, second contacts; regularized
 * dashed) and the codimension-two points. A click on a curve shows the orbit at that point; a click on a region
 * shows the orbits of every response of the nearest slice at that frequency (stable solid, unstable dashed).
 * window.atlas exposes showCurvePoint() and showRegion() for tests and the console.
 */
(function () {
  "use strict";
  const S = window.Synthesis;
  const atlases = (window.explorer && window.explorer.data.atlases) || [];
  const section = document.getElementById("atlas-section");
  if (!atlases.length || !section) return;
  section.hidden = false;
  const REGION_COLORS = {
    no_contact: "#f4f4f4", impacting: "#cfe3f3", coexisting: "#f7c98b", no_stable_periodic: "#ef8a8a", not_covered: "#bdbdbd",
  };
  const CURVE_COLORS = {
    grazing: "black", fold: "#1f4e9c", neimark_sacker: "#c0281f", flip: "#7b3294", second_contact: "#555555",
  };
  const SAMPLES = 256;
  const select = document.getElementById("atlas-select");
  const key = document.getElementById("atlas-key");
  const CONFIG = { displaylogo: false, responsive: true, modeBarButtonsToRemove: ["select2d", "lasso2d"] };
  let current = 0;

  atlases.forEach(function (a, i) {
    const option = document.createElement("option");
    option.value = String(i);
    option.textContent = a.name + " (frequency, " + a.plane + ")";
    select.appendChild(option);
  });

  function orbitRow(array, i) {
    // (points, 2 DOFs, 2K + 1) float32: the row of point i as two coefficient arrays
    const width = array.shape[1] * array.shape[2];
    return array.data.subarray(i * width, (i + 1) * width);
  }

  function synthesized(row, dof, K) {
    const n = 2 * K + 1;
    const c = row.subarray(dof * n, (dof + 1) * n);
    const cos = new Float64Array(K + 1);
    const sin = new Float64Array(K + 1);
    const harmonics = new Int32Array(K + 1);
    for (let k = 0; k <= K; k++) {
      harmonics[k] = k;
      cos[k] = c[k];
      sin[k] = k === 0 ? 0 : c[K + k];
    }
    return S.synthesize(cos, sin, harmonics, SAMPLES);
  }

  function closedArray(values, scale) {
    const out = new Array(values.length + 1);
    for (let j = 0; j < values.length; j++) out[j] = values[j] * scale;
    out[values.length] = out[0];
    return out;
  }

  function regionShapes(a) {
    const runs = a.regions.runs;
    const shapes = [];
    for (let r = 0; r < runs.shape[0]; r++) {
      const v = runs.data.subarray(r * 5, r * 5 + 5);
      shapes.push({
        type: "rect", x0: v[0], x1: v[1], y0: v[2], y1: v[3], line: { width: 0 }, layer: "below",
        fillcolor: REGION_COLORS[a.regions.meanings[v[4]]],
      });
    }
    return shapes;
  }

  function regionAt(a, f, s) {
    const runs = a.regions.runs;
    for (let r = 0; r < runs.shape[0]; r++) {
      const v = runs.data.subarray(r * 5, r * 5 + 5);
      if (f >= v[0] && f < v[1] && s >= v[2] && s < v[3]) return a.regions.meanings[v[4]];
    }
    return "";
  }

  function draw() {
    const a = atlases[current];
    const c = a.curves;
    const traces = [];
    const curves = new Map();
    for (let i = 0; i < c.curve.data.length; i++) {
      const j = c.curve.data[i];
      if (!curves.has(j)) curves.set(j, []);
      curves.get(j).push(i);
    }
    curves.forEach(function (indices, j) {
      const kind = c.kind[j];
      const regularized = c.law[j] === "regularized";
      traces.push({
        x: indices.map(function (i) { return c.frequency.data[i]; }),
        y: indices.map(function (i) { return c.second.data[i]; }),
        customdata: indices, type: "scatter", mode: "lines+markers", marker: { size: 3 },
        line: { color: CURVE_COLORS[kind], width: regularized ? 1 : 1.8, dash: regularized ? "dash" : "solid" },
        name: kind.replace(/_/g, " ") + (regularized ? " (regularized)" : ""), hoverinfo: "name+x+y", meta: "curve",
      });
    });
    traces.push({
      x: Array.from(a.codim2.frequency.data), y: Array.from(a.codim2.second.data), text: a.codim2.kind,
      type: "scatter", mode: "markers", marker: { symbol: "diamond-open", size: 10, color: "black" },
      name: "codimension-two points", hoverinfo: "text+x+y", meta: "codim2",
    });
    // an invisible layer of the slices' response points: a click anywhere on the map lands on the nearest one
    if (a.responses.frequency) {
      traces.push({
        x: Array.from(a.responses.frequency.data), y: Array.from(a.responses.second.data), type: "scatter",
        mode: "markers", marker: { size: 8, opacity: 0.0 }, hoverinfo: "none", showlegend: false, meta: "response",
      });
    }
    const layout = {
      margin: { l: 60, r: 10, t: 10, b: 45 }, hovermode: "closest", shapes: regionShapes(a),
      xaxis: { title: { text: "frequency [Hz]" } }, yaxis: { title: { text: a.plane === "force" ? "force amplitude F" : a.plane } },
      legend: { orientation: "h", y: -0.2 }, uirevision: a.path,
    };
    Plotly.react("atlas-plot", traces, layout, CONFIG);
  }

  function orbitPlot(orbits, title) {
    const traces = [];
    orbits.forEach(function (o) {
      const dash = o.stable === false ? "dash" : "solid";
      traces.push({ x: o.t, y: o.x, type: "scatter", mode: "lines", line: { color: "#1f4e9c", dash: dash }, name: "x " + o.label });
      traces.push({ x: o.t, y: o.u, type: "scatter", mode: "lines", line: { color: "#c4521b", dash: dash }, name: "u " + o.label });
      traces.push({ x: o.x, y: o.xdot, xaxis: "x2", yaxis: "y2", type: "scatter", mode: "lines",
        line: { color: "#1f4e9c", dash: dash }, name: "(x, dx/dt) " + o.label, showlegend: false });
    });
    const gap = atlases[current].gap;
    const layout = {
      margin: { l: 50, r: 10, t: 28, b: 40 }, title: { text: title, font: { size: 12 } }, showlegend: true,
      legend: { orientation: "h", y: -0.25 },
      xaxis: { domain: [0, 0.55], title: { text: "phase of the force / 2 pi" } }, yaxis: { title: { text: "x, u" } },
      xaxis2: { domain: [0.65, 1], anchor: "y2", title: { text: "x" } }, yaxis2: { anchor: "x2", title: { text: "dx/dt" } },
      shapes: [-gap, gap].map(function (g) {
        return { type: "line", xref: "x2", yref: "y2 domain", x0: g, x1: g, y0: 0, y1: 1, line: { color: "#777", dash: "dot" } };
      }),
    };
    Plotly.react("atlas-orbit", traces, layout, CONFIG);
  }

  function orbitFrom(coefficients, i, omega, label, stable) {
    const a = atlases[current];
    const row = orbitRow(coefficients, i);
    const x = synthesized(row, 0, a.harmonics);
    const u = synthesized(row, 1, a.harmonics);
    const t = [];
    for (let j = 0; j <= SAMPLES; j++) t.push(j / SAMPLES);
    return {
      t: t, x: closedArray(x.values, 1), u: closedArray(u.values, 1), xdot: closedArray(x.derivative, omega),
      label: label, stable: stable,
    };
  }

  /** The orbit at point i of the curves. */
  function showCurvePoint(i) {
    const a = atlases[current];
    const c = a.curves;
    const j = c.curve.data[i];
    const f = c.frequency.data[i];
    const label = c.kind[j].replace(/_/g, " ") + (c.law[j] === "regularized" ? " (regularized)" : "");
    const text = label + " at " + f.toFixed(6) + " Hz, " + a.plane + " " + c.second.data[i].toPrecision(6);
    key.textContent = "Curve point: " + text;
    orbitPlot([orbitFrom(c.orbit, i, 2 * Math.PI * f, "", true)], text);
    return text;
  }

  /** The responses of the slice nearest to (f, s) at the frequency nearest to f: one orbit each. */
  function showRegion(f, s) {
    const a = atlases[current];
    const r = a.responses;
    let best = Infinity;
    let value = null;
    for (let i = 0; i < r.second.data.length; i++) {
      const d = Math.abs(r.second.data[i] - s);
      if (d < best) { best = d; value = r.second.data[i]; }
    }
    // every piece of the response at that slice: the points nearest to f, one per crossing of f
    const picks = [];
    const indices = [];
    for (let i = 0; i < r.second.data.length; i++) if (r.second.data[i] === value) indices.push(i);
    for (let n = 0; n + 1 < indices.length; n++) {
      const i = indices[n], k = indices[n + 1];
      if (r.piece.data[i] !== r.piece.data[k]) continue; // consecutive points of one piece of the response only
      const a0 = r.frequency.data[i], a1 = r.frequency.data[k];
      const lo = Math.min(a0, a1), hi = Math.max(a0, a1);
      if (lo <= f && f < hi) picks.push(Math.abs(a0 - f) <= Math.abs(a1 - f) ? i : k);
    }
    const region = regionAt(a, f, s);
    const orbits = picks.map(function (i, n) {
      const stable = r.stable.data[i] === 1;
      return orbitFrom(r.orbit, i, 2 * Math.PI * r.frequency.data[i], "#" + (n + 1) + (stable ? " stable" : " unstable"), stable);
    });
    const text = (region ? region.replace(/_/g, " ") + ": " : "") + picks.length + " response(s) of the slice " +
      a.plane + " = " + Number(value).toPrecision(4) + " near " + f.toFixed(5) + " Hz";
    key.textContent = text;
    orbitPlot(orbits, text);
    return { region: region, responses: picks.length, value: value };
  }

  select.addEventListener("change", function () {
    current = Number(select.value);
    draw();
  });
  draw();
  document.getElementById("atlas-plot").on("plotly_click", function (event) {
    const p = event.points[0];
    if (p.data.meta === "curve") showCurvePoint(p.customdata);
    else showRegion(p.x, p.y);
  });
  window.atlas = { atlases: atlases, showCurvePoint: showCurvePoint, showRegion: showRegion, select: function (i) {
    current = i; select.value = String(i); draw();
  } };
})();
