"""Interactive charts for the HTML report: data as JSON, drawn by a small inline script.

A :class:`Chart` holds its series as arrays; :func:`chart_json` writes them compactly (long
series reduced to at most ``max_points`` by keeping each bucket's minimum and maximum, so peaks
survive). The report's inline script (:data:`CHART_SCRIPT`, no library, a few kilobytes) draws
each chart as SVG and lets the reader zoom the x axis with the mouse wheel, pan by dragging and
reset with a double click; the y axis follows the visible data.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

SeriesStyle = Literal["line", "points", "markers"]


@dataclass(frozen=True, slots=True, eq=False)
class Series:
    """One series of a chart.

    Attributes
    ----------
    name
        Legend text.
    x, y
        Coordinates, shape (n,); lines need ``x`` increasing.
    style
        ``"line"``, ``"points"`` (small dots) or ``"markers"`` (triangles, for a few values).
    color
        CSS colour; empty for the palette's next.
    lower, upper
        Optional band drawn around the series (for example ``y -/+ sigma``), shape (n,).
    """

    name: str
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    style: SeriesStyle = "line"
    color: str = ""
    lower: NDArray[np.float64] | None = None
    upper: NDArray[np.float64] | None = None


def series(
    name: str,
    x: ArrayLike,
    y: ArrayLike,
    *,
    style: SeriesStyle = "line",
    color: str = "",
    sigma: ArrayLike | None = None,
) -> Series:
    """A :class:`Series` from any arrays; ``sigma`` draws the band ``y -/+ sigma``."""
    xx = np.asarray(x, dtype=np.float64).ravel()
    yy = np.asarray(y, dtype=np.float64).ravel()
    if xx.shape != yy.shape:
        raise ValueError(f"series {name!r}: x and y differ in length")
    lo = hi = None
    if sigma is not None:
        s = np.broadcast_to(np.asarray(sigma, dtype=np.float64), yy.shape)
        lo, hi = yy - s, yy + s
    if style != "line":
        # the script finds the visible range by bisection: keep x sorted
        order = np.argsort(xx, kind="stable")
        xx, yy = xx[order], yy[order]
        if lo is not None and hi is not None:
            lo, hi = lo[order], hi[order]
    return Series(name=name, x=xx, y=yy, style=style, color=color, lower=lo, upper=hi)


@dataclass(frozen=True, slots=True, eq=False)
class Chart:
    """A chart: series on shared axes.

    Attributes
    ----------
    title
        Heading drawn above the plot.
    x_label, y_label
        Axis labels with units.
    series
        The series, drawn in order.
    caption
        Text under the chart.
    x_log, y_log
        Logarithmic axes.
    spans
        ``(x0, x1)`` intervals shaded grey (for example flagged samples).
    """

    title: str
    x_label: str
    y_label: str
    series: tuple[Series, ...]
    caption: str = ""
    x_log: bool = False
    y_log: bool = False
    spans: tuple[tuple[float, float], ...] = ()


def decimate(
    x: NDArray[np.float64], y: NDArray[np.float64], *, max_points: int
) -> NDArray[np.int64]:
    """Indices of each bucket's minimum and maximum, and of the first and last sample, in order.

    Examples
    --------
    >>> y = np.array([0.0, 5, 1, 2, -3, 1, 0, 0])
    >>> decimate(np.arange(8.0), y, max_points=4).tolist()
    [0, 1, 4, 5, 7]
    """
    n = x.size
    if n <= max_points:
        return np.arange(n, dtype=np.int64)
    buckets = max(max_points // 2, 1)
    edges = np.linspace(0, n, buckets + 1).astype(np.int64)
    keep = [np.array([0, n - 1], dtype=np.int64)]
    finite = np.where(np.isfinite(y), y, np.nan)
    for a, b in itertools.pairwise(edges):
        if b <= a:
            continue
        seg = finite[a:b]
        if np.all(np.isnan(seg)):
            keep.append(np.array([a], dtype=np.int64))
            continue
        keep.append(np.array([a + np.nanargmin(seg), a + np.nanargmax(seg)], dtype=np.int64))
    return np.unique(np.concatenate(keep))


def _numbers(values: NDArray[np.float64]) -> str:
    return "[" + ",".join(f"{v:.6g}" if math.isfinite(v) else "null" for v in values) + "]"


def chart_json(chart: Chart, *, max_points: int = 8000) -> str:
    """The chart as compact JSON for :data:`CHART_SCRIPT` (``</`` escaped for inline use)."""
    parts = []
    for s in chart.series:
        idx = decimate(s.x, s.y, max_points=max_points)
        item = (
            f'{{"name":{json.dumps(s.name)},"style":"{s.style}","color":{json.dumps(s.color)},'
            f'"x":{_numbers(s.x[idx])},"y":{_numbers(s.y[idx])}'
        )
        if s.lower is not None and s.upper is not None:
            item += f',"lo":{_numbers(s.lower[idx])},"hi":{_numbers(s.upper[idx])}'
        parts.append(item + "}")
    head = {
        "title": chart.title,
        "xlabel": chart.x_label,
        "ylabel": chart.y_label,
        "xlog": chart.x_log,
        "ylog": chart.y_log,
        "spans": [[float(a), float(b)] for a, b in chart.spans],
    }
    text = json.dumps(head)[:-1] + ',"series":[' + ",".join(parts) + "]}"
    return text.replace("</", "<\\/")


def spans_from_mask(
    t: ArrayLike, mask: ArrayLike, *, max_spans: int = 400
) -> tuple[tuple[float, float], ...]:
    """Intervals ``(t0, t1)`` where ``mask`` holds; the shortest gaps merged past ``max_spans``.

    Examples
    --------
    >>> spans_from_mask([0.0, 1, 2, 3, 4], [0, 1, 1, 0, 1])
    ((1.0, 2.0), (4.0, 4.0))
    """
    tt = np.asarray(t, dtype=np.float64)
    m = np.asarray(mask, dtype=bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], m.astype(np.int8), [0]])))
    runs = [(float(tt[a]), float(tt[b - 1])) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    while len(runs) > max_spans:
        gaps = [runs[i + 1][0] - runs[i][1] for i in range(len(runs) - 1)]
        i = int(np.argmin(gaps))
        runs[i : i + 2] = [(runs[i][0], runs[i + 1][1])]
    return tuple(runs)


#: The inline script that draws every ``<div class="chart" data-src=ID>`` from the JSON in
#: ``<script type="application/json" id=ID>`` and writes ``data-charts-drawn`` and
#: ``data-charts-total`` on ``<body>`` (the browser test reads them).
CHART_SCRIPT = r"""
(function () {
  var NS = "http://www.w3.org/2000/svg";
  var PALETTE = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2"];
  function el(name, attrs, parent) {
    var e = document.createElementNS(NS, name);
    for (var k in attrs) { e.setAttribute(k, attrs[k]); }
    if (parent) { parent.appendChild(e); }
    return e;
  }
  function fmt(v) {
    if (v === 0) { return "0"; }
    var a = Math.abs(v);
    if (a >= 1e4 || a < 1e-3) { return v.toExponential(1); }
    return String(parseFloat(v.toPrecision(3)));
  }
  function ticks(lo, hi, log) {
    var out = [];
    if (log) {
      for (var p = Math.floor(lo); p <= Math.ceil(hi); p++) { if (p >= lo && p <= hi) { out.push(p); } }
      return out;
    }
    var span = hi - lo, step = Math.pow(10, Math.floor(Math.log10(span / 5)));
    var r = span / 5 / step;
    step *= r > 5 ? 10 : r > 2 ? 5 : r > 1 ? 2 : 1;
    for (var t = Math.ceil(lo / step) * step; t <= hi + 1e-12 * span; t += step) { out.push(t); }
    return out;
  }
  function tr(v, log) { return log ? (v > 0 ? Math.log10(v) : NaN) : v; }
  function visible(xs, x0, x1) {
    var a = 0, b = xs.length;
    while (a < b && !(xs[a] >= x0)) { a++; }
    while (b > a && !(xs[b - 1] <= x1)) { b--; }
    return [Math.max(a - 1, 0), Math.min(b + 1, xs.length)];
  }
  function draw(box, spec, view) {
    while (box.firstChild) { box.removeChild(box.firstChild); }
    var W = box.clientWidth || 800, H = 320, L = 70, R = 12, T = 26, B = 40;
    var pw = W - L - R, ph = H - T - B;
    var svg = el("svg", {width: W, height: H, viewBox: "0 0 " + W + " " + H}, box);
    var x0 = view[0], x1 = view[1], ylo = Infinity, yhi = -Infinity;
    var cuts = spec.series.map(function (s) {
      var xs = s.x.map(function (v) { return tr(v, spec.xlog); });
      var ab = visible(xs, x0, x1);
      for (var i = ab[0]; i < ab[1]; i++) {
        var vals = [s.y[i]];
        if (s.lo) { vals.push(s.lo[i], s.hi[i]); }
        vals.forEach(function (v) {
          var w = tr(v, spec.ylog);
          if (v !== null && isFinite(w) && xs[i] >= x0 && xs[i] <= x1) { ylo = Math.min(ylo, w); yhi = Math.max(yhi, w); }
        });
      }
      return {xs: xs, ab: ab};
    });
    if (!isFinite(ylo)) { ylo = 0; yhi = 1; }
    if (yhi - ylo < 1e-300) { ylo -= 0.5; yhi += 0.5; }
    var pad = 0.06 * (yhi - ylo); ylo -= pad; yhi += pad;
    function X(v) { return L + (v - x0) / (x1 - x0) * pw; }
    function Y(v) { return T + (yhi - v) / (yhi - ylo) * ph; }
    var id = "c" + Math.random().toString(36).slice(2);
    el("rect", {x: L, y: T, width: pw, height: ph}, el("clipPath", {id: id}, el("defs", {}, svg)));
    el("rect", {x: L, y: T, width: pw, height: ph, fill: "#fff", stroke: "#bbb"}, svg);
    var plot = el("g", {"clip-path": "url(#" + id + ")"}, svg);
    (spec.spans || []).forEach(function (sp) {
      var a = X(tr(sp[0], spec.xlog)), b = X(tr(sp[1], spec.xlog));
      el("rect", {x: a, y: T, width: Math.max(b - a, 1), height: ph, fill: "#e4e4e4"}, plot);
    });
    ticks(x0, x1, spec.xlog).forEach(function (t) {
      el("line", {x1: X(t), x2: X(t), y1: T, y2: T + ph, stroke: "#eee"}, plot);
      el("text", {x: X(t), y: T + ph + 15, "text-anchor": "middle", "font-size": 11}, svg).textContent = fmt(spec.xlog ? Math.pow(10, t) : t);
    });
    ticks(ylo, yhi, spec.ylog).forEach(function (t) {
      el("line", {x1: L, x2: L + pw, y1: Y(t), y2: Y(t), stroke: "#eee"}, plot);
      el("text", {x: L - 5, y: Y(t) + 4, "text-anchor": "end", "font-size": 11}, svg).textContent = fmt(spec.ylog ? Math.pow(10, t) : t);
    });
    var legendX = L + 8;
    spec.series.forEach(function (s, k) {
      var c = s.color || PALETTE[k % PALETTE.length], xs = cuts[k].xs, ab = cuts[k].ab;
      var step = Math.max(1, Math.floor((ab[1] - ab[0]) / (4 * pw)));
      var pts = [];
      for (var i = ab[0]; i < ab[1]; i += step) {
        var yv = tr(s.y[i], spec.ylog);
        if (s.y[i] !== null && isFinite(yv) && isFinite(xs[i])) { pts.push([X(xs[i]), Y(yv), i]); }
      }
      if (s.lo) {
        var up = [], down = [];
        for (var j = ab[0]; j < ab[1]; j += step) {
          var lo = tr(s.lo[j], spec.ylog), hi = tr(s.hi[j], spec.ylog);
          if (isFinite(lo) && isFinite(hi) && isFinite(xs[j])) { up.push(X(xs[j]) + "," + Y(hi)); down.unshift(X(xs[j]) + "," + Y(lo)); }
        }
        if (up.length) { el("polygon", {points: up.concat(down).join(" "), fill: c, "fill-opacity": 0.18, stroke: "none"}, plot); }
      }
      if (s.style === "line") {
        el("polyline", {points: pts.map(function (p) { return p[0].toFixed(1) + "," + p[1].toFixed(1); }).join(" "), fill: "none", stroke: c, "stroke-width": 1.3}, plot);
      } else if (s.style === "points") {
        el("path", {d: pts.map(function (p) { return "M" + (p[0] - 1.2).toFixed(1) + " " + (p[1] - 1.2).toFixed(1) + "h2.4v2.4h-2.4z"; }).join(""), fill: c}, plot);
      } else {
        pts.forEach(function (p) { el("path", {d: "M" + p[0] + " " + (p[1] + 5) + "l-5 -9h10z", fill: c}, plot); });
      }
      var g = el("g", {}, svg);
      el("rect", {x: legendX, y: T + 5, width: 10, height: 10, fill: c}, g);
      var txt = el("text", {x: legendX + 14, y: T + 14, "font-size": 11}, g);
      txt.textContent = s.name;
      legendX += 24 + 6.2 * s.name.length;
    });
    el("text", {x: L, y: 16, "font-size": 13, "font-weight": "bold"}, svg).textContent = spec.title;
    el("text", {x: L + pw / 2, y: H - 4, "text-anchor": "middle", "font-size": 12}, svg).textContent = spec.xlabel;
    el("text", {x: 14, y: T + ph / 2, "text-anchor": "middle", "font-size": 12, transform: "rotate(-90 14 " + (T + ph / 2) + ")"}, svg).textContent = spec.ylabel;
    return {L: L, pw: pw};
  }
  function setup(box) {
    var spec = JSON.parse(document.getElementById(box.getAttribute("data-src")).textContent);
    var lo = Infinity, hi = -Infinity;
    spec.series.forEach(function (s) {
      s.x.forEach(function (v) { var w = tr(v, spec.xlog); if (v !== null && isFinite(w)) { lo = Math.min(lo, w); hi = Math.max(hi, w); } });
    });
    if (!isFinite(lo)) { lo = 0; hi = 1; }
    if (hi <= lo) { hi = lo + 1; }
    var full = [lo, hi], view = full.slice(), geo = draw(box, spec, view), drag = null;
    box.addEventListener("wheel", function (ev) {
      ev.preventDefault();
      var r = box.getBoundingClientRect(), f = (ev.clientX - r.left - geo.L) / geo.pw;
      f = Math.min(Math.max(f, 0), 1);
      var c = view[0] + f * (view[1] - view[0]), k = ev.deltaY < 0 ? 0.8 : 1.25;
      var a = c - (c - view[0]) * k, b = c + (view[1] - c) * k;
      view = [Math.max(a, full[0]), Math.min(b, full[1])];
      geo = draw(box, spec, view);
    }, {passive: false});
    box.addEventListener("mousedown", function (ev) { drag = [ev.clientX, view.slice()]; });
    window.addEventListener("mouseup", function () { drag = null; });
    box.addEventListener("mousemove", function (ev) {
      if (!drag) { return; }
      var dx = (ev.clientX - drag[0]) / geo.pw * (drag[1][1] - drag[1][0]);
      var a = drag[1][0] - dx, b = drag[1][1] - dx;
      if (a < full[0]) { b += full[0] - a; a = full[0]; }
      if (b > full[1]) { a -= b - full[1]; b = full[1]; }
      view = [a, b];
      geo = draw(box, spec, view);
    });
    box.addEventListener("dblclick", function () { view = full.slice(); geo = draw(box, spec, view); });
  }
  window.addEventListener("load", function () {
    var boxes = document.querySelectorAll("div.chart"), ok = 0;
    boxes.forEach(function (box) {
      try { setup(box); ok += 1; } catch (e) { box.textContent = "chart failed: " + e; }
    });
    document.body.setAttribute("data-charts-drawn", String(ok));
    document.body.setAttribute("data-charts-total", String(boxes.length));
  });
})();
"""
