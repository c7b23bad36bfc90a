/* foldprint studio page: plain JavaScript over the studio's JSON API (docs/studio.md).
   The token lives in an HttpOnly cookie the first page load set, so every same-origin
   request below carries it. State: the design (GET /api/design), the nominal result of
   the shown revision (PATCH answers), the verdict and the material search (server-sent
   events from /api/verdict/stream). An edit that the server refuses shows its one-line
   error next to the control and the controls return to the last good design. */
(function () {
  "use strict";
  var SVGNS = "http://www.w3.org/2000/svg";
  var $ = function (id) { return document.getElementById(id); };
  var design = null, nominal = null, shownRev = 0, selected = null, verdict = null;

  function el(tag, attrs, parent, ns) {
    var e = ns ? document.createElementNS(SVGNS, tag) : document.createElement(tag);
    Object.keys(attrs || {}).forEach(function (k) {
      if (k === "text") e.textContent = attrs[k]; else e.setAttribute(k, attrs[k]);
    });
    if (parent) parent.appendChild(e);
    return e;
  }
  function svg(tag, attrs, parent) { return el(tag, attrs, parent, true); }
  function clear(node) { while (node.firstChild) node.removeChild(node.firstChild); }
  function fmt(v, d) { return v === null || v === undefined ? "-" : Number(v).toFixed(d === undefined ? 2 : d); }
  function pct(v) { return v === null || v === undefined ? "-" : (100 * v).toFixed(1) + " %"; }

  function api(method, path, body) {
    var opts = {method: method, headers: {}};
    if (body !== undefined) { opts.headers["content-type"] = "application/json"; opts.body = JSON.stringify(body); }
    return fetch(path, opts).then(function (r) {
      return r.json().then(function (data) { return {ok: r.ok, status: r.status, data: data}; });
    });
  }

  function status(text, cls) { var s = $("status"); s.textContent = text; s.className = "status " + (cls || ""); }

  function clearErrors() {
    Array.prototype.forEach.call(document.querySelectorAll(".err"), function (e) { e.textContent = ""; });
  }
  function showError(key, message) {
    var spot = document.querySelector('.err[data-for="' + key + '"]');
    if (!spot) spot = document.querySelector('.err[data-for="' + key.split(".").slice(0, 2).join(".") + '"]');
    if (spot) spot.textContent = message; else status(message, "fail");
  }

  // -- edits -------------------------------------------------------------------------
  function edit(body, key) {
    clearErrors();
    status("re-folding\u2026", "run");
    return api("PATCH", "/api/design", body).then(function (r) {
      if (!r.ok) {
        showError(key, r.data.error);
        status("not applied: " + r.data.error, "fail");
        renderControls();  // the last good design stays
        return;
      }
      if (r.data.revision >= shownRev) return refresh(r.data);
    });
  }
  function refresh(result) {
    return api("GET", "/api/design").then(function (r) {
      design = r.data;
      if (result.revision < design.revision) return;  // a newer edit answers for itself
      nominal = result; shownRev = result.revision;
      renderAll();
    });
  }
  function history(which) {
    clearErrors();
    api("POST", "/api/" + which).then(function (r) {
      if (!r.ok) { status(r.data.error, "fail"); return; }
      refresh(r.data);
    });
  }

  // -- rendering ---------------------------------------------------------------------
  function renderAll() {
    $("name").textContent = design.name;
    $("revision").textContent = "revision " + design.revision;
    $("undo").disabled = !design.can_undo; $("redo").disabled = !design.can_redo;
    if (!$("save-name").value) $("save-name").value = design.name + "_edited.toml";
    renderControls(); renderLayout(); renderTimeline(); renderClearance(); renderFindings(); reloadPlayer();
    renderStatus();
  }

  function plural(k, word) { return k + " " + word + (k === 1 ? "" : "s"); }

  // The banner: the nominal fold, the design rules and the jam test of the shown revision,
  // each as it stands (the rules alone until check's findings arrive with the sweep).
  function renderStatus() {
    var n = nominal, v = verdict && verdict.design_revision === shownRev ? verdict : null;
    var parts = [n.completed ? "nominal fold completes in " + fmt(n.fold_time_s, 1) + " s" :
      (n.first_collision ? "nominal fold collides: " + n.first_collision.panels.join("-") + " at " +
        fmt(n.first_collision.time_s, 2) + " s" : "nominal fold does not complete")];
    var c = v && v.check, errors = c ? c.errors : n.errors, warnings = c ? c.warnings : n.warnings;
    parts.push((c ? "check (rules, jam test, sweep): " : "design rules: ") + plural(errors, "error") + ", " +
               plural(warnings, "warning"));
    var jam = !v ? "waiting" : v.state === "decided" ?
      ({pass: "PASS", warning: "WARNING", error: "FAIL"}[v.verdict] || v.verdict) + " (" + v.jams + " of " +
        v.samples + " samples jam)" :
      v.state === "failed" ? "could not run" : "running (" + v.samples + " samples" +
        (v.jams === null || v.jams === undefined ? "" : ", " + v.jams + " jammed") + ")";
    parts.push("jam test: " + jam);
    var bad = !n.completed || errors > 0 || (v && (v.verdict === "error" || v.state === "failed"));
    var cls = bad ? "fail" : warnings > 0 || (v && v.verdict === "warning") ? "warn" :
      v && v.state === "decided" ? "ok" : "run";
    status(parts.join("; "), cls);
    $("status").setAttribute("data-jam", v && v.state === "decided" ? v.verdict : "");
  }

  function options(select, values, current) {
    clear(select);
    values.forEach(function (v) { el("option", {value: v.value, text: v.label}, select); });
    select.value = current;
  }

  function renderControls() {
    var c = design.choices;
    $("bath").value = design.process.bath_c;
    options($("printer"), c.printers.map(function (p) { return {value: p.key, label: p.name}; }), design.setup.printer);
    options($("hinge_model"), c.hinge_models.map(function (m) { return {value: m, label: m}; }), design.setup.hinge_model);
    options($("mechanics"), c.mechanics.map(function (m) { return {value: m, label: m}; }), design.setup.mechanics);
    var body = document.querySelector("#hinges tbody"); clear(body);
    var times = {};
    (nominal ? nominal.hinges : []).forEach(function (h) { times[h.id] = h; });
    design.hinges.forEach(function (h) {
      var tr = el("tr", {"data-hinge": h.id}, body);
      var td = el("td", {}, tr);
      el("span", {"class": "swatch", style: "background:" + h.color}, td);
      td.appendChild(document.createTextNode(" " + h.id));
      var sel = el("select", {"data-hinge": h.id, "aria-label": "material of " + h.id}, el("td", {}, tr));
      var names = c.materials.map(function (m) { return m.name; });
      if (names.indexOf(h.material) < 0) names.push(h.material);
      options(sel, names.map(function (m) { return {value: m, label: m}; }), h.material);
      sel.addEventListener("change", function () {
        var e = {hinges: {}}; e.hinges[h.id] = {material: sel.value}; edit(e, "hinges." + h.id);
      });
      var vw = el("input", {type: "number", min: "0", max: "1", step: "0.01", placeholder: "VW", title:
                 "a continuous VeroWhite fraction (0-1) instead of a grade", "data-vw": h.id}, sel.parentNode);
      vw.addEventListener("change", function () {
        if (vw.value === "") return;
        var e = {hinges: {}}; e.hinges[h.id] = {material: Number(vw.value)}; edit(e, "hinges." + h.id);
      });
      var ang = el("input", {type: "number", step: "1", value: h.target_deg, "data-angle": h.id,
                             "aria-label": "target angle of " + h.id}, el("td", {}, tr));
      ang.addEventListener("change", function () {
        var e = {hinges: {}}; e.hinges[h.id] = {target_deg: Number(ang.value)}; edit(e, "hinges." + h.id);
      });
      var t = times[h.id] || {};
      el("td", {text: fmt(t.onset_time_s, 1) + " s"}, tr);
      el("td", {text: t.fold_time_s === null || t.fold_time_s === undefined ? "-" : fmt(t.fold_time_s, 1) + " s"}, tr);
      el("span", {"class": "err", "data-for": "hinges." + h.id}, el("td", {}, tr));
    });
  }

  function bounds(points) {
    var b = [Infinity, Infinity, -Infinity, -Infinity];
    points.forEach(function (p) { b[0] = Math.min(b[0], p[0]); b[1] = Math.min(b[1], p[1]);
                                  b[2] = Math.max(b[2], p[0]); b[3] = Math.max(b[3], p[1]); });
    return b;
  }
  function ringPath(ring) {
    return ring.map(function (p, i) { return (i ? "L" : "M") + p[0] + " " + (-p[1]); }).join(" ") + " Z";
  }

  function renderLayout() {
    var s = $("layout"); clear(s);
    var all = []; design.panels.forEach(function (p) { all = all.concat(p.outline); });
    var b = bounds(all), w = b[2] - b[0], h = b[3] - b[1], pad = 0.05 * Math.max(w, h);
    s.setAttribute("viewBox", [b[0] - pad, -b[3] - pad, w + 2 * pad, h + 2 * pad].join(" "));
    var unit = Math.max(w, h) / 100, hit = {};
    // labels no larger than the panels they name (a side-view strip is long and thin)
    var small = Math.min.apply(null, design.panels.map(function (p) {
      var c = bounds(p.outline); return Math.min(c[2] - c[0], c[3] - c[1]); }));
    var font = Math.max(Math.min(3 * unit, 0.6 * small), unit);
    if (nominal && nominal.first_collision) nominal.first_collision.panels.forEach(function (p) { hit[p] = true; });
    design.panels.forEach(function (p) {
      var d = ringPath(p.outline) + " " + p.holes.map(ringPath).join(" ");
      svg("path", {d: d, "fill-rule": "evenodd", fill: hit[p.id] ? "#f6c6c6" : "#e8e8e8",
                   stroke: hit[p.id] ? "#d62728" : "#777", "stroke-width": 0.3 * unit, "data-panel": p.id}, s);
      var c = bounds(p.outline);
      svg("text", {x: (c[0] + c[2]) / 2, y: -(c[1] + c[3]) / 2 + 0.35 * font, "font-size": font,
                   "text-anchor": "middle", fill: "#444", text: p.id}, s);
    });
    design.hinges.forEach(function (hg, k) {
      var a = hg.line[0], z = hg.line[1];
      svg("line", {x1: a[0], y1: -a[1], x2: z[0], y2: -z[1], stroke: hg.color, "stroke-width": Math.min(1.5 * unit, 0.4 * small),
                   "stroke-linecap": "round", "data-hinge": hg.id}, s);
      var below = Math.abs(a[0] - z[0]) < 1e-9 && k % 2;  // parallel fold lines: labels alternate above and below
      var y = below ? Math.min(-a[1], -z[1]) - font * 0.4 : Math.max(-a[1], -z[1]) + font * 1.1;
      svg("text", {x: (a[0] + z[0]) / 2, y: Math.abs(a[0] - z[0]) < 1e-9 ? y : -(a[1] + z[1]) / 2 - font * 0.3,
                   "font-size": font * 0.85, "text-anchor": "middle", fill: "#123", text: hg.id}, s);
    });
  }

  function renderTimeline() {
    var s = $("timeline"); clear(s);
    if (!nominal) return;
    var order = nominal.fold_order, by = {};
    nominal.hinges.forEach(function (h) { by[h.id] = h; });
    var tmax = nominal.duration_s || 1, rowH = 14, left = 40, width = 350;
    s.setAttribute("viewBox", "0 0 400 " + (order.length * rowH + 24));
    var colour = {}; design.hinges.forEach(function (h) { colour[h.id] = h.color; });
    order.forEach(function (id, k) {
      var h = by[id], y = 4 + k * rowH;
      svg("text", {x: 2, y: y + 10, "font-size": 10, text: id}, s);
      var t0 = h.onset_time_s || 0, t1 = h.fold_time_s === null ? tmax : h.fold_time_s;
      svg("rect", {x: left + width * t0 / tmax, y: y, width: Math.max(1, width * (t1 - t0) / tmax), height: rowH - 4,
                   fill: colour[id] || "#999", stroke: h.fold_time_s === null ? "#d62728" : "#555",
                   "stroke-width": 0.6, "data-hinge": id}, s);
    });
    var yb = order.length * rowH + 6;
    svg("line", {x1: left, y1: yb, x2: left + width, y2: yb, stroke: "#888", "stroke-width": 0.5}, s);
    for (var t = 0; t <= tmax + 1e-9; t += Math.max(1, Math.round(tmax / 10))) {
      svg("text", {x: left + width * t / tmax, y: yb + 12, "font-size": 8, "text-anchor": "middle", text: t + " s"}, s);
    }
    if (nominal.first_collision) {
      var x = left + width * nominal.first_collision.time_s / tmax;
      svg("line", {x1: x, y1: 0, x2: x, y2: yb, stroke: "#d62728", "stroke-width": 1}, s);
    }
  }

  function renderClearance() {
    var s = $("clearance"); clear(s);
    var c = nominal && nominal.clearance_curve;
    if (!c || !c.time_s.length) { $("clear-text").textContent = "no pair of panels to measure"; return; }
    var tmax = Math.max.apply(null, c.time_s.concat([1e-9])), dmax = Math.max.apply(null, c.distance_mm.concat([1]));
    var L = 40, W = 350, T = 8, H = 110;
    var pts = c.time_s.map(function (t, i) { return (L + W * t / tmax) + "," + (T + H - H * c.distance_mm[i] / dmax); });
    svg("polyline", {points: pts.join(" "), fill: "none", stroke: "#1f5fa8", "stroke-width": 1.5}, s);
    svg("line", {x1: L, y1: T + H, x2: L + W, y2: T + H, stroke: "#888", "stroke-width": 0.5}, s);
    svg("text", {x: 2, y: T + 8, "font-size": 8, text: fmt(dmax, 1) + " mm"}, s);
    svg("text", {x: 2, y: T + H, "font-size": 8, text: "0"}, s);
    svg("text", {x: L + W, y: T + H + 12, "font-size": 8, "text-anchor": "end", text: fmt(tmax, 1) + " s"}, s);
    var g = nominal.clearance;
    $("clear-text").textContent = g ? "smallest clearance " + fmt(g.distance_mm, 2) + " mm between " +
      g.panels.join(" and ") + (g.time_s !== undefined ? " at " + fmt(g.time_s, 2) + " s" : "") : "";
  }

  function renderFindings() {
    var ul = $("findings"); clear(ul);
    (nominal ? nominal.findings : []).forEach(function (f) { finding(ul, f); });
  }
  function finding(ul, f) {
    var li = el("li", {"class": f.severity, text: f.severity.toUpperCase() + " " + f.code + " " + f.message}, ul);
    li.addEventListener("click", function () {
      var on = li.classList.contains("on");
      Array.prototype.forEach.call(document.querySelectorAll(".findings li.on"), function (x) { x.classList.remove("on"); });
      highlight(on ? null : f.where); if (!on) li.classList.add("on");
    });
  }
  function highlight(where) {
    Array.prototype.forEach.call(document.querySelectorAll(".hl"), function (x) { x.classList.remove("hl"); });
    if (!where) return;
    var ids = [];
    if (where.hinge) ids.push('[data-hinge="' + where.hinge + '"]');
    [].concat(where.panels || [], where.panel ? [where.panel] : []).forEach(function (p) { ids.push('[data-panel="' + p + '"]'); });
    ids.forEach(function (q) {
      Array.prototype.forEach.call(document.querySelectorAll("svg " + q + ", tr" + q), function (x) { x.classList.add("hl"); });
    });
  }

  function reloadPlayer() {
    var src = "/view?rev=" + shownRev + ($("worst").checked ? "&worst=1" : "");
    if ($("player").getAttribute("src") !== src) $("player").setAttribute("src", src);
  }

  // -- the verdict and the material search (server-sent events) -----------------------
  function renderVerdict(v) {
    verdict = v;
    if (nominal && v.design_revision === shownRev) renderStatus();
    var box = $("verdict"); clear(box);
    box.setAttribute("data-state", v.state); box.setAttribute("data-verdict", v.verdict || "");
    box.setAttribute("data-revision", v.design_revision);
    box.setAttribute("data-sweep", (v.sweep || {}).state || "");
    var cls = v.state === "decided" ? (v.verdict === "pass" ? "ok" : v.verdict === "warning" ? "warn" : "fail") :
      v.state === "failed" ? "fail" : "run";
    box.className = "verdict " + cls;
    if (v.state === "failed") { el("b", {text: "the jam test could not run: " + v.error}, box); return; }
    if (v.state !== "decided") {
      el("b", {text: (v.state === "cancelled" ? "cancelled" : "running") + ": " + (v.stage || "")}, box);
      el("div", {"class": "samples", text: v.samples + " of at most " + v.max_samples + " samples" +
                 (v.jams === null || v.jams === undefined ? "" : ", " + v.jams + " jammed") +
                 " (revision " + v.design_revision + ")"}, box);
      if (v.interval) {
        el("div", {"class": "estimate", text: "jam probability so far " + pct(v.estimate) + ", " +
                   pct(v.level) + " interval " + pct(v.interval[0]) + " - " + pct(v.interval[1])}, box);
      }
      return;
    }
    var word = {pass: "PASS", warning: "WARNING", error: "FAIL"}[v.verdict] || v.verdict;
    el("b", {text: word + ": jam probability " + pct(v.estimate) + " (" + pct(v.level) + " interval " +
             pct(v.interval[0]) + " - " + pct(v.interval[1]) + ")"}, box);
    el("div", {text: v.jams + " of " + v.samples + " samples jam" + (v.test && v.test.truncated ? " (truncated)" : "") +
               " (revision " + v.design_revision + ")"}, box);
    if (v.test) {
      el("div", {"class": "muted", text: v.test.name + ": thresholds " + pct(v.test.warning.threshold) + " / " +
                 pct(v.test.error.threshold) + ", error rates alpha " + pct(v.test.warning.alpha) + ", beta " +
                 pct(v.test.warning.beta)}, box);
    }
    var sw = v.sweep || {};
    if (sw.state === "done" && sw.points) {
      el("div", {"class": "sweep", text: "sweep of the scatter spreads: " + sw.points.map(function (p) {
        return p.scale + "x " + (p.verdict || (p.verdicts || []).join(" or ") || "undecided") + " (" + p.jams +
          " of " + p.samples + " jam)"; }).join(", ")}, box);
    } else {
      el("div", {"class": "muted", text: "sweep of the scatter spreads: " + (sw.state || "waiting") +
                 (sw.stage ? ", " + sw.stage : "") + (sw.samples !== undefined ? " (" + sw.samples + " samples" +
                 (sw.jams === null || sw.jams === undefined ? "" : ", " + sw.jams + " jammed") + ")" : "")}, box);
    }
    if (v.check && nominal && v.design_revision === shownRev) {
      var ul = $("findings"); clear(ul);
      v.check.findings.forEach(function (f) { finding(ul, f); });
    }
  }

  function renderAssign(a) {
    var st = $("assign-state"), ol = $("choices");
    if (a.state === "running") { st.textContent = "searching: " + a.done + " of at most " + a.total + " evaluations"; return; }
    if (a.state === "failed") { st.textContent = a.error; return; }
    if (a.state !== "done") { st.textContent = a.state; return; }
    var r = a.result; clear(ol);
    st.textContent = r.feasible + " feasible in " + r.evaluated + " evaluations";
    r.best.forEach(function (c, k) {
      var li = el("li", {}, ol);
      li.appendChild(document.createTextNode(Object.keys(c.assignment).map(function (h) { return h + "=" + c.assignment[h]; })
        .join(", ") + " at " + c.temperature_c + " \u00b0C: folds in " + fmt(c.fold_time_s, 1) + " s, clearance " +
        fmt(c.min_clearance_mm, 2) + " mm "));
      var b = el("button", {type: "button", text: "apply", "data-choice": k}, li);
      b.addEventListener("click", function () {
        api("POST", "/api/assign/apply", {index: k}).then(function (res) {
          if (!res.ok) { st.textContent = res.data.error; return; }
          refresh(res.data);
        });
      });
    });
  }

  function listen() {
    var es = new EventSource("/api/verdict/stream");
    es.addEventListener("verdict", function (e) { renderVerdict(JSON.parse(e.data)); });
    es.addEventListener("assign", function (e) { renderAssign(JSON.parse(e.data)); });
    es.addEventListener("design", function (e) {
      var d = JSON.parse(e.data);
      if (design && d.revision > shownRev) api("GET", "/api/nominal").then(function (r) { if (r.ok) refresh(r.data); });
    });
  }

  // -- wiring --------------------------------------------------------------------------
  function wire() {
    $("undo").addEventListener("click", function () { history("undo"); });
    $("redo").addEventListener("click", function () { history("redo"); });
    document.addEventListener("keydown", function (e) {
      if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === "z" && e.target.tagName !== "INPUT") {
        e.preventDefault(); history(e.shiftKey ? "redo" : "undo");
      }
    });
    $("bath").addEventListener("change", function () { edit({process: {bath_c: Number($("bath").value)}}, "process.bath_c"); });
    ["printer", "hinge_model", "mechanics"].forEach(function (k) {
      $(k).addEventListener("change", function () { var o = {}; o[k] = $(k).value; edit({options: o}, "options." + k); });
    });
    $("worst").addEventListener("change", reloadPlayer);
    $("save").addEventListener("click", function () { save(false); });
    $("export").addEventListener("click", function () {
      $("files").textContent = "exporting\u2026";
      api("POST", "/api/export").then(function (r) {
        $("files").textContent = r.ok ? "exported " + r.data.files.length + " files into " + r.data.out : r.data.error;
      });
    });
    $("suggest").addEventListener("click", function () {
      $("assign-state").textContent = "starting\u2026"; clear($("choices"));
      api("POST", "/api/assign", {}).then(function (r) { if (!r.ok) $("assign-state").textContent = r.data.error; });
    });
  }
  function save(overwrite) {
    api("POST", "/api/save", {name: $("save-name").value, overwrite: overwrite}).then(function (r) {
      if (r.status === 409 && !overwrite) {
        if (window.confirm(r.data.error + "\nOverwrite it?")) save(true);
        return;
      }
      $("files").textContent = r.ok ? "saved " + r.data.path : r.data.error;
      $("files").setAttribute("data-saved", r.ok ? r.data.path : "");
    });
  }

  wire();
  api("GET", "/api/nominal").then(function (r) {
    if (!r.ok) { status(r.data.error, "fail"); return; }
    return refresh(r.data).then(listen);
  });
})();
