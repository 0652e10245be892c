/*
 * nnmstop explorer: the views of one orbit, drawn as the panels of one Plotly figure (compose). Each view
 * function takes the orbits to draw (the selected one first, then an overlaid one) and returns a view.
 * An orbit: {label, t, x, u, xdot, udot, f, dash} with arrays over one closed period.
 */
(function (root) {
  "use strict";

  const X_COLOR = "#1f4e9c";
  const U_COLOR = "#c4521b";
  const LAW_COLOR = "#777";

  /** A view: its traces, title, axis titles and extra axis settings (the panel's axes are set by compose). */
  function view(data, title, xTitle, yTitle, extra) {
    return Object.assign({ data: data, title: title, xTitle: xTitle, yTitle: yTitle, xaxis: {}, yaxis: {}, shapes: [] }, extra || {});
  }

  /** The views as panels of one figure, two per row (one Plotly figure draws much faster than six). */
  function compose(views) {
    const rows = Math.ceil(views.length / 2);
    const layout = {
      margin: { l: 54, r: 8, t: 22, b: 38 }, font: { size: 11 }, showlegend: false, hovermode: "closest",
      annotations: [], shapes: [], uirevision: "orbit",
    };
    const data = [];
    views.forEach(function (v, n) {
      const s = n === 0 ? "" : String(n + 1);
      const col = n % 2;
      const row = Math.floor(n / 2);
      const top = 1 - row / rows - 0.045;
      const bottom = 1 - (row + 1) / rows + 0.06;
      layout["xaxis" + s] = Object.assign(
        { domain: col === 0 ? [0, 0.44] : [0.56, 1], anchor: "y" + s, zeroline: false,
          title: { text: v.xTitle, standoff: 2, font: { size: 11 } } },
        v.xaxis
      );
      layout["yaxis" + s] = Object.assign(
        { domain: [bottom, top], anchor: "x" + s, zeroline: false, title: { text: v.yTitle, standoff: 2, font: { size: 11 } } },
        v.yaxis
      );
      layout.annotations.push({
        text: v.title, xref: "x" + s + " domain", yref: "y" + s + " domain", x: 0, y: 1.01, xanchor: "left", yanchor: "bottom",
        showarrow: false, font: { size: 13 },
      });
      v.shapes.forEach(function (shape) {
        layout.shapes.push(Object.assign({}, shape, { xref: "x" + s, yref: "y" + s + " domain" }));
      });
      v.data.forEach(function (trace) {
        data.push(Object.assign(trace, { xaxis: "x" + s, yaxis: "y" + s }));
      });
    });
    return { data: data, layout: layout };
  }

  function line(x, y, name, color, dash, extra) {
    return Object.assign(
      { x: Array.from(x), y: Array.from(y), name: name, type: "scatter", mode: "lines",
        line: { color: color, width: dash === "solid" ? 1.6 : 1.3, dash: dash } },
      extra || {}
    );
  }

  function suffix(orbit, index) {
    return index === 0 ? "" : " (" + orbit.label + ")";
  }

  function timeView(orbits, labels) {
    const data = [];
    orbits.forEach(function (o, i) {
      data.push(line(o.t, o.x, labels.x + suffix(o, i), X_COLOR, o.dash));
      data.push(line(o.t, o.u, labels.u + suffix(o, i), U_COLOR, o.dash));
    });
    return view(data, "Time histories over one period", labels.t, labels.x + ", " + labels.u);
  }

  function phaseView(orbits, labels) {
    const data = [];
    orbits.forEach(function (o, i) {
      data.push(line(o.x, o.xdot, "(" + labels.x + ", d" + labels.x + "/dt)" + suffix(o, i), X_COLOR, o.dash));
      data.push(line(o.u, o.udot, "(" + labels.u + ", d" + labels.u + "/dt)" + suffix(o, i), U_COLOR, o.dash));
    });
    return view(data, "Phase portraits", "displacement", "velocity");
  }

  function modalView(orbits, labels, gap) {
    const data = orbits.map(function (o, i) {
      return line(o.x, o.u, "modal line" + suffix(o, i), i === 0 ? X_COLOR : "#000", o.dash);
    });
    const stops = [-gap, gap].map(function (g) {
      return { type: "line", x0: g, x1: g, y0: 0, y1: 1, line: { color: LAW_COLOR, width: 1.5, dash: "dot" } };
    });
    return view(data, "Modal line with the stops (dotted)", labels.x, labels.u, { shapes: stops });
  }

  function forceTimeView(orbits, labels) {
    const data = orbits.map(function (o, i) {
      return line(o.t, o.f, labels.f + suffix(o, i), i === 0 ? X_COLOR : "#000", o.dash);
    });
    return view(data, "Contact force over one period", labels.t, labels.f);
  }

  function forceDisplacementView(orbits, labels, alpha, gap) {
    let reach = gap * 1.05;
    orbits.forEach(function (o) {
      for (let j = 0; j < o.x.length; j++) reach = Math.max(reach, Math.abs(o.x[j]));
    });
    const lawX = [-reach, -gap, gap, reach];
    const lawF = lawX.map(function (x) {
      return Math.abs(x) > gap ? alpha * (Math.abs(x) - gap) * Math.sign(x) : 0;
    });
    const data = [line(lawX, lawF, "piecewise-linear law", LAW_COLOR, "solid", { line: { color: LAW_COLOR, width: 4 }, opacity: 0.45 })];
    orbits.forEach(function (o, i) {
      data.push(line(o.x, o.f, "orbit" + suffix(o, i), i === 0 ? X_COLOR : "#000", o.dash));
    });
    return view(data, "Contact force against " + labels.x, labels.x, labels.f);
  }

  function multiplierView(multipliers, label) {
    const circle = { x: [], y: [] };
    for (let k = 0; k <= 256; k++) {
      circle.x.push(Math.cos((2 * Math.PI * k) / 256));
      circle.y.push(Math.sin((2 * Math.PI * k) / 256));
    }
    const data = [line(circle.x, circle.y, "unit circle", LAW_COLOR, "solid", { hoverinfo: "skip" })];
    multipliers.forEach(function (m, i) {
      data.push({
        x: m.real, y: m.imag, type: "scatter", mode: "markers", name: (i === 0 ? "multipliers" : "multipliers (" + m.label + ")"),
        marker: { size: i === 0 ? 9 : 7, color: i === 0 ? X_COLOR : "#000", symbol: i === 0 ? "x" : "circle-open" },
        hovertemplate: "%{x:.6g} %{y:+.6g}i<extra></extra>",
      });
    });
    let reach = 1.15;
    multipliers.forEach(function (m) {
      m.real.concat(m.imag).forEach(function (v) { reach = Math.max(reach, Math.abs(v) * 1.08); });
    });
    reach = Math.min(reach, 50);
    return view(data, "Floquet multipliers" + (label ? " " + label : ""), "real part", "imaginary part", {
      xaxis: { range: [-reach, reach] },
      yaxis: { range: [-reach, reach], scaleanchor: "x6", constrain: "domain" },
    });
  }

  root.Views = { compose, timeView, phaseView, modalView, forceTimeView, forceDisplacementView, multiplierView };
})(typeof self !== "undefined" ? self : this);
