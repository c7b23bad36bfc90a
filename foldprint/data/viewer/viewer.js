/* foldprint fold viewer: draws the data block of a design page (see foldprint/viewer.py)
   with three.js (window.FOLDPRINT_THREE). Panels are the printed solids in the flat sheet,
   moved by the simulation's panel poses; hinge ribbons come per frame from Python (the
   hinge map is not re-implemented here). Between frames, poses and ribbon vertices are
   interpolated linearly. The URL's "#t=<fraction 0..1>" sets the shown moment; when the
   data holds a replayed Monte-Carlo sample (D.worst), "#run=worst" shows it instead of the
   nominal fold (same geometry; its own poses, ribbons, contacts and duration), and the banner
   names that sample's contact. The camera follows the part: at every moment it frames the
   box of that frame (D.boxes, interpolated between frames) from the current direction, so
   the flat sheet and the folded part both fill the view; zooming or panning fixes the
   camera, the "follow the part" button lets it follow again. */
(function () {
  "use strict";
  var T = window.FOLDPRINT_THREE;
  var D = JSON.parse(document.getElementById("fold-data").textContent);
  var canvas = document.getElementById("view");
  var stage = document.getElementById("stage");
  var slider = document.getElementById("slider");
  var clock = document.getElementById("clock");
  var playBtn = document.getElementById("play");
  var RED = new T.Color("#d62728");

  function decode(s, Type) {
    var bin = atob(s), buf = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) buf[i] = bin.charCodeAt(i);
    return new Type(buf.buffer);
  }

  var nF = D.frames, nP = D.panels.length;
  // the runs: the nominal fold and, when present, the worst sample; each (nF + 2) x nP x 16
  // poses (the last two: programmed, permanent) and (nF + 2) x nR x 3 ribbon vertices
  var banner = document.getElementById("banner");
  var RUNS = {nominal: {poses: decode(D.poses, Float32Array), q: D.ribbon.n ? decode(D.ribbon.q, Uint16Array) : new Uint16Array(0),
                        end: D.end, contacts: D.contacts, bath_c: D.bath_c, completed: D.completed, boxes: D.boxes,
                        banner: banner ? banner.textContent : "", cls: banner ? banner.className : "status"}};
  if (D.worst) {
    RUNS.worst = {poses: decode(D.worst.poses, Float32Array), q: D.ribbon.n ? decode(D.worst.q, Uint16Array) : new Uint16Array(0),
                  end: D.worst.end, contacts: D.worst.contacts, bath_c: D.worst.bath_c, completed: D.worst.completed,
                  boxes: D.worst.boxes, banner: D.worst.banner, cls: "status " + (D.worst.completed ? "ok" : "fail")};
  }
  var run = "nominal", cur = RUNS.nominal;
  var poses = cur.poses;
  var lo = D.bounds[0], hi = D.bounds[1];
  var centre = new T.Vector3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2);
  var radius = Math.max(0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]), 1);

  var renderer = new T.WebGLRenderer({canvas: canvas, antialias: true, preserveDrawingBuffer: true});
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.setClearColor(0xf7f7f7, 1);
  var scene = new T.Scene();
  scene.add(new T.HemisphereLight(0xffffff, 0x8a8a8a, 1.6));
  var sun = new T.DirectionalLight(0xffffff, 1.8);
  sun.position.set(0.35, -0.55, 0.76);
  scene.add(sun);
  var camera = new T.PerspectiveCamera(30, 16 / 9, radius / 50, radius * 50);
  camera.up.set(0, 0, 1);
  // the still renders' cameras: strips from the side (along +y, 20 deg up), others oblique
  var el = (D.planar ? 20 : 32) * Math.PI / 180, az = (D.planar ? -90 : -58) * Math.PI / 180;
  var dist = radius / Math.sin(15 * Math.PI / 180) * 0.62;
  camera.position.set(centre.x + dist * Math.cos(el) * Math.cos(az),
                      centre.y + dist * Math.cos(el) * Math.sin(az), centre.z + dist * Math.sin(el));
  var controls = new T.OrbitControls(camera, canvas);
  controls.target.copy(centre);
  controls.update();
  controls.addEventListener("change", draw);

  // follow the part: frame the box of the moment shown, from the camera's current direction
  var follow = true, followBtn = document.getElementById("follow");
  function setFollow(on) {
    follow = on;
    if (followBtn) followBtn.setAttribute("aria-pressed", String(on));
    document.body.setAttribute("data-follow", String(on));
  }
  var MARGIN = 1.1, markerSize = radius * 0.035;
  function fit(box) {  // the nearest distance at which every corner of the box is in view
    var c = new T.Vector3((box[0] + box[3]) / 2, (box[1] + box[4]) / 2, (box[2] + box[5]) / 2);
    var dir = camera.position.clone().sub(controls.target).normalize();
    var fwd = dir.clone().negate();
    var right = new T.Vector3().crossVectors(fwd, camera.up).normalize();
    var up = new T.Vector3().crossVectors(right, fwd).normalize();
    var tv = Math.tan(camera.fov * Math.PI / 360), th = tv * camera.aspect;
    var d = 1e-3, o = new T.Vector3();
    for (var k = 0; k < 8; k++) {
      o.set(box[k & 1 ? 3 : 0] - c.x, box[k & 2 ? 4 : 1] - c.y, box[k & 4 ? 5 : 2] - c.z);
      var z = o.dot(dir);
      d = Math.max(d, z + MARGIN * Math.abs(o.dot(right)) / th, z + MARGIN * Math.abs(o.dot(up)) / tv);
    }
    controls.target.copy(c);
    camera.position.copy(c).addScaledVector(dir, d);
    camera.near = d / 100;
    camera.far = d * 100;
    camera.updateProjectionMatrix();
    markerSize = 0.03 * Math.max(box[3] - box[0], box[4] - box[1], box[5] - box[2], 1e-3);
  }
  function frameBox(fa, fb, w) {
    var a = cur.boxes[fa], b = cur.boxes[fb], out = [];
    for (var i = 0; i < 6; i++) out.push(a[i] * (1 - w) + b[i] * w);
    return out;
  }
  canvas.addEventListener("wheel", function () { setFollow(false); }, {passive: true});
  canvas.addEventListener("pointerdown", function (e) {
    if (e.button === 2 || e.ctrlKey || e.metaKey || e.shiftKey) setFollow(false);  // a pan
  });
  canvas.addEventListener("touchstart", function (e) { if (e.touches.length > 1) setFollow(false); }, {passive: true});

  // panels and teeth: one mesh each, sheet-frame geometry, pose as the object matrix
  var items = D.items.map(function (it) {
    var g = new T.BufferGeometry();
    g.setAttribute("position", new T.BufferAttribute(decode(it.v, Float32Array), 3));
    g.setIndex(new T.BufferAttribute(decode(it.f, Uint32Array), 1));
    g = g.toNonIndexed();
    g.computeVertexNormals();
    var base = new T.Color(D.colors[it.material] || "#9a9a9a");
    var mat = new T.MeshStandardMaterial({color: base.clone(), roughness: 0.8, metalness: 0,
                                          flatShading: true, side: T.DoubleSide});
    var mesh = new T.Mesh(g, mat);
    mesh.matrixAutoUpdate = false;
    var edges = new T.LineSegments(new T.EdgesGeometry(g, 25),
                                   new T.LineBasicMaterial({color: base.clone().multiplyScalar(0.45)}));
    mesh.add(edges);
    scene.add(mesh);
    return {mesh: mesh, edges: edges, base: base, panel: it.panel, kind: it.kind};
  });

  // hinge ribbons: positions rewritten per frame from quantised vertices
  var R = D.ribbon, nR = R.n;
  var q = cur.q;
  var ribbons = R.owners.map(function (o) {
    var h = D.hinges[o[0]];
    var g = new T.BufferGeometry();
    var pos = new Float32Array(o[2] * 3);
    g.setAttribute("position", new T.BufferAttribute(pos, 3));
    var all = decode(R.f, Uint32Array), tris = [];
    for (var i = 0; i < all.length; i += 3) {
      if (all[i] >= o[1] && all[i] < o[1] + o[2])
        tris.push(all[i] - o[1], all[i + 1] - o[1], all[i + 2] - o[1]);
    }
    g.setIndex(tris);
    var mat = new T.MeshStandardMaterial({color: new T.Color(D.colors[h.material] || "#9a9a9a"),
                                          roughness: 0.6, metalness: 0, flatShading: true,
                                          side: T.DoubleSide});
    var mesh = new T.Mesh(g, mat);
    mesh.frustumCulled = false;
    scene.add(mesh);
    return {mesh: mesh, start: o[1], count: o[2], pos: pos};
  });

  // contact markers of each run (hidden until their time, and when their run is not shown)
  Object.keys(RUNS).forEach(function (name) {
    RUNS[name].markers = RUNS[name].contacts.map(function (c) {
      var m = new T.Mesh(new T.SphereGeometry(1, 20, 12),
                         new T.MeshBasicMaterial({color: RED}));
      m.position.set(c.point[0], c.point[1], c.point[2]);
      m.visible = false;
      scene.add(m);
      return m;
    });
  });

  var mA = new T.Matrix4(), mB = new T.Matrix4(), tmp = new Float32Array(16);

  function lerpPose(fa, fb, w, p, out) {
    var a = (fa * nP + p) * 16, b = (fb * nP + p) * 16;
    for (var i = 0; i < 16; i++) tmp[i] = poses[a + i] * (1 - w) + poses[b + i] * w;
    out.fromArray(tmp);
  }

  var state = {frac: 0, named: null}, lastShown = null;

  function show(fa, fb, w, time) {
    lastShown = [fa, fb, w];
    if (follow) fit(frameBox(fa, fb, w));
    for (var k = 0; k < items.length; k++) {
      var it = items[k];
      lerpPose(fa, fb, w, it.panel, it.mesh.matrix);
      it.mesh.matrixWorldNeedsUpdate = true;
      var hit = time !== null && cur.contacts.some(function (c) {
        return c.time <= time + 1e-9 && c.pair.indexOf(it.panel) >= 0;
      });
      it.mesh.material.color.copy(it.base);
      if (hit && it.kind === "panel") it.mesh.material.color.lerp(RED, 0.45);
      it.edges.material.color.copy(hit ? RED : it.base.clone().multiplyScalar(0.45));
    }
    var span = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    for (var r = 0; r < ribbons.length; r++) {
      var rb = ribbons[r];
      for (var v = 0; v < rb.count; v++) {
        for (var c = 0; c < 3; c++) {
          var ia = (fa * nR + rb.start + v) * 3 + c, ib = (fb * nR + rb.start + v) * 3 + c;
          var x = q[ia] * (1 - w) + q[ib] * w;
          rb.pos[v * 3 + c] = lo[c] + x / 65535 * span[c];
        }
      }
      rb.mesh.geometry.attributes.position.needsUpdate = true;
      rb.mesh.geometry.computeVertexNormals();
    }
    Object.keys(RUNS).forEach(function (name) {
      RUNS[name].markers.forEach(function (m, i) {
        m.visible = name === run && time !== null && RUNS[name].contacts[i].time <= time + 1e-9;
        m.scale.setScalar(markerSize);
      });
    });
    draw();
  }

  function draw() { renderer.render(scene, camera); }

  // bar-and-hinge runs (--mechanics bar-hinge): the largest panel strain at the solved step at or before t
  function strainAt(t) {
    var M = run === "worst" ? null : D.mechanics;
    if (!M || !M.times.length) return "";
    var k = 0;
    while (k + 1 < M.times.length && M.times[k + 1] <= t) k++;
    return " \u00b7 panel strain " + (100 * M.strain[k]).toFixed(3) + " %, bending " + M.bending_deg[k].toFixed(2) + "\u00b0";
  }

  function setFraction(f, fromUser) {
    f = Math.min(1, Math.max(0, isFinite(f) ? f : 0));
    state.frac = f;
    state.named = null;
    var x = f * (nF - 1), fa = Math.floor(x), fb = Math.min(fa + 1, nF - 1);
    var time = f * cur.end;
    show(fa, fb, x - fa, time);
    slider.value = String(Math.round(f * 1000));
    clock.textContent = "t = " + time.toFixed(2) + " s" + strainAt(time);
    setPressed(null);
    if (fromUser) history.replaceState(null, "", runHash() + "t=" + f.toFixed(3));
    document.body.setAttribute("data-t", f.toFixed(3));
  }

  function runHash() { return run === "nominal" ? "#" : "#run=" + run + "&"; }

  function setRun(name) {  // show the nominal fold or the worst sample (same moment or state)
    if (!RUNS[name]) name = "nominal";
    run = name;
    cur = RUNS[name];
    poses = cur.poses;
    q = cur.q;
    document.body.setAttribute("data-run", name);
    if (banner) {
      banner.textContent = cur.banner;
      banner.className = cur.cls;
    }
    Object.keys(RUNS).forEach(function (n) {
      var b = document.getElementById("run-" + n);
      if (b) b.setAttribute("aria-pressed", String(n === name));
    });
    describe();
  }

  function setNamed(name, fromUser) {
    var k = name === "programmed" ? nF : nF + 1;
    if (fromUser) history.replaceState(null, "", runHash() + "state=" + name);
    state.named = name;
    show(k, k, 0, null);
    clock.textContent = name + " state";
    setPressed(name);
    document.body.setAttribute("data-t", name);
  }

  function setPressed(name) {
    ["programmed", "permanent"].forEach(function (n) {
      document.getElementById(n).setAttribute("aria-pressed", String(n === name));
    });
  }

  function fromHash() {  // "#t=0.5" a moment of the fold, "#state=permanent" a named state, "#run=worst&t=0.5"
    var rn = /(?:^#|&)run=(nominal|worst)\b/.exec(location.hash);
    var want = rn && RUNS[rn[1]] ? rn[1] : "nominal";
    if (want !== run) setRun(want);
    var st = /(?:^#|&)state=(programmed|permanent)\b/.exec(location.hash);
    if (st) { setNamed(st[1]); return; }
    var m = /(?:^#|&)t=([0-9.eE+-]+)/.exec(location.hash);
    setFraction(m ? parseFloat(m[1]) : 0, false);
  }

  // play: the fold in real time, but at least 4 s and at most 12 s per pass
  var playing = false, last = 0;
  function seconds() { return Math.min(12, Math.max(4, cur.end)); }
  function tick(now) {
    if (!playing) return;
    var dt = last ? (now - last) / 1000 : 0;
    last = now;
    var f = state.named ? 0 : state.frac + dt / seconds();
    if (f >= 1) { setFraction(1, true); stop(); return; }
    setFraction(f, false);
    requestAnimationFrame(tick);
  }
  function stop() { playing = false; playBtn.innerHTML = "&#9654; play"; history.replaceState(null, "", runHash() + "t=" + state.frac.toFixed(3)); }
  playBtn.addEventListener("click", function () {
    if (playing) { stop(); return; }
    if (state.frac >= 1) setFraction(0, false);
    playing = true; last = 0; playBtn.innerHTML = "&#10074;&#10074; pause";
    requestAnimationFrame(tick);
  });
  slider.addEventListener("input", function () { if (playing) stop(); setFraction(slider.value / 1000, true); });
  document.getElementById("programmed").addEventListener("click", function () { if (playing) stop(); setNamed("programmed", true); });
  document.getElementById("permanent").addEventListener("click", function () { if (playing) stop(); setNamed("permanent", true); });
  window.addEventListener("hashchange", fromHash);
  if (followBtn) followBtn.addEventListener("click", function () {
    setFollow(!follow);
    if (follow && lastShown) show(lastShown[0], lastShown[1], lastShown[2], state.named ? null : state.frac * cur.end);
  });

  function resize() {
    var w = stage.clientWidth, h = Math.round(Math.min(w * 9 / 16, window.innerHeight * 0.7));
    renderer.setSize(w, h, true);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    if (follow && lastShown) fit(frameBox(lastShown[0], lastShown[1], lastShown[2]));  // the new aspect
    draw();
  }
  window.addEventListener("resize", resize);

  // legend, facts, contact marks on the time track
  function esc(s) { return String(s).replace(/[&<>"]/g, function (c) { return {"&": "&amp;", "<": "&lt;", ">": "&gt;", "\"": "&quot;"}[c]; }); }
  var used = {};
  D.hinges.forEach(function (h) { (used[h.material] = used[h.material] || []).push(h.id); });
  var legend = "<h2>Hinge materials</h2><ul>";
  var ramp = D.ramp || null;  // continuous / graded VeroWhite fractions (docs/composition.md)
  Object.keys(used).sort().forEach(function (m) {
    var bg = ramp && ramp.swatches[m] ? ramp.swatches[m] : (D.colors[m] || "#9a9a9a");
    legend += "<li><span class=\"swatch\" style=\"background:" + esc(bg) + "\"></span>" +
      esc(m) + " <span class=\"muted\">(" + esc(used[m].join(", ")) +
      (ramp && ramp.labels[m] ? "; " + esc(ramp.labels[m]) : "") + ")</span></li>";
  });
  if (ramp) {
    legend += "<li><span class=\"ramp\" style=\"background:linear-gradient(to right, " + esc(ramp.tangoblack) + ", " +
      esc(ramp.verowhite) + ")\"></span> TangoBlack 0 &rarr; VeroWhite 1 <span class=\"muted\">(usable " +
      ramp.range[0].toFixed(3) + "&ndash;" + ramp.range[1].toFixed(3) + "; graded hinges drawn in their mean colour)</span></li>";
  }
  var panelMats = {};
  D.panels.forEach(function (p) { panelMats[p.material] = true; });
  Object.keys(panelMats).sort().forEach(function (m) {
    legend += "<li><span class=\"swatch\" style=\"background:" + esc(D.colors[m] || "#9a9a9a") + "\"></span>" +
      esc(m) + " <span class=\"muted\">(panels)</span></li>";
  });
  document.getElementById("legend").innerHTML = legend + "</ul>";
  // the facts and the contact marks on the time track: of the run shown
  var marks = document.getElementById("marks");
  function describe() {
    var c0 = cur.contacts;
    var facts = "<h2>" + (run === "worst" ? "Worst of " + D.robust.samples + " scatter samples (#" + D.worst.sample + ")"
                                          : "This fold" + (D.worst ? " (nominal)" : "")) + "</h2><ul>";
    if (run === "worst") facts += "<li>" + esc(D.worst.why) + "</li>";
    facts += "<li>bath " + cur.bath_c.toFixed(2).replace(/\.?0+$/, "") + " \u00b0C, " + esc(D.model) +
      " hinges; the slider spans 0 to " + cur.end.toFixed(2) + " s</li>";
    if (c0.length) {
      c0.forEach(function (c, i) {
        facts += "<li class=\"contact\"><button type=\"button\" data-c=\"" + i + "\">" +
          (i === 0 ? "first contact" : "contact") + "</button> panels " + esc(c.panels[0]) + "\u2013" +
          esc(c.panels[1]) + " at " + c.time.toFixed(3) + " s (" + esc(c.method) + ")</li>";
      });
      if (D.after_contact === "stop")
        facts += "<li class=\"muted\">After the first contact the model moves on kinematically; the real part jams there.</li>";
    } else {
      facts += "<li>no contact</li>";
    }
    if (D.mechanics && run !== "worst") {
      facts += "<li" + (D.mechanics.max_strain > D.mechanics.limit ? " class=\"contact\"" : "") +
        ">bar-and-hinge model: largest panel strain " + (100 * D.mechanics.max_strain).toFixed(3) + " % (limit " +
        (100 * D.mechanics.limit).toFixed(1) + " %), largest diagonal fold " + D.mechanics.max_bending_deg.toFixed(2) +
        "\u00b0</li>";
    }
    if (D.robust) {
      facts += "<li>jam probability " + (100 * D.robust.jam_probability).toFixed(1) + " % (95 % CI " +
        (100 * D.robust.ci95[0]).toFixed(1) + "\u2013" + (100 * D.robust.ci95[1]).toFixed(1) + " %) in " +
        D.robust.samples + " samples, seed " + D.robust.seed + "</li>";
    }
    document.getElementById("facts").innerHTML = facts + "</ul>";
    marks.innerHTML = "";
    c0.forEach(function (c) {
      var f = Math.min(1, c.time / cur.end), m = document.createElement("span");
      m.className = "mark";
      m.style.left = (100 * f) + "%";
      m.title = "contact " + c.panels[0] + "\u2013" + c.panels[1] + " at " + c.time.toFixed(3) + " s";
      marks.appendChild(m);
    });
    Array.prototype.forEach.call(document.querySelectorAll("#facts button[data-c]"), function (b) {
      b.addEventListener("click", function () {
        if (playing) stop();
        setFraction(Math.min(1, cur.contacts[+b.getAttribute("data-c")].time / cur.end), true);
      });
    });
  }

  // the run toggle: only when a worst sample was replayed
  var runsBox = document.getElementById("runs");
  if (D.worst && runsBox) {
    runsBox.innerHTML = "<button id=\"run-nominal\" type=\"button\">nominal fold</button>" +
      "<button id=\"run-worst\" type=\"button\" title=\"" + esc(D.worst.why) + "\">worst sample (#" +
      D.worst.sample + ")</button>";
    Object.keys(RUNS).forEach(function (n) {
      document.getElementById("run-" + n).addEventListener("click", function () {
        if (playing) stop();
        var named = state.named;
        setRun(n);
        if (named) setNamed(named, true); else setFraction(state.frac, true);
      });
    });
  }
  setRun("nominal");
  setFollow(true);

  resize();
  fromHash();
  var rect = canvas.getBoundingClientRect();  // for tests and screenshots: where the 3D view is
  document.body.setAttribute("data-canvas", [rect.left, rect.top, rect.width, rect.height].map(Math.round).join(","));
  document.body.setAttribute("data-ready", "1");
})();
