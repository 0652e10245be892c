/*
 * nnmstop explorer: the views of one orbit (Plotly figures). Each function takes the orbits to draw
 * (the selected one first, then an overlaid one) and returns {data, layout} for Plotly.react.
 * An orbit: {label, t, x, u, xdot, udot, f, dash} with arrays over one closed period.
 */
(function (root) {
  "use strict";

  const X_COLOR = "#1f4e9c";
  const U_COLOR = "#c4521b";
  const LAW_COLOR = "#777";

  function layout(title, xTitle, yTitle, extra) {
    return Object.assign(
      {
        title: { text: title, font: { size: 13 }, x: 0.02, xanchor: "left", y: 0.98 },
        margin: { l: 54, r: 8, t: 26, b: 38 },
        font: { size: 11 },
        xaxis: { title: { text: xTitle, standoff: 4 }, zeroline: false, automargin: true },
        yaxis: { title: { text: yTitle, standoff: 4 }, zeroline: false, automargin: true },
        showlegend: false,
        hovermode: "closest",
        uirevision: title,
      },
      extra || {}
    );
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
    return { data: data, layout: layout("Time histories over one period", labels.t, labels.x + ", " + labels.u) };
  }

  function phaseView(orbits, labels) {
    const data = [];
    orbits.forEach(function (o, i) {
      data.push(line(o.x, o.xdot, "(" + labels.x + ", d" + labels.x + "/dt)" + suffix(o, i), X_COLOR, o.dash));
      data.push(line(o.u, o.udot, "(" + labels.u + ", d" + labels.u + "/dt)" + suffix(o, i), U_COLOR, o.dash));
    });
    return { data: data, layout: layout("Phase portraits", "displacement", "velocity") };
  }

  function modalView(orbits, labels, gap) {
    const data = orbits.map(function (o, i) {
      return line(o.x, o.u, "modal line" + suffix(o, i), i === 0 ? X_COLOR : "#000", o.dash);
    });
    const stops = [-gap, gap].map(function (g) {
      return { type: "line", xref: "x", yref: "paper", x0: g, x1: g, y0: 0, y1: 1, line: { color: LAW_COLOR, width: 1.5, dash: "dot" } };
    });
    return { data: data, layout: layout("Modal line with the stops (dotted)", labels.x, labels.u, { shapes: stops }) };
  }

  function forceTimeView(orbits, labels) {
    const data = orbits.map(function (o, i) {
      return line(o.t, o.f, labels.f + suffix(o, i), i === 0 ? X_COLOR : "#000", o.dash);
    });
    return { data: data, layout: layout("Contact force over one period", labels.t, labels.f) };
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
    return { data: data, layout: layout("Contact force against " + labels.x, labels.x, labels.f) };
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
    return {
      data: data,
      layout: layout("Floquet multipliers" + (label ? " " + label : ""), "real part", "imaginary part", {
        xaxis: { range: [-reach, reach], zeroline: false, title: { text: "real part", standoff: 4 } },
        yaxis: { range: [-reach, reach], scaleanchor: "x", zeroline: false, title: { text: "imaginary part", standoff: 4 } },
      }),
    };
  }

  root.Views = { timeView, phaseView, modalView, forceTimeView, forceDisplacementView, multiplierView };
})(typeof self !== "undefined" ? self : this);
