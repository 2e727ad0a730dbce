/* eval/viewer/viewer.js: the report you can watch. Reads report.js (TND_REPORT: sources, frames,
 * per-frame metrics, settings) and, on demand, frames/fNNNN.js (TND_FRAME: one RGBE PNG data URI
 * per source, linear HDR), tone-maps them here as eval does (exposure x linear, ACES fit, sRGB)
 * and shows them: A/B swipe, side by side (zoom and pan linked), false-colour error, FLIP maps;
 * a scrubber, play/pause at the run's frame rate, plots linked to the scrubber. Plain script, no
 * network. For tests, <body> carries data-ready, data-frame, data-shown (a checksum of the
 * shown pixels; "flip" once a FLIP map is drawn), data-zoom and data-errors. */
(function () {
  "use strict";
  var body = document.body;
  var errors = [];
  function fail(msg) {
    errors.push(String(msg));
    body.setAttribute("data-errors", errors.join(" | "));
  }
  window.addEventListener("error", function (e) { fail(e.message); });
  var R = window.TND_REPORT;
  if (!R) {
    fail("report.js did not load");
    return;
  }
  var W = R.width, H = R.height, N = R.frames.length, S = R.sources.length;
  var PALETTE = ["#e6e6e6", "#ff8c42", "#4cc9f0", "#90be6d", "#f94144", "#b5179e", "#f9c74f", "#577590"];
  var st = { frame: 0, a: S > 1 ? 1 : 0, b: 0, mode: "swipe", split: 0.5, ev: 0, zoom: 1, px: 0, py: 0,
             playing: false };
  var hdr = {};      /* frame index -> [Float32Array (W x H x 3) per source] */
  var loading = {};  /* frame index -> true while its script and images load */
  var toned = {};    /* "frame/source/ev" -> canvas of the tone-mapped image */
  var flipImg = {};  /* "frame/series" -> Image of the FLIP map */
  var $ = function (id) { return document.getElementById(id); };

  /* ---- decoding ---------------------------------------------------------------------------- */
  function pad(n) { return ("000" + n).slice(-4); }
  window.TND_FRAME = function (k, uris) {
    var out = new Array(uris.length), left = uris.length;
    uris.forEach(function (uri, s) {
      var img = new Image();
      img.onload = function () {
        var c = document.createElement("canvas");
        c.width = W; c.height = H;
        var g = c.getContext("2d");
        g.drawImage(img, 0, 0);
        var px = g.getImageData(0, 0, W, H).data, f = new Float32Array(W * H * 3);
        for (var i = 0, n = W * H; i < n; i++) {
          var e = px[4 * i + 3];
          var sc = e ? Math.pow(2, e - 136) : 0;
          f[3 * i] = e ? (px[4 * i] + 0.5) * sc : 0;
          f[3 * i + 1] = e ? (px[4 * i + 1] + 0.5) * sc : 0;
          f[3 * i + 2] = e ? (px[4 * i + 2] + 0.5) * sc : 0;
        }
        out[s] = f;
        if (--left === 0) {
          hdr[k] = out;
          delete loading[k];
          if (k === st.frame)
            render();
        }
      };
      img.onerror = function () { fail("frame " + k + ": image " + s + " does not decode"); };
      img.src = uri;
    });
  };
  function load(k) {
    if (k < 0 || k >= N || hdr[k] || loading[k])
      return;
    loading[k] = true;
    var s = document.createElement("script");
    s.src = "frames/f" + pad(R.frames[k]) + ".js";
    s.onerror = function () { fail("missing " + s.src); };
    document.head.appendChild(s);
  }

  /* ---- tone mapping (eval/metrics.c's ev_tonemap) --------------------------------------------- */
  function srgb(y) { return y <= 0.0031308 ? 12.92 * y : 1.055 * Math.pow(y, 1 / 2.4) - 0.055; }
  function tone(x) {
    x = x > 0 ? x : 0;
    var y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
    return srgb(y < 0 ? 0 : y > 1 ? 1 : y);
  }
  function canvasOf(k, s) {
    var key = k + "/" + s + "/" + st.ev;
    if (toned[key])
      return toned[key];
    var f = hdr[k][s], c = document.createElement("canvas");
    c.width = W; c.height = H;
    var g = c.getContext("2d"), im = g.createImageData(W, H), d = im.data;
    var e = R.exposure * Math.pow(2, st.ev);
    for (var i = 0, n = W * H; i < n; i++) {
      d[4 * i] = 255 * tone(f[3 * i] * e) + 0.5;
      d[4 * i + 1] = 255 * tone(f[3 * i + 1] * e) + 0.5;
      d[4 * i + 2] = 255 * tone(f[3 * i + 2] * e) + 0.5;
      d[4 * i + 3] = 255;
    }
    g.putImageData(im, 0, 0);
    toned[key] = c;
    return c;
  }
  /* |A - B| / (B + 0.01) on luminance, in a magma-like ramp over [0, 1] */
  var RAMP = [[0, 0, 5], [59, 15, 112], [140, 41, 129], [222, 74, 104], [252, 159, 7], [252, 253, 191]];
  function errorCanvas(k) {
    var fa = hdr[k][st.a], fb = hdr[k][st.b], c = document.createElement("canvas");
    c.width = W; c.height = H;
    var g = c.getContext("2d"), im = g.createImageData(W, H), d = im.data;
    for (var i = 0, n = W * H; i < n; i++) {
      var ya = 0.2126 * fa[3 * i] + 0.7152 * fa[3 * i + 1] + 0.0722 * fa[3 * i + 2];
      var yb = 0.2126 * fb[3 * i] + 0.7152 * fb[3 * i + 1] + 0.0722 * fb[3 * i + 2];
      var t = Math.min(1, Math.abs(ya - yb) / (yb + 0.01)) * (RAMP.length - 1);
      var j = Math.min(RAMP.length - 2, Math.floor(t)), u = t - j;
      for (var ch = 0; ch < 3; ch++)
        d[4 * i + ch] = RAMP[j][ch] * (1 - u) + RAMP[j + 1][ch] * u;
      d[4 * i + 3] = 255;
    }
    g.putImageData(im, 0, 0);
    return c;
  }

  /* ---- the panes ------------------------------------------------------------------------------ */
  var base = Math.max(1, Math.min(4, Math.floor(480 / W)));
  var panes = [];
  function makePane(i) {
    var wrap = document.createElement("div"), c = document.createElement("canvas");
    var cap = document.createElement("div");
    wrap.className = "pane";
    cap.className = "cap";
    c.width = W * base; c.height = H * base;
    c.id = "view" + i;
    wrap.appendChild(c);
    wrap.appendChild(cap);
    $("views").appendChild(wrap);
    var drag = null;
    c.addEventListener("mousedown", function (ev) {
      var r = c.getBoundingClientRect(), x = ev.clientX - r.left;
      var swipe = st.mode === "swipe" && Math.abs(x - st.split * c.width) < 8;
      drag = { swipe: swipe, x: ev.clientX, y: ev.clientY, px: st.px, py: st.py };
      ev.preventDefault();
    });
    window.addEventListener("mousemove", function (ev) {
      if (!drag)
        return;
      var r = c.getBoundingClientRect();
      if (drag.swipe)
        st.split = Math.max(0, Math.min(1, (ev.clientX - r.left) / c.width));
      else
        st.px = drag.px + ev.clientX - drag.x, st.py = drag.py + ev.clientY - drag.y;
      draw();
    });
    window.addEventListener("mouseup", function () { drag = null; });
    c.addEventListener("wheel", function (ev) {
      ev.preventDefault();
      var r = c.getBoundingClientRect(), mx = ev.clientX - r.left, my = ev.clientY - r.top;
      var z = Math.max(1, Math.min(32, st.zoom * (ev.deltaY < 0 ? 1.25 : 0.8)));
      /* keep the image point under the cursor where it is */
      st.px = mx - (mx - st.px) * z / st.zoom;
      st.py = my - (my - st.py) * z / st.zoom;
      st.zoom = z;
      draw();
    }, { passive: false });
    return { canvas: c, cap: cap };
  }
  /* panes 0 and 1: images (read back for data-shown); pane 2: FLIP maps only, whose file images
   * taint the canvas they are drawn on */
  function layout() {
    while (panes.length < 3)
      panes.push(makePane(panes.length));
    var on = st.mode === "flip" ? [2] : st.mode === "side" ? [0, 1] : [0];
    panes.forEach(function (p, i) {
      p.canvas.parentNode.style.display = on.indexOf(i) >= 0 ? "" : "none";
    });
  }
  function place(g) {
    g.setTransform(1, 0, 0, 1, 0, 0);
    g.fillStyle = "#000";
    g.fillRect(0, 0, g.canvas.width, g.canvas.height);
    g.imageSmoothingEnabled = false;
    var k = base * st.zoom;
    g.setTransform(k, 0, 0, k, st.px, st.py);
  }
  function flipSeries() { return st.a > 0 ? st.a - 1 : st.b > 0 ? st.b - 1 : -1; }
  function draw() {
    var k = st.frame;
    if (!hdr[k])
      return;
    layout();
    var p0 = panes[st.mode === "flip" ? 2 : 0], g = p0.canvas.getContext("2d");
    place(g);
    if (st.mode === "swipe") {
      g.drawImage(canvasOf(k, st.a), 0, 0);
      g.save();
      g.setTransform(1, 0, 0, 1, 0, 0);
      g.beginPath();
      g.rect(st.split * p0.canvas.width, 0, p0.canvas.width, p0.canvas.height);
      g.clip();
      var kk = base * st.zoom;
      g.setTransform(kk, 0, 0, kk, st.px, st.py);
      g.drawImage(canvasOf(k, st.b), 0, 0);
      g.restore();
      g.setTransform(1, 0, 0, 1, 0, 0);
      g.fillStyle = "#fff";
      g.fillRect(Math.round(st.split * p0.canvas.width) - 1, 0, 2, p0.canvas.height);
      p0.cap.textContent = "A: " + R.sources[st.a] + "  |  B: " + R.sources[st.b];
    } else if (st.mode === "side") {
      g.drawImage(canvasOf(k, st.a), 0, 0);
      p0.cap.textContent = "A: " + R.sources[st.a];
      var g1 = panes[1].canvas.getContext("2d");
      place(g1);
      g1.drawImage(canvasOf(k, st.b), 0, 0);
      panes[1].cap.textContent = "B: " + R.sources[st.b];
    } else if (st.mode === "error") {
      g.drawImage(errorCanvas(k), 0, 0);
      p0.cap.textContent = "|A - B| / (B + 0.01): " + R.sources[st.a] + " against " + R.sources[st.b];
    } else {
      /* (a file image taints the canvas: no checksum; "flip" once the map is drawn) */
      var si = flipSeries(), shown = "flip-none";
      if (si < 0) {
        p0.cap.textContent = "FLIP: choose a series as A or B";
      } else {
        var key = k + "/" + si;
        if (!flipImg[key]) {
          flipImg[key] = new Image();
          flipImg[key].onload = draw;
          flipImg[key].onerror = function () { fail("missing FLIP map of frame " + k); };
          flipImg[key].src = "frames/f" + pad(R.frames[k]) + "_s" + si + "_flip.png";
        }
        shown = "flip-loading"; /* (drawn again when the map has loaded) */
        if (flipImg[key].complete && flipImg[key].naturalWidth) {
          g.drawImage(flipImg[key], 0, 0, W, H);
          shown = "flip";
        }
        p0.cap.textContent = "FLIP: " + R.sources[si + 1] + " against the reference";
      }
      body.setAttribute("data-shown", shown);
    }
    if (st.mode !== "flip")
      body.setAttribute("data-shown", checksum(p0.canvas));
    body.setAttribute("data-zoom", String(st.zoom));
  }
  function checksum(c) {
    var d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data, h = 2166136261;
    for (var i = 0; i < d.length; i += 7)
      h = Math.imul(h ^ d[i], 16777619) >>> 0;
    return String(h);
  }
  function render() {
    var k = st.frame;
    $("scrub").value = String(k);
    var m = [];
    ["relmse", "flip"].forEach(function (name) {
      var v = R.metrics[name];
      if (v && v.length > 0 && v[0][k] !== null)
        m.push(name + " " + v[0][k].toPrecision(4));
    });
    $("frameinfo").textContent = "frame " + R.frames[k] + " (" + (k + 1) + " of " + N + ")" +
      (m.length ? ", " + R.series[0] + ": " + m.join(", ") : "");
    body.setAttribute("data-frame", String(k));
    if (!hdr[k]) {
      load(k);
      return;
    }
    draw();
    plots();
    load(k + 1);
    if (!body.hasAttribute("data-ready"))
      body.setAttribute("data-ready", "1");
  }
  function show(k) {
    st.frame = Math.max(0, Math.min(N - 1, k));
    render();
  }

  /* ---- plots ---------------------------------------------------------------------------------- */
  var plotCanvases = [];
  function plots() {
    var names = Object.keys(R.metrics);
    if (!plotCanvases.length) {
      names.forEach(function (name) {
        var c = document.createElement("canvas");
        c.width = 340; c.height = 170;
        c.title = name + ": click to show a frame";
        c.setAttribute("data-metric", name);
        c.addEventListener("click", function (ev) {
          var r = c.getBoundingClientRect(), x = ev.clientX - r.left;
          show(Math.round((x - 40) / (c.width - 50) * Math.max(1, N - 1)));
        });
        $("plots").appendChild(c);
        plotCanvases.push(c);
      });
      $("legend").innerHTML = "";
      R.series.forEach(function (s, i) {
        var sp = document.createElement("span");
        sp.style.color = PALETTE[(i + 1) % PALETTE.length];
        sp.textContent = "\u25a0 " + s;
        $("legend").appendChild(sp);
      });
    }
    names.forEach(function (name, pi) {
      var c = plotCanvases[pi], g = c.getContext("2d"), v = R.metrics[name];
      var lo = Infinity, hi = -Infinity, logy = name === "relmse";
      v.forEach(function (row) {
        row.forEach(function (y) {
          if (y === null || (logy && y <= 0))
            return;
          var t = logy ? Math.log10(y) : y;
          lo = Math.min(lo, t); hi = Math.max(hi, t);
        });
      });
      if (!(hi > lo)) { hi = lo + 1; }
      g.fillStyle = "#26262c"; g.fillRect(0, 0, c.width, c.height);
      g.fillStyle = "#bbb"; g.font = "11px sans-serif";
      g.fillText(name + (logy ? " (log)" : ""), 40, 12);
      g.fillText((logy ? Math.pow(10, hi) : hi).toPrecision(3), 2, 24);
      g.fillText((logy ? Math.pow(10, lo) : lo).toPrecision(3), 2, c.height - 14);
      var X = function (k) { return 40 + (c.width - 50) * (N > 1 ? k / (N - 1) : 0.5); };
      var Y = function (y) { return 20 + (c.height - 40) * (1 - ((logy ? Math.log10(y) : y) - lo) / (hi - lo)); };
      v.forEach(function (row, si) {
        g.strokeStyle = PALETTE[(si + 1) % PALETTE.length];
        g.beginPath();
        var started = false;
        row.forEach(function (y, k) {
          if (y === null || (logy && y <= 0)) { started = false; return; }
          if (started) g.lineTo(X(k), Y(y)); else g.moveTo(X(k), Y(y));
          started = true;
        });
        g.stroke();
      });
      g.strokeStyle = "#fff";
      g.beginPath();
      g.moveTo(X(st.frame), 16); g.lineTo(X(st.frame), c.height - 18);
      g.stroke();
    });
  }

  /* ---- controls ------------------------------------------------------------------------------- */
  $("title").textContent = R.title;
  $("settings").textContent = JSON.stringify(R.settings, null, 1);
  ["srcA", "srcB"].forEach(function (id) {
    R.sources.forEach(function (s, i) {
      var o = document.createElement("option");
      o.value = String(i);
      o.textContent = s;
      $(id).appendChild(o);
    });
  });
  $("srcA").value = String(st.a);
  $("srcB").value = String(st.b);
  $("srcA").addEventListener("change", function () { st.a = +this.value; draw(); });
  $("srcB").addEventListener("change", function () { st.b = +this.value; draw(); });
  $("mode").addEventListener("change", function () { st.mode = this.value; draw(); });
  $("ev").addEventListener("input", function () {
    st.ev = +this.value;
    $("evinfo").textContent = (st.ev >= 0 ? "+" : "") + st.ev + " EV";
    toned = {};
    draw();
  });
  $("reset").addEventListener("click", function () { st.zoom = 1; st.px = st.py = 0; draw(); });
  var scrub = $("scrub");
  scrub.max = String(N - 1);
  scrub.addEventListener("input", function () { show(+this.value); });
  document.addEventListener("keydown", function (ev) {
    if (ev.key === "ArrowRight") show(st.frame + 1);
    else if (ev.key === "ArrowLeft") show(st.frame - 1);
    else if (ev.key === " ") { ev.preventDefault(); toggle(); }
  });
  var timer = null;
  function toggle() {
    st.playing = !st.playing;
    $("play").textContent = st.playing ? "pause" : "play";
    body.setAttribute("data-playing", st.playing ? "1" : "0");
    if (timer) { clearInterval(timer); timer = null; }
    if (st.playing)
      timer = setInterval(function () {
        var next = (st.frame + 1) % N;
        if (hdr[next]) show(next); else load(next);
      }, 1000 / (R.fps > 0 ? R.fps : 30));
  }
  $("play").addEventListener("click", toggle);
  show(0);
})();
