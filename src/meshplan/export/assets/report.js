/* meshplan report.html: the 3D view (plotly) and the annotation editor.
 *
 * Data come from the JSON in #meshplan-data (see meshplan/export/report.py; the meshes are
 * packed by meshplan/export/view3d.py and decoded by decodeLayer, once the browser has inflated
 * them, before the plot is made). Everything is in the plan frame (metres, +y up) except what
 * is exported, which goes back to the scan's own coordinates and units. A click is turned into
 * a ray with the camera plotly draws with, and the ray is cast against the faces shown, so that
 * the point picked lies on the surface under the cursor (on the faces as decoded: within a
 * tenth of a millimetre of those shown on a 10 m story, which are the scan's own, or for a large
 * scan its surface simplified on a grid of a few centimetres; plotly's own click data only give
 * the nearest vertex).
 *
 * plotly's turntable rotation keeps its z axis up, so the plot shows plan (x, y, z) as plotly
 * (x, -z, y): a proper rotation (no mirror), with y up and, seen from above, x to the right and
 * z down the screen as on the plans. The z axis ticks are relabelled to read plan z.
 */
(function () {
  "use strict";

  var DATA = JSON.parse(document.getElementById("meshplan-data").textContent);
  var gd = document.getElementById("model3d");
  var t0 = performance.now();
  var api = (window.meshplanReport = { ready: false, error: null, lastPlotlyClick: null, pending: null, timing: {} });

  // ---------------------------------------------------------------------------------------
  // Geometry

  function bytesOf(b64) {
    var bin = atob(b64);
    var n = bin.length;
    var out = new Uint8Array(n);
    for (var i = 0; i < n; i++) out[i] = bin.charCodeAt(i);
    return out;
  }

  // A block of the page's data: base64 of zlib (deflate) bytes, inflated by the browser itself
  // (DecompressionStream: Chrome/Edge 80+, Firefox 113+, Safari 16.4+; nothing is fetched).
  function inflate(b64) {
    if (typeof DecompressionStream === "undefined") {
      return Promise.reject(new Error("this browser cannot inflate the model (no DecompressionStream)"));
    }
    var stream = new Blob([bytesOf(b64)]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer();
  }

  // A layer as meshplan.export.view3d._layer_data packs it: uint16 coordinates on the layer's
  // box (x = origin + q * step, as decode_positions), given per axis as the low and then the
  // high bytes of their differences from vertex to vertex, modulo 65536 (as unpack_positions);
  // and faces as back-references to the vertices in first-use order (index = next - code,
  // where next is the first vertex not yet seen, one on after each 0 code; as decode_faces).
  function decodeLayer(m) {
    var nv = m.n_vertices, nf = m.n_faces;
    return Promise.all([inflate(m.positions), inflate(m.faces)]).then(function (blocks) {
      var wide = m.face_dtype === "uint32";
      if (blocks[0].byteLength !== 6 * nv || blocks[1].byteLength !== (wide ? 12 : 6) * nf) {
        throw new Error("the data of layer " + m.name + " do not match its size");
      }
      var b = new Uint8Array(blocks[0]), o = m.position_origin, st = m.position_step;
      var pos = new Float32Array(3 * nv);
      for (var a = 0; a < 3; a++) {
        var lo = 2 * a * nv, hi = lo + nv, q = 0;
        for (var n = 0; n < nv; n++) {
          q = (q + (b[lo + n] | (b[hi + n] << 8))) & 0xffff;
          pos[a * nv + n] = o[a] + q * st[a];
        }
      }
      var codes = wide ? new Uint32Array(blocks[1]) : new Uint16Array(blocks[1]);
      var idx = new Uint32Array(3 * nf), next = 0;
      for (var f = 0; f < nf; f++) {
        for (var c = 0; c < 3; c++) {
          var code = codes[3 * f + c];
          idx[c * nf + f] = next - code; // i, j and k blocks, as plotly wants them
          if (code === 0) next++;
        }
      }
      if (next !== nv) throw new Error("the faces of layer " + m.name + " do not match its vertices");
      return {
        name: m.name, role: m.role, story: m.story, color: m.color, visible: m.visible,
        nv: nv, nf: nf,
        x: pos.subarray(0, nv), y: pos.subarray(nv, 2 * nv), z: pos.subarray(2 * nv, 3 * nv),
        i: idx.subarray(0, nf), j: idx.subarray(nf, 2 * nf), k: idx.subarray(2 * nf, 3 * nf)
      };
    });
  }

  var meshes = []; // the decoded layers, once decodeLayer has made them (see the end)

  // plan frame <-> plotly's axes (see the top of this file)
  function toPlot(p) { return [p[0], -p[2], p[1]]; }
  function fromPlot(q) { return [q[0], q[2], -q[1]]; }

  // 4x4 matrices are column-major arrays (as gl-matrix and plotly's cameraParams).
  function mul(a, b) {
    var out = new Array(16);
    for (var c = 0; c < 4; c++) {
      for (var r = 0; r < 4; r++) {
        var s = 0;
        for (var k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
        out[c * 4 + r] = s;
      }
    }
    return out;
  }

  function apply(m, v) {
    var out = [0, 0, 0, 0];
    for (var r = 0; r < 4; r++) out[r] = m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2] + m[12 + r] * v[3];
    return out;
  }

  function invert(a) {
    var a00 = a[0], a01 = a[1], a02 = a[2], a03 = a[3], a10 = a[4], a11 = a[5], a12 = a[6], a13 = a[7];
    var a20 = a[8], a21 = a[9], a22 = a[10], a23 = a[11], a30 = a[12], a31 = a[13], a32 = a[14], a33 = a[15];
    var b00 = a00 * a11 - a01 * a10, b01 = a00 * a12 - a02 * a10, b02 = a00 * a13 - a03 * a10;
    var b03 = a01 * a12 - a02 * a11, b04 = a01 * a13 - a03 * a11, b05 = a02 * a13 - a03 * a12;
    var b06 = a20 * a31 - a21 * a30, b07 = a20 * a32 - a22 * a30, b08 = a20 * a33 - a23 * a30;
    var b09 = a21 * a32 - a22 * a31, b10 = a21 * a33 - a23 * a31, b11 = a22 * a33 - a23 * a32;
    var det = b00 * b11 - b01 * b10 + b02 * b09 + b03 * b08 - b04 * b07 + b05 * b06;
    if (!det) return null;
    det = 1.0 / det;
    return [
      (a11 * b11 - a12 * b10 + a13 * b09) * det, (a02 * b10 - a01 * b11 - a03 * b09) * det,
      (a31 * b05 - a32 * b04 + a33 * b03) * det, (a22 * b04 - a21 * b05 - a23 * b03) * det,
      (a12 * b08 - a10 * b11 - a13 * b07) * det, (a00 * b11 - a02 * b08 + a03 * b07) * det,
      (a32 * b02 - a30 * b05 - a33 * b01) * det, (a20 * b05 - a22 * b02 + a23 * b01) * det,
      (a10 * b10 - a11 * b08 + a13 * b06) * det, (a01 * b08 - a00 * b10 - a03 * b06) * det,
      (a30 * b04 - a31 * b02 + a33 * b00) * det, (a21 * b02 - a20 * b04 - a23 * b00) * det,
      (a11 * b07 - a10 * b09 - a12 * b06) * det, (a00 * b09 - a01 * b07 + a02 * b06) * det,
      (a31 * b01 - a30 * b03 - a32 * b00) * det, (a20 * b03 - a21 * b01 + a22 * b00) * det
    ];
  }

  // What plotly draws with: clip = projection . view . model . (data * dataScale), on the
  // scene's canvas (the same mapping plotly uses to place its 3D annotations).
  function sceneCamera() {
    var sc = gd._fullLayout && gd._fullLayout.scene && gd._fullLayout.scene._scene;
    if (!sc || !sc.glplot || !sc.glplot.cameraParams || !sc.glplot.cameraParams.view) return null;
    var cp = sc.glplot.cameraParams;
    return {
      m: mul(cp.projection, mul(cp.view, cp.model)),
      s: sc.dataScale,
      rect: sc.glplot.canvas.getBoundingClientRect()
    };
  }

  // where a plan-frame point is drawn, in client (CSS) pixels
  function toScreen(p) {
    var cam = sceneCamera();
    if (!cam) return null;
    var q = toPlot(p);
    var c = apply(cam.m, [q[0] * cam.s[0], q[1] * cam.s[1], q[2] * cam.s[2], 1]);
    if (!(c[3] > 0)) return null;
    return {
      x: cam.rect.left + 0.5 * (1 + c[0] / c[3]) * cam.rect.width,
      y: cam.rect.top + 0.5 * (1 - c[1] / c[3]) * cam.rect.height
    };
  }

  function clickRay(clientX, clientY) {
    var cam = sceneCamera();
    if (!cam) return null;
    var inv = invert(cam.m);
    if (!inv) return null;
    var nx = (2 * (clientX - cam.rect.left)) / cam.rect.width - 1;
    var ny = 1 - (2 * (clientY - cam.rect.top)) / cam.rect.height;
    var a = apply(inv, [nx, ny, -1, 1]), b = apply(inv, [nx, ny, 1, 1]);
    var o = [], d = [];
    for (var q = 0; q < 3; q++) {
      o[q] = a[q] / a[3] / cam.s[q];
      d[q] = b[q] / b[3] / cam.s[q] - o[q];
    }
    return { o: fromPlot(o), d: fromPlot(d) };
  }

  function isShown(traceIndex) {
    var v = gd.data[traceIndex].visible;
    return v === undefined || v === true;
  }

  // Moller-Trumbore against every face of a layer: the nearest face the ray goes through. A
  // large scan is shown simplified (vertex clustering: a closed surface, no gaps between its
  // faces), so the face hit is the surface drawn under the cursor (a point cloud's splats,
  // subsampled past the budget, leave gaps: a click there takes what is seen through them).
  function castLayer(m, ray, best) {
    var ox = ray.o[0], oy = ray.o[1], oz = ray.o[2], dx = ray.d[0], dy = ray.d[1], dz = ray.d[2];
    var X = m.x, Y = m.y, Z = m.z, I = m.i, J = m.j, K = m.k;
    for (var f = 0; f < m.nf; f++) {
      var a = I[f], b = J[f], c = K[f];
      var ax = X[a], ay = Y[a], az = Z[a];
      var e1x = X[b] - ax, e1y = Y[b] - ay, e1z = Z[b] - az;
      var e2x = X[c] - ax, e2y = Y[c] - ay, e2z = Z[c] - az;
      var px = dy * e2z - dz * e2y, py = dz * e2x - dx * e2z, pz = dx * e2y - dy * e2x;
      var det = e1x * px + e1y * py + e1z * pz;
      if (det > -1e-14 && det < 1e-14) continue;
      var idet = 1 / det;
      var sx = ox - ax, sy = oy - ay, sz = oz - az;
      var u = (sx * px + sy * py + sz * pz) * idet;
      if (u < 0 || u > 1) continue;
      var qx = sy * e1z - sz * e1y, qy = sz * e1x - sx * e1z, qz = sx * e1y - sy * e1x;
      var v = (dx * qx + dy * qy + dz * qz) * idet;
      if (v < 0 || u + v > 1) continue;
      var t = (e2x * qx + e2y * qy + e2z * qz) * idet;
      if (!(t > 0)) continue;
      if (!best.hit || t < best.hit.t) best.hit = { t: t, layer: m, face: f };
    }
  }

  function pick(clientX, clientY) {
    var ray = clickRay(clientX, clientY);
    if (!ray) return null;
    var best = { hit: null };
    meshes.forEach(function (m, li) {
      if (isShown(meshTrace[li])) castLayer(m, ray, best);
    });
    var hit = best.hit;
    if (!hit) return null;
    var m = hit.layer, f = hit.face;
    var a = m.i[f], b = m.j[f], c = m.k[f];
    var e1 = [m.x[b] - m.x[a], m.y[b] - m.y[a], m.z[b] - m.z[a]];
    var e2 = [m.x[c] - m.x[a], m.y[c] - m.y[a], m.z[c] - m.z[a]];
    var n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    var nl = Math.hypot(n[0], n[1], n[2]) || 1;
    var s = n[0] * ray.d[0] + n[1] * ray.d[1] + n[2] * ray.d[2] > 0 ? -1 / nl : 1 / nl; // towards the viewer
    return {
      position: [ray.o[0] + hit.t * ray.d[0], ray.o[1] + hit.t * ray.d[1], ray.o[2] + hit.t * ray.d[2]],
      direction: [n[0] * s, n[1] * s, n[2] * s],
      layer: m.name,
      face: f
    };
  }

  // ---------------------------------------------------------------------------------------
  // Annotations

  var items = DATA.annotations.map(function (a) { return Object.assign({}, a); });

  function storyOf(y) {
    for (var s = 0; s < DATA.stories.length; s++) {
      var st = DATA.stories[s];
      if ((st.top === null || y < st.top) && (st.bottom === null || y >= st.bottom)) return st.index;
    }
    return null;
  }

  // plan frame -> the scan file's coordinates (inverse transform, then back to its units)
  function toInputPoint(p) {
    var T = DATA.to_input, k = DATA.scale_to_m, out = [];
    for (var r = 0; r < 3; r++) out[r] = (T[r][0] * p[0] + T[r][1] * p[1] + T[r][2] * p[2] + T[r][3]) / k;
    return out;
  }

  function toInputDirection(d) {
    var T = DATA.to_input, out = [];
    for (var r = 0; r < 3; r++) out[r] = T[r][0] * d[0] + T[r][1] * d[1] + T[r][2] * d[2];
    var l = Math.hypot(out[0], out[1], out[2]) || 1;
    return out.map(function (c) { return c / l; });
  }

  function round6(v) { return Number(v.toFixed(6)) + 0; }

  function exportDocument() {
    return {
      annotations: items.map(function (a) {
        var out = { label: a.label, kind: a.kind, position: a.input_position.map(round6) };
        if (a.input_direction) out.direction = a.input_direction.map(round6);
        return out;
      })
    };
  }

  function suggestLabel(kind) {
    var prefix = DATA.kind_prefix[kind] || "A";
    var used = {};
    items.forEach(function (a) { used[a.label] = true; });
    for (var n = 1; ; n++) if (!used[prefix + n]) return prefix + n;
  }

  // ---------------------------------------------------------------------------------------
  // Plot

  // The traces are made once the layers are decoded (buildTraces): a mesh3d a layer, then the
  // markers and probes of each kind of annotation, then the point picked.
  var traces = [], meshTrace = [], kindTrace = {}, probeTrace = {}, pendingTrace;
  var drawn = false; // Plotly.newPlot was called: the traces can be restyled

  function buildTraces() {
    meshes.forEach(function (m, li) {
      meshTrace[li] = traces.length;
      traces.push({
        type: "mesh3d", name: m.name, x: m.x, y: m.z.map(function (c) { return -c; }), z: m.y, i: m.i, j: m.j, k: m.k,
        color: m.color, flatshading: true, showlegend: true, hoverinfo: "none",
        // plotly's default epsilons zero the normals of small faces (scaled to the scene box,
        // a scan's faces are tiny), which leaves them flat grey without any shading
        lighting: { ambient: 0.45, diffuse: 0.8, specular: 0.05, roughness: 0.8, fresnel: 0.1, facenormalsepsilon: 0, vertexnormalsepsilon: 0 },
        lightposition: { x: 3e4, y: -2e4, z: 1e5 },
        visible: m.visible ? true : "legendonly"
      });
    });
    DATA.kinds.forEach(function (k) {
      var col = DATA.kind_colors[k];
      kindTrace[k] = traces.length;
      traces.push({
        type: "scatter3d", mode: "markers+text", name: k, legendgroup: k, x: [], y: [], z: [], text: [],
        marker: { size: 5, color: col, line: { color: "#ffffff", width: 1 } },
        textposition: "top center", textfont: { size: 11, color: col },
        hovertemplate: "%{text} (" + k + ")<extra></extra>"
      });
      probeTrace[k] = traces.length;
      traces.push({
        type: "scatter3d", mode: "lines", name: k + " probes", legendgroup: k, showlegend: false,
        x: [], y: [], z: [], line: { color: col, width: 5 }, hoverinfo: "skip"
      });
    });
    pendingTrace = traces.length;
    traces.push({
      type: "scatter3d", mode: "markers+lines", name: "picked point", showlegend: false, x: [], y: [], z: [],
      marker: { size: 6, color: "#111111", symbol: "diamond" }, line: { color: "#111111", width: 4 }, hoverinfo: "skip"
    });
    fillInitial();
  }

  function annotationArrays() {
    var upd = { x: [], y: [], z: [], text: [] }, ids = [];
    DATA.kinds.forEach(function (k) {
      var mx = [], my = [], mz = [], mt = [], lx = [], ly = [], lz = [];
      items.forEach(function (a) {
        if (a.kind !== k || !a.position) return;
        var p = toPlot(a.position);
        mx.push(p[0]); my.push(p[1]); mz.push(p[2]); mt.push(a.label);
        if (a.direction) {
          var d = toPlot(a.direction), L = DATA.probe_m;
          lx.push(p[0], p[0] + L * d[0], null); ly.push(p[1], p[1] + L * d[1], null); lz.push(p[2], p[2] + L * d[2], null);
        }
      });
      ids.push(kindTrace[k]); upd.x.push(mx); upd.y.push(my); upd.z.push(mz); upd.text.push(mt);
      ids.push(probeTrace[k]); upd.x.push(lx); upd.y.push(ly); upd.z.push(lz); upd.text.push([]);
    });
    return { upd: upd, ids: ids };
  }

  function pendingArrays() {
    var p = api.pending;
    if (!p) return { x: [[]], y: [[]], z: [[]] };
    var d = toPlot(p.direction), L = DATA.probe_m, q = toPlot(p.position);
    return { x: [[q[0], q[0] + L * d[0]]], y: [[q[1], q[1] + L * d[1]]], z: [[q[2], q[2] + L * d[2]]] };
  }

  function fillInitial() {
    var a = annotationArrays();
    a.ids.forEach(function (ti, n) {
      traces[ti].x = a.upd.x[n]; traces[ti].y = a.upd.y[n]; traces[ti].z = a.upd.z[n];
      if (traces[ti].mode !== "lines") traces[ti].text = a.upd.text[n];
    });
  }

  // from above, seen from the bottom of the plan (plan +z); and straight from above
  var CAM_3D = { eye: { x: 0.35, y: -1.45, z: 1.5 }, up: { x: 0, y: 0, z: 1 }, center: { x: 0, y: 0, z: -0.1 } };
  var CAM_TOP = { eye: { x: 0, y: -0.001, z: 2.0 }, up: { x: 0, y: 0, z: 1 }, center: { x: 0, y: 0, z: 0 } };
  var axis = function (title) {
    return { title: { text: title }, backgroundcolor: "#f4f5f7", gridcolor: "#d9dde3", zerolinecolor: "#b9c0ca", showspikes: false };
  };
  // plotly's y axis holds -z: label its ticks with plan z
  function zAxis() {
    var lo = Infinity, hi = -Infinity;
    meshes.forEach(function (m) { for (var n = 0; n < m.nv; n++) { var c = m.z[n]; if (c < lo) lo = c; if (c > hi) hi = c; } });
    var ax = axis("z (m)");
    if (!(hi >= lo)) return ax;
    var step = hi - lo > 40 ? 10 : hi - lo > 16 ? 4 : hi - lo > 8 ? 2 : 1;
    ax.tickvals = []; ax.ticktext = [];
    for (var t = Math.ceil(lo / step) * step; t <= hi; t += step) { ax.tickvals.push(-t); ax.ticktext.push(String(t)); }
    return ax;
  }
  function makeLayout() {
    return {
      margin: { l: 0, r: 0, t: 0, b: 0 },
      paper_bgcolor: "#f4f5f7",
      uirevision: "meshplan",
      legend: { x: 0.01, y: 0.99, bgcolor: "rgba(255,255,255,0.85)", bordercolor: "#d9dde3", borderwidth: 1 },
      scene: {
        aspectmode: "data", dragmode: "turntable", camera: CAM_3D,
        xaxis: axis("x (m)"), yaxis: zAxis(), zaxis: axis("y (m), up")
      }
    };
  }
  var config = { displaylogo: false, responsive: true, scrollZoom: true };

  function redrawAnnotations() {
    if (!drawn) return Promise.resolve(); // the plot, when made, draws the annotations as they are then
    var a = annotationArrays();
    var p = pendingArrays();
    var ids = a.ids.concat([pendingTrace]);
    return Plotly.restyle(gd, {
      x: a.upd.x.concat(p.x), y: a.upd.y.concat(p.y), z: a.upd.z.concat(p.z),
      text: a.upd.text.concat([[]])
    }, ids);
  }

  // ---------------------------------------------------------------------------------------
  // Panel

  var $ = function (id) { return document.getElementById(id); };
  var kindSel = $("ann-kind"), labelIn = $("ann-label"), addBtn = $("ann-add"), cancelBtn = $("ann-cancel");
  var errBox = $("ann-error"), pendingBox = $("pending"), tbody = $("ann-table").querySelector("tbody");
  var labelEdited = false;

  function fmt(p) { return p ? p.map(function (c) { return c.toFixed(3); }).join(", ") : "—"; }

  function renderTable() {
    tbody.textContent = "";
    items.forEach(function (a, n) {
      var tr = document.createElement("tr");
      tr.setAttribute("data-label", a.label);
      var sw = document.createElement("span");
      sw.className = "swatch";
      sw.style.background = DATA.kind_colors[a.kind];
      var cells = [a.label, a.kind, a.story === null || a.story === undefined ? "—" : String(a.story), fmt(a.position)];
      cells.forEach(function (text, ci) {
        var td = document.createElement("td");
        if (ci === 1) td.appendChild(sw);
        td.appendChild(document.createTextNode(text));
        tr.appendChild(td);
      });
      var td = document.createElement("td");
      var del = document.createElement("button");
      del.type = "button";
      del.className = "ann-delete";
      del.textContent = "delete";
      del.title = "Delete " + a.label;
      del.addEventListener("click", function () {
        items.splice(n, 1);
        renderTable();
        redrawAnnotations();
        if (!labelEdited) labelIn.value = suggestLabel(kindSel.value);
      });
      td.appendChild(del);
      tr.appendChild(td);
      tbody.appendChild(tr);
    });
  }

  function setPending(p) {
    api.pending = p;
    errBox.textContent = "";
    if (p) {
      pendingBox.className = "pending picked";
      pendingBox.textContent = "Picked (" + fmt(p.position) + ") m on " + p.layer + ", facing (" +
        p.direction.map(function (c) { return c.toFixed(2); }).join(", ") + ").";
      if (!labelEdited || !labelIn.value) { labelIn.value = suggestLabel(kindSel.value); labelEdited = false; }
    } else {
      pendingBox.className = "pending";
      pendingBox.textContent = "No point picked.";
    }
    addBtn.disabled = cancelBtn.disabled = !p;
    redrawAnnotations();
  }

  function addPending() {
    var p = api.pending;
    if (!p) return;
    var label = labelIn.value.trim();
    if (!label) { errBox.textContent = "Give a label."; return; }
    if (items.some(function (a) { return a.label === label; })) { errBox.textContent = "The label " + label + " is taken."; return; }
    items.push({
      label: label, kind: kindSel.value, story: storyOf(p.position[1]),
      position: p.position, direction: p.direction,
      input_position: toInputPoint(p.position), input_direction: toInputDirection(p.direction)
    });
    labelEdited = false;
    labelIn.value = "";
    renderTable();
    setPending(null);
  }

  function download() {
    var text = JSON.stringify(exportDocument(), null, 2) + "\n";
    var url = URL.createObjectURL(new Blob([text], { type: "application/json" }));
    var a = document.createElement("a");
    a.href = url;
    a.download = "annotations.json";
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(function () { URL.revokeObjectURL(url); }, 1000);
  }

  kindSel.addEventListener("change", function () { if (!labelEdited) labelIn.value = suggestLabel(kindSel.value); });
  labelIn.addEventListener("input", function () { labelEdited = true; });
  labelIn.addEventListener("keydown", function (ev) { if (ev.key === "Enter") addPending(); });
  addBtn.addEventListener("click", addPending);
  cancelBtn.addEventListener("click", function () { setPending(null); });
  $("ann-export").addEventListener("click", download);
  labelIn.value = suggestLabel(kindSel.value);
  renderTable();

  // a click is a press and release that did not move (a drag rotates the view)
  var down = null;
  gd.addEventListener("pointerdown", function (ev) {
    down = ev.button === 0 ? { x: ev.clientX, y: ev.clientY } : null;
  }, true);
  gd.addEventListener("pointerup", function (ev) {
    if (!down || ev.button !== 0) return;
    var moved = Math.hypot(ev.clientX - down.x, ev.clientY - down.y);
    down = null;
    if (moved > 4 || !api.ready) return;
    if (ev.target && ev.target.closest && ev.target.closest(".legend, .modebar, .modebar-container")) return;
    var cam = sceneCamera();
    if (!cam) return;
    var r = cam.rect;
    if (ev.clientX < r.left || ev.clientX > r.right || ev.clientY < r.top || ev.clientY > r.bottom) return;
    var hit = pick(ev.clientX, ev.clientY);
    if (hit) setPending(hit);
  }, true);

  // ---------------------------------------------------------------------------------------
  // View buttons

  function setCamera(cam) { return drawn ? Plotly.relayout(gd, { "scene.camera": cam }) : Promise.resolve(); }
  $("view-3d").addEventListener("click", function () { setCamera(CAM_3D); });
  $("view-top").addEventListener("click", function () { setCamera(CAM_TOP); });
  Array.prototype.forEach.call(document.querySelectorAll(".story-btn"), function (btn) {
    btn.addEventListener("click", function () {
      if (!drawn) return;
      var which = btn.getAttribute("data-story");
      var vis = [], ids = [];
      meshes.forEach(function (m, li) {
        var mine = which === "all" || String(m.story) === which;
        if (m.role === "scan") { ids.push(meshTrace[li]); vis.push(mine ? true : "legendonly"); }
        else if (!mine) { ids.push(meshTrace[li]); vis.push("legendonly"); }
      });
      Array.prototype.forEach.call(document.querySelectorAll(".story-btn"), function (b) { b.classList.toggle("active", b === btn); });
      Plotly.restyle(gd, { visible: vis }, ids);
    });
  });

  Object.assign(api, {
    data: DATA,
    meshes: meshes,
    traces: { mesh: meshTrace, kind: kindTrace, probe: probeTrace, pending: pendingTrace },
    toScreen: toScreen,
    pick: pick,
    annotations: function () { return items.slice(); },
    exportDocument: exportDocument,
    setCamera: setCamera
  });

  // ---------------------------------------------------------------------------------------
  // Start: inflate and decode the layers (asynchronous: DecompressionStream), then plot. The
  // panel above works meanwhile; api.ready is set once the plot is drawn, and any failure on
  // the way (no DecompressionStream, corrupt data, no WebGL) is put in api.error, on the
  // console and in place of the plot.
  function fail(err) {
    api.error = String(err);
    gd.textContent = "The 3D view could not be drawn: " + (err && err.message ? err.message : err);
    if (window.console) console.error("meshplan report: the 3D view could not be drawn:", err);
  }

  var started;
  try {
    started = Promise.all(DATA.meshes.map(decodeLayer));
  } catch (err) {
    started = Promise.reject(err);
  }
  started.then(function (decoded) {
    meshes = api.meshes = decoded;
    api.timing.decode_ms = performance.now() - t0;
    buildTraces();
    api.traces = { mesh: meshTrace, kind: kindTrace, probe: probeTrace, pending: pendingTrace };
    var t1 = performance.now();
    var plotted;
    try {
      plotted = Plotly.newPlot(gd, traces, makeLayout(), config);
    } catch (err) {
      throw new Error("it needs WebGL (" + err + ")");
    }
    drawn = true;
    return plotted.then(function () {
      gd.on("plotly_click", function (ev) {
        var pt = ev && ev.points && ev.points[0];
        if (pt) api.lastPlotlyClick = { curveNumber: pt.curveNumber, pointNumber: pt.pointNumber, position: fromPlot([pt.x, pt.y, pt.z]) };
      });
      api.timing.plot_ms = performance.now() - t1;
      api.ready = true;
    });
  }).catch(fail);
})();
