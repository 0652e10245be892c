/*
 * nnmstop explorer: the page. Reads the data block, draws the frequency-energy plot of every branch and,
 * for the selected (or hovered) point, its orbit synthesized from the stored Fourier coefficients.
 * window.explorer exposes the state and select() for tests and the console.
 */
(function () {
  "use strict";
  const S = window.Synthesis;
  const V = window.Views;
  // milliseconds since the navigation started (performance.now's origin): script start, data decoded, plot drawn, ready
  const timings = { scriptStart: performance.now() };
  const data = S.unpackAll(JSON.parse(document.getElementById("explorer-data").textContent));
  timings.dataDecoded = performance.now();
  const branches = data.branches;
  const samples = data.settings.time_samples;
  const state = { branch: 0, point: 0, shown: null, overlay: true, selectionTrace: 0, traceBranch: [] };
  const PALETTE = ["#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf", "#bcbd22"];
  const EXACT_COLOR = "#d62728";
  const CONFIG = { displaylogo: false, responsive: true, modeBarButtonsToRemove: ["select2d", "lasso2d"] };

  branches.forEach(function (b, i) {
    b.label = b.id || b.path;
    b.color = b.kind === "exact" ? EXACT_COLOR : PALETTE[i % PALETTE.length];
  });

  function column(b, name) {
    const c = b.columns[name];
    return c === undefined ? undefined : Array.isArray(c) ? c : c.data;
  }

  function value(b, name, i) {
    const c = column(b, name);
    return c === undefined ? undefined : c[i];
  }

  function format(v) {
    if (typeof v === "string") return v;
    if (!Number.isFinite(v)) return String(v);
    if (Number.isInteger(v) && Math.abs(v) < 1e6) return String(v);
    const a = Math.abs(v);
    return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(5) : String(Number(v.toPrecision(7)));
  }

  function flagText(meta, v) {
    if (!meta.flag_values) return "";
    const k = meta.flag_values.indexOf(v);
    return k >= 0 ? " (" + meta.flag_meanings[k].replace(/_/g, " ") + ")" : "";
  }

  // ------------------------------------------------------------------ orbits

  function closed(values, scale) {
    const out = new Float64Array(values.length + 1);
    for (let j = 0; j < values.length; j++) out[j] = values[j] * scale;
    out[values.length] = out[0];
    return out;
  }

  function orbitOf(bi, i, dash) {
    const b = branches[bi];
    const o = b.orbit;
    const omega = o.omega.data[i];
    const field = function (name) {
      const sin = o.sines && o.sines[name] ? S.row(o.sines[name], i) : null;
      return S.synthesize(S.row(o.fields[name], i), sin, o.harmonics.data, samples);
    };
    const x = field("x");
    const u = field("u");
    const orbit = {
      label: b.label + " #" + i, t: S.periodTimes(omega, samples), dash: dash,
      x: closed(x.values, 1), u: closed(u.values, 1), xdot: closed(x.derivative, omega), udot: closed(u.derivative, omega),
    };
    orbit.f = o.force === "coefficients" ? closed(field("f").values, 1) : S.piecewiseForce(orbit.x, b.model.alpha, b.model.gap);
    orbit.xMax = Math.max.apply(null, Array.from(x.values));
    return orbit;
  }

  function multipliersOf(bi, i) {
    const m = branches[bi].multipliers;
    return { real: Array.from(S.row(m.real, i)), imag: Array.from(S.row(m.imag, i)), label: branches[bi].label + " #" + i };
  }

  /** The orbit of the other model's branch of the same NNM with the same impacts per period, nearest in energy
   * (within 5 %) and frequency. */
  function partnerOf(bi, i) {
    const b = branches[bi];
    const energy = value(b, "energy", i);
    const frequency = value(b, "frequency", i);
    const impacts = value(b, "impacts_per_period", i);
    let best = null;
    branches.forEach(function (c, ci) {
      // the other model's branch of the same NNM of the same system
      if (c.kind === b.kind || c.family !== b.family || c.model.alpha !== b.model.alpha || c.model.gap !== b.model.gap) return;
      const E = column(c, "energy");
      const f = column(c, "frequency");
      const n = column(c, "impacts_per_period");
      for (let j = 0; j < E.length; j++) {
        const gap = Math.abs(Math.log(E[j] / energy));
        if (gap > 0.05) continue;
        if (impacts === undefined || !n || n[j] !== impacts) continue;
        const score = gap + Math.abs(f[j] - frequency) / frequency;
        if (!best || score < best.score) best = { branch: ci, point: j, score: score };
      }
    });
    return best;
  }

  // ------------------------------------------------------------------ frequency-energy plot

  function runs(b) {
    const piece = b.piece ? column(b, b.piece) : null;
    const out = [];
    let start = 0;
    for (let i = 1; i <= b.points; i++) {
      if (i === b.points || (piece && piece[i] !== piece[i - 1])) {
        out.push([start, i]);
        start = i;
      }
    }
    return out;
  }

  /** Two traces per branch, stable solid and unstable dashed; a gap (null) between stages or segments. */
  function curveTraces(b) {
    const E = column(b, "energy");
    const f = column(b, "frequency");
    const stable = column(b, "stable");
    const impacts = column(b, "impacts_per_period");
    const isStable = function (k) { return !stable || stable[k] === 1; };
    const solid = { x: [], y: [], customdata: [], text: [] };
    const dashed = { x: [], y: [], customdata: [], text: [] };
    runs(b).forEach(function (run) {
      const first = run[0];
      const last = run[1];
      for (let k = first; k < last; k++) {
        const text = impacts ? "impacts per period: " + impacts[k] : "";
        const inDashed = !isStable(k) || (k > first && !isStable(k - 1)) || (k + 1 < last && !isStable(k + 1));
        [[solid, isStable(k)], [dashed, inDashed]].forEach(function (pair) {
          pair[0].x.push(pair[1] ? E[k] : null);
          pair[0].y.push(pair[1] ? f[k] : null);
          pair[0].customdata.push(k);
          pair[0].text.push(text);
        });
      }
      [solid, dashed].forEach(function (trace) { // the next piece does not join this one
        trace.x.push(null);
        trace.y.push(null);
        trace.customdata.push(null);
        trace.text.push("");
      });
    });
    const hover = b.label + "<br>point %{customdata}<br>E = %{x:.6g}<br>f = %{y:.6g} Hz<br>%{text}<extra></extra>";
    return [[solid, "solid", true], [dashed, "dash", false]].map(function (spec) {
      return Object.assign(spec[0], {
        type: "scatter", mode: "lines", name: b.label + " (" + b.kind + ")", legendgroup: b.label, showlegend: spec[2],
        line: { color: b.color, width: 1.6, dash: spec[1] }, hovertemplate: hover, connectgaps: false,
      });
    });
  }

  function markTraces(b) {
    const out = [];
    const E = column(b, "energy");
    const f = column(b, "frequency");
    const impacts = column(b, "impacts_per_period");
    if (impacts) {
      const change = { x: [], y: [], text: [], customdata: [] };
      for (let k = 1; k < b.points; k++) {
        if (impacts[k] !== impacts[k - 1]) {
          change.x.push(E[k]); change.y.push(f[k]); change.text.push(String(impacts[k])); change.customdata.push(k);
        }
      }
      out.push(Object.assign(change, {
        type: "scatter", mode: "markers+text", textposition: "top center", textfont: { size: 9, color: b.color },
        marker: { size: 5, color: b.color, symbol: "circle-open" }, legendgroup: b.label, showlegend: false,
        name: b.label + " impacts", hovertemplate: b.label + ": %{text} impacts per period from point %{customdata}<extra></extra>",
      }));
    }
    [["branch_points", "x-thin-open", "branch point", 11], ["folds", "diamond-open", "fold", 8]].forEach(function (spec) {
      const m = b.marks && b.marks[spec[0]];
      if (!m || m.energy.data.length === 0) return;
      out.push({
        x: Array.from(m.energy.data), y: Array.from(m.frequency.data), type: "scatter", mode: "markers",
        name: spec[2] + "s", legendgroup: spec[2], showlegend: false,
        marker: { symbol: spec[1], size: spec[3], color: "#000", line: { width: 1.5, color: "#000" } },
        hovertemplate: b.label + ": located " + spec[2] + "<br>E = %{x:.6g}<br>f = %{y:.6g} Hz<extra></extra>",
      });
    });
    return out;
  }

  function drawFrequencyEnergy() {
    const traces = [];
    state.traceBranch = [];
    branches.forEach(function (b, bi) {
      curveTraces(b).forEach(function (t) {
        traces.push(t);
        state.traceBranch.push(bi);
      });
    });
    branches.forEach(function (b) {
      markTraces(b).forEach(function (t) {
        traces.push(t);
        state.traceBranch.push(-1);
      });
    });
    traces.push({
      x: [], y: [], type: "scatter", mode: "markers", name: "selected", showlegend: false, hoverinfo: "skip",
      marker: { size: 14, color: "rgba(0,0,0,0)", line: { width: 2.5, color: "#000" } },
    });
    state.traceBranch.push(-1);
    state.selectionTrace = traces.length - 1;
    const meta = branches[0].meta;
    const layout = {
      margin: { l: 62, r: 10, t: 8, b: 44 }, font: { size: 12 }, hovermode: "closest", dragmode: "zoom",
      xaxis: { type: "log", title: { text: "energy [" + meta.energy.units + "] (log scale)" }, exponentformat: "power" },
      yaxis: { title: { text: "frequency [" + meta.frequency.units + "]" } },
      legend: { x: 0.01, y: 0.99, bgcolor: "rgba(255,255,255,0.85)", font: { size: 11 } },
      uirevision: "fep",
    };
    return Plotly.newPlot("fep", traces, layout, CONFIG);
  }

  // ------------------------------------------------------------------ panels

  function labelsOf(b) {
    return Object.assign({ t: "t", x: "x", u: "u", f: "f" }, b.orbit.labels || {});
  }

  function drawOrbit(bi, i) {
    const b = branches[bi];
    const orbit = orbitOf(bi, i, "solid");
    const orbits = [orbit];
    const multipliers = [multipliersOf(bi, i)];
    const partner = state.overlay ? partnerOf(bi, i) : null;
    if (partner) {
      orbits.push(orbitOf(partner.branch, partner.point, "dot"));
      multipliers.push(multipliersOf(partner.branch, partner.point));
    }
    const labels = labelsOf(b);
    const figure = V.compose([
      V.timeView(orbits, labels),
      V.phaseView(orbits, labels),
      V.modalView(orbits, labels, b.model.gap),
      V.forceTimeView(orbits, labels),
      V.forceDisplacementView(orbits, labels, b.model.alpha, b.model.gap),
      V.multiplierView(multipliers, ""), // sixth panel: its y axis is scale-anchored to x6
    ]);
    Plotly.react("orbit-plot", figure.data, figure.layout, CONFIG);
    return { orbit: orbit, partner: partner };
  }

  function row(tbody, name, text, title, id, raw, className) {
    const tr = document.createElement("tr");
    if (className) tr.className = className;
    const th = document.createElement("td");
    th.className = "name";
    th.textContent = name;
    if (title) th.title = title;
    const td = document.createElement("td");
    td.className = "value";
    td.textContent = text;
    if (id) td.id = id;
    if (raw !== undefined) td.dataset.value = String(raw);
    tr.append(th, td);
    tbody.append(tr);
  }

  function showNumbers(bi, i, drawn) {
    const b = branches[bi];
    const tbody = document.querySelector("#numbers tbody");
    tbody.replaceChildren();
    row(tbody, "branch", b.label + " (" + b.kind + ")", b.title, "value-branch", bi, "identity");
    row(tbody, "dataset", b.path, b.in_manifest ? "listed in " + data.manifest : "not in " + data.manifest, "value-dataset",
      undefined, "identity");
    row(tbody, "SHA-256", b.sha256, "SHA-256 of the dataset file", "value-sha256", undefined, "identity sha");
    row(tbody, "point", i + " of " + b.points, "index along the branch (0-based)", "value-point", i, "identity");
    b.numbers.forEach(function (name) {
      const meta = b.meta[name];
      const v = value(b, name, i);
      const units = meta.units && meta.units !== "1" ? " " + meta.units : "";
      row(tbody, name + ": " + meta.long_name, format(v) + units + flagText(meta, v), meta.long_name, "value-" + name, v);
    });
    row(tbody, "largest x of the synthesized orbit", format(drawn.orbit.xMax),
      "maximum of x over the " + samples + " instants of the period at which the page synthesizes the orbit",
      "value-x-max-synthesized", drawn.orbit.xMax);
    const p = drawn.partner;
    const text = p ? branches[p.branch].label + " #" + p.point + ", E = " + format(value(branches[p.branch], "energy", p.point))
      : "none (no orbit of the other model on this NNM with as many impacts within 5 % in energy)";
    row(tbody, "overlaid orbit (dotted)", state.overlay ? text : "off", "the other model's orbit nearest in energy", "value-partner");
    const key = "Solid: " + b.label + " #" + i + (p && state.overlay ? "; dotted: " + text : "") +
      ". Blue: " + labelsOf(b).x + ", orange: " + labelsOf(b).u + ".";
    document.getElementById("orbit-key").textContent = key;
  }

  function show(bi, i) {
    const drawn = drawOrbit(bi, i);
    showNumbers(bi, i, drawn);
    state.shown = [bi, i];
  }

  function select(bi, i) {
    const b = branches[bi];
    i = Math.max(0, Math.min(b.points - 1, i));
    state.branch = bi;
    state.point = i;
    document.getElementById("branch-select").value = String(bi);
    const input = document.getElementById("point-input");
    input.max = String(b.points - 1);
    input.value = String(i);
    Plotly.restyle("fep", { x: [[value(b, "energy", i)]], y: [[value(b, "frequency", i)]] }, [state.selectionTrace]);
    show(bi, i);
  }

  // ------------------------------------------------------------------ events

  let pending = null;
  function preview(bi, i) {
    pending = [bi, i];
    requestAnimationFrame(function () {
      if (pending) show(pending[0], pending[1]);
      pending = null;
    });
  }

  function pointOf(event) {
    const p = event.points && event.points[0];
    if (!p) return null;
    const bi = state.traceBranch[p.curveNumber];
    return bi >= 0 && typeof p.customdata === "number" ? [bi, p.customdata] : null;
  }

  function nearestInEnergy(bi, energy) {
    const E = column(branches[bi], "energy");
    let best = 0;
    for (let j = 1; j < E.length; j++) if (Math.abs(Math.log(E[j] / energy)) < Math.abs(Math.log(E[best] / energy))) best = j;
    return best;
  }

  function onKey(event) {
    const b = branches[state.branch];
    const steps = { ArrowRight: 1, ArrowLeft: -1, PageUp: 10, PageDown: -10 };
    if (event.key in steps) select(state.branch, state.point + steps[event.key]);
    else if (event.key === "Home") select(state.branch, 0);
    else if (event.key === "End") select(state.branch, b.points - 1);
    else if (event.key === "ArrowUp" || event.key === "ArrowDown") {
      const next = (state.branch + (event.key === "ArrowUp" ? 1 : branches.length - 1)) % branches.length;
      select(next, nearestInEnergy(next, value(b, "energy", state.point)));
    } else return;
    event.preventDefault();
  }

  function wire() {
    const fep = document.getElementById("fep");
    fep.on("plotly_click", function (event) {
      const p = pointOf(event);
      if (p) select(p[0], p[1]);
      fep.focus();
    });
    fep.on("plotly_hover", function (event) {
      const p = pointOf(event);
      if (p) preview(p[0], p[1]);
    });
    fep.on("plotly_unhover", function () {
      preview(state.branch, state.point);
    });
    fep.addEventListener("keydown", onKey);
    document.getElementById("branch-select").addEventListener("change", function (event) {
      const bi = Number(event.target.value);
      select(bi, nearestInEnergy(bi, value(branches[state.branch], "energy", state.point)));
    });
    document.getElementById("point-input").addEventListener("change", function (event) {
      select(state.branch, Math.round(Number(event.target.value)) || 0);
    });
    document.getElementById("overlay-toggle").addEventListener("change", function (event) {
      state.overlay = event.target.checked;
      show(state.branch, state.point);
    });
  }

  function describe() {
    const select = document.getElementById("branch-select");
    const sources = document.querySelector("#sources tbody");
    branches.forEach(function (b, bi) {
      select.add(new Option(b.label + " (" + b.kind + ")", String(bi)));
      const tr = document.createElement("tr");
      const listed = b.in_manifest ? "listed in " + data.manifest : "not in " + data.manifest + " (SHA-256 of the file)";
      [b.label + " — " + b.title, b.path, b.sha256, String(b.points)].forEach(function (text, k) {
        const td = document.createElement("td");
        td.textContent = text;
        if (k === 1 || k === 2) td.className = "sha";
        if (k === 2) td.title = listed;
        tr.append(td);
      });
      sources.append(tr);
    });
    const model = branches[0].model;
    const parameters = Object.keys(model).filter(function (k) { return k !== "gap"; })
      .map(function (k) { return k + " = " + format(model[k]); }).join(", ");
    document.getElementById("build-info").textContent =
      branches.length + " branches; " + parameters + "; " + (branches[0].source || "");
    document.getElementById("library-info").textContent =
      "Plots by " + data.plotly.package + " " + data.plotly.version + " (MIT license), inlined: the page uses no network.";
  }

  describe();
  drawFrequencyEnergy().then(function () {
    timings.frequencyEnergyDrawn = performance.now();
    wire();
    const start = Math.max(0, branches.findIndex(function (b) { return b.kind === "regularized"; }));
    select(start, Math.floor(branches[start].points / 4));
    timings.ready = performance.now(); // first render: every view drawn for the first selected orbit
    document.body.dataset.ready = "true";
  });

  window.explorer = { timings: timings, state: state, branches: branches, samples: samples, select: select, orbitOf: orbitOf, partnerOf: partnerOf, data: data };
})();
