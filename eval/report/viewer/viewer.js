// texdefrag report viewer (classic script; needs lib/three.js loaded first as window.THREE).
// One WebGL canvas shows every view of one model (input and each configuration) side by side in
// scissored viewports, one camera and one orbit control for all. Data arrive as script files
// (file:// pages cannot fetch()): data/<key>_t<p>.js calls TD.texture, data/<key>_g<k>.js calls
// TD.chunk; chunks are added to the scene as they arrive (progressive loading).
/* global THREE */
(function () {
  'use strict';
  const TD = window.TD = window.TD || {};
  const manifest = TD.manifest;
  // contextLost: the browser took the WebGL context away (GPU process restart, driver reset);
  // nothing draws until it gives it back, then the viewer renders again by itself.
  const state = { model: null, mode: 'texture', views: {}, loading: 0, errors: [], contextLost: false };
  TD.state = state;

  // Chart and region colours: the same golden-ratio hues as the bench's PNG views.
  function idColour(id) {
    if (id < 0) return [0.6, 0.6, 0.6];
    const h = ((0.1 + 0.6180339887498949 * id) % 1) * 6;
    const s = Math.floor(id / 7) % 2 ? 0.55 : 0.85, v = Math.floor(id / 3) % 2 ? 0.75 : 0.95;
    const i = Math.floor(h) % 6, f = h - Math.floor(h);
    const p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    return [[v, t, p], [q, v, p], [p, v, t], [p, q, v], [t, p, v], [v, p, q]][i];
  }

  function decode(b64, Type) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; ++i) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }

  let renderer = null, camera = null, controls = null, canvas = null, host = null;
  let frameRequested = false;

  function layout(n) {
    const cols = Math.min(n, 3), rows = Math.ceil(n / cols);
    const width = host.clientWidth || 900;
    const cellW = Math.floor(width / cols), cellH = Math.floor(cellW * 0.75);
    return { cols, rows, cellW, cellH, width: cellW * cols, height: cellH * rows };
  }

  function requestRender() {
    if (frameRequested) return;
    frameRequested = true;
    requestAnimationFrame(render);
  }

  function render() {
    frameRequested = false;
    if (!renderer || !state.model) return;
    const m = state.model;
    const L = layout(m.views.length);
    renderer.setScissorTest(true);
    renderer.setClearColor(0xf4f4f4, 1);
    renderer.clear();
    m.views.forEach(function (v, i) {
      const x = (i % L.cols) * L.cellW, yTop = Math.floor(i / L.cols) * L.cellH;
      const y = L.height - yTop - L.cellH;
      renderer.setViewport(x + 1, y + 1, L.cellW - 2, L.cellH - 2);
      renderer.setScissor(x + 1, y + 1, L.cellW - 2, L.cellH - 2);
      renderer.setClearColor(0xffffff, 1);
      renderer.clear();
      const view = state.views[v.key];
      if (!view) return;
      for (const g of view.groups) {
        g.texture.visible = state.mode === 'texture';
        g.chart.visible = state.mode === 'chart';
        g.region.visible = state.mode === 'region';
      }
      renderer.render(view.scene, camera);
    });
  }

  function status(text) {
    const el = document.getElementById('viewer-status');
    if (el) el.textContent = text;
  }

  function labelViews(m) {
    const L = layout(m.views.length);
    const labels = document.getElementById('viewer-labels');
    labels.innerHTML = '';
    m.views.forEach(function (v, i) {
      const d = document.createElement('div');
      d.className = 'vlabel';
      d.style.left = ((i % L.cols) * L.cellW + 6) + 'px';
      d.style.top = (Math.floor(i / L.cols) * L.cellH + 4) + 'px';
      d.id = 'vlabel-' + v.key;
      d.textContent = v.label + ' \u2014 ' + v.faces.toLocaleString('en') + ' faces' +
        (v.too_large ? ': too large to view here (limit ' + manifest.max_faces.toLocaleString('en') + ' faces)' : '');
      labels.appendChild(d);
    });
  }

  function ensureRenderer() {
    if (renderer) return;
    host = document.getElementById('viewer');
    canvas = document.createElement('canvas');
    canvas.id = 'viewer-canvas';
    host.insertBefore(canvas, host.firstChild);
    renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(1);
    renderer.autoClear = false;
    camera = new THREE.PerspectiveCamera(40, 4 / 3, 0.01, 1e7);
    camera.up.set(0, 0, 1);
    controls = new THREE.OrbitControls(camera, canvas);
    controls.addEventListener('change', requestRender);
    watchContext(canvas);
    window.addEventListener('resize', function () { if (state.model) resize(state.model); });
  }

  // A lost context is kept restorable (preventDefault) and said on the status line; three.js
  // re-creates its GPU objects on restore, and the viewer draws the current model again.
  function watchContext(c) {
    c.addEventListener('webglcontextlost', function (e) {
      e.preventDefault();
      state.contextLost = true;
      status('WebGL context lost: waiting for the browser to restore it');
    });
    c.addEventListener('webglcontextrestored', function () {
      state.contextLost = false;
      status('WebGL context restored');
      requestRender();
    });
  }

  function resize(m) {
    const L = layout(m.views.length);
    renderer.setSize(L.width, L.height, true);
    camera.aspect = L.cellW / L.cellH;
    camera.updateProjectionMatrix();
    labelViews(m);
    requestRender();
  }

  function resetCamera(m) {
    const r = Math.max(m.radius, 1e-6);
    const az = 35 * Math.PI / 180, el = 40 * Math.PI / 180;
    const d = r / Math.sin(20 * Math.PI / 180);
    camera.near = d / 1000;
    camera.far = d * 10;
    camera.position.set(d * Math.cos(el) * Math.cos(az), d * Math.cos(el) * Math.sin(az), d * Math.sin(el));
    controls.target.set(0, 0, 0);
    camera.updateProjectionMatrix();
    controls.update();
  }

  function newView(v) {
    const scene = new THREE.Scene();
    scene.add(new THREE.AmbientLight(0xffffff, 0.55));
    const light = new THREE.DirectionalLight(0xffffff, 0.9);
    light.position.set(0.4, -0.3, 1);
    scene.add(light);
    return { key: v.key, scene: scene, groups: [], textures: {}, materials: {}, chunks: 0 };
  }

  function textureMaterial(view, page) {
    if (!view.materials[page]) {
      view.materials[page] = page < 0
        ? new THREE.MeshBasicMaterial({ color: 0x999999, side: THREE.DoubleSide })
        : new THREE.MeshBasicMaterial({ color: 0xffffff, side: THREE.DoubleSide, map: view.textures[page] || null });
    }
    return view.materials[page];
  }

  let colourMat = null, greyMat = null;  // shared by every chart / region mesh
  function colourMaterial(coloured) {
    if (!colourMat) {
      colourMat = new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide, flatShading: true });
      greyMat = new THREE.MeshLambertMaterial({ color: 0xaaaaaa, side: THREE.DoubleSide, flatShading: true });
    }
    return coloured ? colourMat : greyMat;
  }

  TD.texture = function (key, page, url) {
    const view = state.views[key];
    if (!view) return;
    const tex = new THREE.TextureLoader().load(url, requestRender, undefined, function () {
      state.errors.push('texture ' + key + '/' + page + ' failed to decode');
    });
    tex.colorSpace = THREE.SRGBColorSpace;
    tex.anisotropy = 4;
    view.textures[page] = tex;
    if (view.materials[page]) { view.materials[page].map = tex; view.materials[page].needsUpdate = true; }
  };

  TD.chunk = function (key, index, d) {
    const view = state.views[key];
    if (!view) return;
    const pos = decode(d.p, Float32Array), uv = decode(d.u, Float32Array), chart = decode(d.c, Int32Array);
    const region = d.r ? decode(d.r, Int32Array) : null;
    for (const [page, first, count] of d.groups) {
      const position = new THREE.BufferAttribute(pos.slice(first * 9, (first + count) * 9), 3);
      const gt = new THREE.BufferGeometry();
      gt.setAttribute('position', position);
      gt.setAttribute('uv', new THREE.BufferAttribute(uv.slice(first * 6, (first + count) * 6), 2));
      const colours = function (ids) {
        const c = new Float32Array(count * 9);
        for (let f = 0; f < count; ++f) {
          const rgb = idColour(ids[first + f]);
          for (let k = 0; k < 3; ++k) c.set(rgb, f * 9 + k * 3);
        }
        return new THREE.BufferAttribute(c, 3);
      };
      const gc = new THREE.BufferGeometry();
      gc.setAttribute('position', position);
      gc.setAttribute('color', colours(chart));
      gc.computeVertexNormals();
      const gr = new THREE.BufferGeometry();
      gr.setAttribute('position', position);
      gr.setAttribute('normal', gc.getAttribute('normal'));
      if (region) gr.setAttribute('color', colours(region));
      const g = {
        texture: new THREE.Mesh(gt, textureMaterial(view, page)),
        chart: new THREE.Mesh(gc, colourMaterial(true)),
        region: new THREE.Mesh(gr, colourMaterial(!!region)),  // grey: no detector
      };
      view.scene.add(g.texture, g.chart, g.region);
      view.groups.push(g);
    }
    view.chunks += 1;
    requestRender();
  };

  // Loads the scripts one after another; each calls TD.texture or TD.chunk when it runs.
  function loadScripts(list, progress, done) {
    let i = 0;
    function next() {
      if (i >= list.length) { done(); return; }
      const s = document.createElement('script');
      s.src = list[i];
      s.onload = function () { i += 1; progress(i, list.length); next(); };
      s.onerror = function () { state.errors.push('cannot load ' + list[i]); i += 1; next(); };
      document.head.appendChild(s);
    }
    next();
  }

  function showModel(id, mode) {
    const m = manifest.models.find(function (x) { return x.id === id; });
    if (!m) return;
    ensureRenderer();
    if (mode) setMode(mode);
    const section = document.getElementById('model-' + m.index);
    section.querySelector('.viewer-slot').appendChild(host);
    host.hidden = false;
    state.model = m;
    state.ready = false;
    for (const k of Object.keys(state.views)) delete state.views[k];
    const files = [];
    for (const v of m.views) {
      state.views[v.key] = newView(v);
      if (v.too_large) continue;
      for (let p = 0; p < v.pages; ++p) files.push('data/' + v.key + '_t' + p + '.js');
      for (let c = 0; c < v.chunks; ++c) files.push('data/' + v.key + '_g' + c + '.js');
    }
    resize(m);
    resetCamera(m);
    const tooLarge = m.views.filter(function (v) { return v.too_large; }).length;
    loadScripts(files, function (i, n) {
      status('loading ' + m.id + ': ' + i + ' / ' + n + ' files');
    }, function () {
      state.ready = true;
      status(m.id + ': ' + m.views.length + ' views loaded' +
        (tooLarge ? ' (' + tooLarge + ' too large to view in the browser)' : '') +
        (state.errors.length ? '; errors: ' + state.errors.join('; ') : ''));
      requestRender();
    });
  }

  function setMode(mode) {
    state.mode = mode;
    for (const b of document.querySelectorAll('#viewer-modes button'))
      b.classList.toggle('on', b.dataset.mode === mode);
    requestRender();
  }

  TD.showModel = showModel;
  TD.setMode = setMode;
  TD.render = render;
  TD.resetCamera = function () { if (state.model) { resetCamera(state.model); requestRender(); } };

  document.addEventListener('DOMContentLoaded', function () {
    // Thumbnails: the browser check's screenshots (thumbs/thumbs.js lists them).
    for (const a of document.querySelectorAll('nav.models a[data-model]')) {
      const t = (TD.thumbs || {})[a.dataset.model];
      if (!t) continue;
      const img = document.createElement('img');
      img.src = 'thumbs/' + t;
      img.alt = '';
      a.insertBefore(img, a.firstChild);
    }
    for (const b of document.querySelectorAll('#viewer-modes button'))
      b.addEventListener('click', function () { setMode(b.dataset.mode); });
    document.getElementById('viewer-reset').addEventListener('click', TD.resetCamera);
    for (const b of document.querySelectorAll('button.open-viewer'))
      b.addEventListener('click', function () { showModel(b.dataset.model); });
    if (typeof THREE === 'undefined') { status('three.js did not load (lib/three.js)'); return; }
    const params = new URLSearchParams(location.hash.slice(1));
    const first = manifest.models.length ? manifest.models[0].id : null;
    const id = params.get('model') || first;
    if (id) showModel(id, params.get('mode') || 'texture');
  });
})();
